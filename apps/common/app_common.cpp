#include "app_common.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/surface/length_scale.hpp"
#include "digilap/surface/volume.hpp"

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>

namespace digilap::app {

namespace {
// A number that must be > 0 and finite (NaN and infinities spelled out are refused too).
const CLI::Validator kPositiveFinite(
    [](std::string& text) {
      double v = 0;
      try {
        v = std::stod(text);
      } catch (...) {
        return std::string("must be a number, got '") + text + "'";
      }
      if (!(v > 0) || !std::isfinite(v)) return std::string("must be > 0 and finite, got ") + text;
      return std::string();
    },
    "POSITIVE");
}  // namespace

void add_front_end_options(CLI::App& app, FrontEndOptions& o, bool with_h) {
  app.add_option("--shape", o.shape,
                 "Reference shape, with its own parameters after a colon (keys not given keep these defaults):\n" +
                     shape_syntax() + "e.g. --shape flower:R=1.5,v=0.3,k=4\n"
                     "digilap-spectrum also takes the surfaces sphere:r=1, ellipsoid:a=1.2,b=1,c=0.8, torus:R=1,r=0.4 (SPEC 7)")
      ->capture_default_str();
  app.add_option("--rotate", o.rotate_degrees, "Rotate the shape by this angle (degrees, counter-clockwise)")
      ->capture_default_str();
  app.add_option("--centre", o.centre, "Move the shape's centre to X,Y")->delimiter(',')->expected(2);
  app.add_option("--image", o.image, "Binary image instead of a shape: PBM, PGM (8/16 bit) or PNG");
  app.add_option("--volume", o.volume, "A 3-D volume instead of a shape: .npy (bool, uint8, uint16) or NIfTI .nii/.nii.gz (cubic voxels; h defaults to the file's spacing)");
  app.add_option("--label", o.label, "Volumes: the label of the object (default: every voxel >= --threshold, 1)")
      ->check(CLI::NonNegativeNumber);
  if (with_h)
    app.add_option("--h", o.h, "Grid step h (default: 0.01 for shapes, 1/max(width, height) for images)")
        ->check(kPositiveFinite);
  app.add_option("--threshold", o.threshold,
                 "Images: foreground = value < threshold * maxval; volumes without --label: value >= threshold (default 1)")
      ->each([&o](const std::string&) { o.threshold_given = true; })
      ->capture_default_str();
  app.add_flag("--invert", o.invert, "Images: foreground = value >= threshold * maxval (light objects)");
  app.add_flag("--largest", o.largest, "Images and volumes: keep the largest contour (surface) only");
  app.add_option("--min-size,--min-linels", o.min_linels,
                 "Images and volumes: drop contours with fewer linels, surfaces with fewer surfels")
      ->capture_default_str();
  app.add_option("--kR", o.k_R, "II radius constant: R = kR h^(1/3) l^(2/3)")->check(kPositiveFinite)->default_str("2 (curves), 1 (surfaces)");
  app.add_option("--length-scale", o.length_scale,
                 "Length scale l of R and of the default t (0: measured on the shape's pixels, a robust small "
                 "radius of curvature; 1: the former R = kR h^(1/3), t = ct h^(2/3))")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--length-quantile", o.length_quantile, "Which quantile of the radii of curvature a measured l is")
      ->check(CLI::Range(1e-6, 1.0 - 1e-6))
      ->capture_default_str();
  app.add_option("--normals", o.normals, "Normals for the measures: ii (estimated) or exact (from the curve)")
      ->check(CLI::IsMember({"ii", "exact"}))
      ->capture_default_str();
}

void add_operator_options(CLI::App& app, HeatLaplacianOptions& o) {
  app.add_option("--t", o.t, "Heat time t (0: ct h^(2/3) l^(4/3), l the length scale)")->capture_default_str();
  app.add_option("--ct", o.c_t, "Constant of the default heat time t = ct h^(2/3) l^(4/3)")->check(kPositiveFinite)->capture_default_str();
  app.add_option("--k", o.k, "Kernel cut at k * sqrt(t)")->check(kPositiveFinite)->capture_default_str();
  const std::map<std::string, DistanceMode> distances{{"geodesic", DistanceMode::Geodesic},
                                                      {"euclidean", DistanceMode::Euclidean}};
  const std::map<std::string, Placement> placements{{"pointels", Placement::Pointels},
                                                    {"linels", Placement::Linels}};
  app.add_option("--distance", o.distance, "geodesic (along the contour) or euclidean")
      ->transform(CLI::CheckedTransformer(distances, CLI::ignore_case).description(""))
      ->type_name("{geodesic,euclidean}")
      ->default_str("geodesic");
  app.add_option("--placement", o.placement, "pointels (vertices) or linels (linel midpoints)")
      ->transform(CLI::CheckedTransformer(placements, CLI::ignore_case).description(""))
      ->type_name("{pointels,linels}")
      ->default_str("pointels");
  app.add_option("--memory-limit", o.memory_limit_bytes, "Refuse operators estimated larger than this many bytes")
      ->check(CLI::Validator(
          [](std::string& text) {
            const double v = std::strtod(text.c_str(), nullptr);
            return v > 0 ? std::string() : "--memory-limit must be a number of bytes > 0 (inf for none), got " + text;
          },
          "BYTES > 0"))
      ->capture_default_str();
  app.add_flag("--one-heat-time{false}", o.per_contour_time,
               "One t for all contours (surfaces), from the set's l (default: each contour's (surface's) own l_c)");
  app.add_flag("--couple-surfaces", o.couple_surfaces,
               "Surfaces: kernel weights between every pair of surfels within the cut, across connected surfaces "
               "(ambient coupling: one zero eigenvalue for the set; default: each surface its own operator)");
}

double ii_k_R(double given, int dimension) {
  if (given > 0) return given;
  return dimension == 1 ? IINormalOptions{}.k_R : surface::SurfaceNormalOptions{}.k_R;
}

std::string per_contour_note(const std::vector<double>& contour_t) {
  if (contour_t.size() < 2) return "";
  const auto [lo, hi] = std::minmax_element(contour_t.begin(), contour_t.end());
  if (*lo == *hi) return "";
  char text[96];
  std::snprintf(text, sizeof text, " (the largest contour's; one per contour, %.4g to %.4g)", *lo, *hi);
  return text;
}

void Progress::start(const std::string& stage) {
  stage_ = stage;
  t0_ = std::chrono::steady_clock::now();
  if (!quiet_) std::fprintf(stderr, "  %-12s ...", stage.c_str()), std::fflush(stderr);
}

double Progress::finish() {
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  if (!quiet_) std::fprintf(stderr, " %8.3f s\n", s);
  return s;
}

void Progress::bar(const std::string& label, double fraction) {
  if (quiet_) return;
  const int width = 30, filled = static_cast<int>(fraction * width + 0.5);
  std::fprintf(stderr, "\r%s [%s%s] %3d%%", label.c_str(), std::string(filled, '#').c_str(),
               std::string(width - filled, '.').c_str(), static_cast<int>(100 * fraction + 0.5));
  std::fflush(stderr);
}

void Progress::end_bar() {
  if (!quiet_) std::fprintf(stderr, "\n");
}

FrontEnd run_front_end(const FrontEndOptions& o, Progress& progress) {
  FrontEnd fe;
  ContourFilter filter;
  if (o.image.empty()) {
    fe.shape = make_shape(o.shape);
    if (!std::isfinite(o.rotate_degrees)) throw Error("--rotate must be a finite angle in degrees");
    if (o.rotate_degrees != 0 || !o.centre.empty())
      fe.shape->set_pose(o.centre.empty() ? Eigen::Vector2d::Zero() : Eigen::Vector2d(o.centre[0], o.centre[1]),
                         o.rotate_degrees * kPi / 180);
    fe.name = fe.shape->name();
    fe.exact_length = fe.shape->length();
    const double h = o.h == 0 ? 0.01 : o.h;
    progress.start("digitize");
    fe.set = digitize(*fe.shape, h);
    fe.seconds_digitize = progress.finish();
    if (fe.set.empty()) throw Error("the digitization at h = " + std::to_string(h) + " is empty: use a smaller h");
  } else {
    if (o.normals == "exact") throw Error("--normals exact needs a reference shape: an image has no exact curve");
    fe.name = std::filesystem::path(o.image).filename().string();
    fe.exact_length = std::nan("");
    progress.start("read image");
    const GrayImage image = read_image(o.image);
    fe.set = binarize(image, BinarizeOptions{o.h, o.threshold, o.invert});
    fe.seconds_digitize = progress.finish();
    if (fe.set.empty())
      throw Error(o.image + ": no foreground pixel (all values are " + (o.invert ? "below" : "at or above") +
                  " the threshold); try --invert or another --threshold");
    filter.min_linels = o.min_linels;
    filter.largest_only = o.largest;
  }
  progress.start("contours");
  FilteredContours kept = filter_contours(track_contours(fe.set), filter);
  fe.contours = std::move(kept.contours);
  fe.seconds_contours = progress.finish();
  if (kept.dropped > 0 && !progress.quiet())
    std::fprintf(stderr, "warning: dropped %zu contour(s)%s\n", kept.dropped,
                 o.largest ? " (keeping the largest only)" : (" shorter than " + std::to_string(o.min_linels) + " linels").c_str());
  if (fe.contours.contours.empty()) throw Error("no contour left (all shorter than --min-linels)");
  progress.start("normals");
  fe.normals = o.normals == "exact" ? exact_normals(*fe.shape, fe.contours, o.length_scale)
                                    : ii_normals(fe.set, fe.contours, IINormalOptions{ii_k_R(o.k_R, 1), o.length_scale, o.length_quantile});
  fe.seconds_normals = progress.finish();
  progress.start("measures");
  fe.measures = measures(fe.contours, fe.normals);
  fe.seconds_measures = progress.finish();
  if (!progress.quiet())
    std::fprintf(stderr, "length scale l = %.6g%s, II radius R = %.6g\n", fe.measures.length_scale,
                 o.length_scale > 0 ? " (given)" : " (measured)", fe.measures.normal_radius);
  if (fe.measures.clamped > 0 && !progress.quiet())
    std::fprintf(stderr, "warning: %zu linels got mu = 0 (normal orthogonal to the linel); k_R may be too large\n",
                 fe.measures.clamped);
  return fe;
}

bool is_surface_input(const FrontEndOptions& o) {
  const std::string name = o.shape.substr(0, o.shape.find(':'));
  return !o.volume.empty() || name == "sphere" || name == "ellipsoid" || name == "torus";
}

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

void check_options_for_input(const CLI::App& app, const FrontEndOptions& o) {
  auto given = [&](const char* name) { return app.get_option_no_throw(name) != nullptr && app.count(name) > 0; };
  if (is_surface_input(o)) {
    const char* what = o.volume.empty() ? "a surface" : "a volume";
    if (given("--distance"))
      throw Error(std::string("--distance is for curves: on ") + what +
                  " the kernel takes the Euclidean distance between the surfels of one connected surface "
                  "(--couple-surfaces extends it across surfaces)");
    if (given("--placement")) throw Error(std::string("--placement is for curves (pointels or linels): ") + what + " has surfels only");
    if (given("--invert")) throw Error("--invert is for images: choose a volume's object with --label or --threshold");
    if (o.normals == "exact" && !o.volume.empty())
      throw Error("--normals exact needs a reference surface (--shape sphere, ellipsoid or torus): a volume has no exact surface");
  } else if (given("--couple-surfaces")) {
    throw Error("--couple-surfaces is for surfaces and volumes (curves: --distance euclidean couples the contours)");
  }
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
    LengthScale measured;
    if (o.length_scale == 0) measured = surface::length_scale(fe.voxels, fe.surfels, {LengthScaleOptions{}.k_R, o.length_quantile});
    fe.normals = surface::exact_normals(*shape, fe.surfels, o.length_scale > 0 ? o.length_scale : measured.length);
    fe.normals.surface_length_scales = measured.per_contour;
    for (double& l_c : fe.normals.surface_length_scales)
      if (!(l_c > 0)) l_c = fe.normals.length_scale;
  } else {
    fe.normals = surface::ii_normals(fe.voxels, fe.surfels, {ii_k_R(o.k_R, 2), o.length_scale, o.length_quantile});
  }
  progress.finish();
  fe.measures = surface::measures(fe.surfels, fe.normals);
  if (!progress.quiet())
    std::fprintf(stderr, "length scale l = %.6g, II radius R = %.6g\n", fe.measures.length_scale, fe.measures.normal_radius);
  return fe;
}

ContourOperator build_operator(const FrontEnd& fe, const HeatLaplacianOptions& options, Progress& progress) {
  progress.start("operator");
  ContourOperator op = heat_laplacian(fe.contours, fe.measures, options);
  progress.finish();
  return op;
}

void add_output_options(CLI::App& app, std::string& out_dir, bool& quiet) {
  app.add_option("--out", out_dir, "Output directory")->capture_default_str();
  app.add_flag("--quiet,-q", quiet, "No progress on stderr");
}

int guarded_main(const std::function<int()>& body) {
  try {
    return body();
  } catch (const Error& e) {
    std::cerr << "error: " << e.what() << "\n";
  } catch (const std::bad_alloc&) {
    // Which parameter helps depends on the stage (a smaller t shrinks the explicit operator but
    // not the matrix-free one): the estimates before each big allocation say; this is the rest.
    std::cerr << "error: out of memory: the machine could not provide what this run asked for; "
                 "use a coarser h or fewer eigenpairs, or set --memory-limit to have sizes checked first\n";
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
  }
  return 1;
}

}  // namespace digilap::app
