// The apps' 3D front end: reference surface or volume -> voxels -> surfels -> normals -> areas.
#pragma once

#include "options.hpp"
#include "progress.hpp"

#include "digilap/surface/measures.hpp"
#include "digilap/surface/shapes.hpp"

#include <memory>
#include <string>

namespace digilap::app {

/// Everything before a surface's operator (SPEC §7): a reference surface (--shape sphere,
/// ellipsoid, torus with parameters; --rotate about z, --centre X,Y) digitized at h (default
/// 0.05), or a .npy volume (--volume, --label); surfels, II normals (k_R: the surfaces' default
/// 1 unless --kR is given), areas.
struct SurfaceFrontEnd {
  std::unique_ptr<surface::Surface> shape;  // null for a volume
  std::string name;
  surface::VoxelSet voxels;
  surface::SurfelSet surfels;
  surface::SurfelNormals normals;
  surface::SurfelMeasures measures;
  std::size_t dropped_surfaces = 0;  // by --largest or --min-size
};
SurfaceFrontEnd run_surface_front_end(const FrontEndOptions& options, Progress& progress);
/// The same from voxels already read (one structure of a segmentation); `started`: the caller
/// has a progress stage open that this one finishes.
SurfaceFrontEnd surface_front_end(surface::VoxelSet voxels, const std::string& name, const FrontEndOptions& options,
                                  Progress& progress, bool started = false, const surface::Surface* shape = nullptr);

}  // namespace digilap::app
