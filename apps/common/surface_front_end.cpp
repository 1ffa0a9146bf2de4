#include "surface_front_end.hpp"

#include "digilap/core/constants.hpp"
#include "digilap/surface/length_scale.hpp"
#include "digilap/surface/volume.hpp"

#include <cstdio>
#include <filesystem>

namespace digilap::app {

SurfaceFrontEnd run_surface_front_end(const FrontEndOptions& o, Progress& progress) {
  progress.start(o.volume.empty() ? "digitize + surfels" : "read volume + surfels");
  std::unique_ptr<surface::Surface> shape;
  surface::VoxelSet voxels;
  std::string name;
  if (o.volume.empty()) {
    shape = surface::make_surface(o.shape);
    if (o.rotate_degrees != 0 || !o.centre.empty())
      shape->set_pose(o.centre.empty() ? Eigen::Vector3d::Zero() : Eigen::Vector3d(o.centre[0], o.centre[1], 0),
                      Eigen::AngleAxisd(o.rotate_degrees * kPi / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix());
    voxels = surface::digitize(*shape, o.h > 0 ? o.h : 0.05);
    name = shape->name();
  } else {
    surface::VolumeOptions vo;
    vo.h = o.h;
    vo.label = o.label;
    if (o.threshold_given) vo.threshold = o.threshold;
    voxels = surface::read_volume(o.volume, vo);
    name = std::filesystem::path(o.volume).filename().string();
  }
  SurfaceFrontEnd fe = surface_front_end(std::move(voxels), name, o, progress, true, shape.get());
  fe.shape = std::move(shape);
  return fe;
}

SurfaceFrontEnd surface_front_end(surface::VoxelSet voxels, const std::string& name, const FrontEndOptions& o, Progress& progress,
                                  bool started, const surface::Surface* shape) {
  if (!started) progress.start("surfels");
  SurfaceFrontEnd fe;
  fe.voxels = std::move(voxels);
  fe.name = name;
  // The connected surfaces, filtered as contours are: --largest, and --min-size in surfels.
  surface::FilteredSurfels kept = surface::filter_surfels(fe.voxels, surface::extract_surfels(fe.voxels), {o.min_linels, o.largest});
  fe.surfels = std::move(kept.surfels);
  fe.dropped_surfaces = kept.dropped;
  progress.finish();
  if (kept.dropped > 0 && !progress.quiet())
    std::fprintf(stderr, "warning: dropped %zu surface(s)%s\n", kept.dropped,
                 o.largest ? " (keeping the largest only)" : (" with fewer than " + std::to_string(o.min_linels) + " surfels").c_str());
  if (fe.surfels.size() == 0 && kept.dropped > 0)
    throw Error("every surface has fewer than " + std::to_string(o.min_linels) + " surfels: lower --min-size");
  if (fe.surfels.size() == 0) throw Error("the digitization is empty: use a smaller h");
  progress.start("normals");
  if (o.normals == "exact") {
    if (shape == nullptr) throw Error("--normals exact needs a reference surface (--shape sphere, ellipsoid or torus)");
    // The exact normals of the shape at the closest point of each surfel centre; l as given, or
    // measured on the voxels as the II normals would (it sets t).
    fe.normals = surface::exact_normals(*shape, fe.voxels, fe.surfels, {ii_k_R(o.k_R, 2), o.length_scale, o.length_quantile});
  } else {
    fe.normals = surface::ii_normals(fe.voxels, fe.surfels, {ii_k_R(o.k_R, 2), o.length_scale, o.length_quantile});
  }
  progress.finish();
  fe.measures = surface::measures(fe.surfels, fe.normals);
  if (!progress.quiet())
    std::fprintf(stderr, "length scale l = %.6g, II radius R = %.6g\n", fe.measures.length_scale, fe.measures.normal_radius);
  return fe;
}

}  // namespace digilap::app
