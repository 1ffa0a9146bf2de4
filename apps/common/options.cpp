#include "options.hpp"

#include "digilap/surface/shapes.hpp"

#include <algorithm>
#include <cmath>
#include <string>

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
                     "digilap-spectrum also takes the surfaces (SPEC 7):\n" + surface::surface_syntax())
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
  app.add_option("--kR", o.k_R, "II radius constant: R = kR h^(1/3) l^(2/3)")->check(kPositiveFinite)->default_str("2 (curves), 1 to 1.5 by l / h (surfaces)");
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

void add_surface_kernel_option(CLI::App& app, SurfaceKernel& kernel) {
  const std::map<std::string, SurfaceKernel> kernels{{"chord", SurfaceKernel::Chord}, {"intrinsic", SurfaceKernel::Intrinsic}};
  app.add_option("--surface-kernel", kernel,
                 "Surfaces: the kernel's distance, chord (|x_i - x_j|) or intrinsic (tangent-plane chord plus the geodesic "
                 "term from the normals, weights corrected for the Gaussian curvature)")
      ->transform(CLI::CheckedTransformer(kernels, CLI::ignore_case).description(""))
      ->type_name("{chord,intrinsic}")
      ->default_str(kernel == SurfaceKernel::Chord ? "chord" : "intrinsic");
}

void add_operator_options(CLI::App& app, HeatLaplacianOptions& o) {
  app.add_option("--t", o.t, "Heat time t (0: ct h^(2/3) l^(4/3), l the length scale)")->capture_default_str();
  app.add_option("--ct", o.c_t, "Constant of the default heat time t = ct h^(2/3) l^(4/3) (spectra of smooth "
                 "surfaces: 0.05 is as accurate in less time, docs/accuracy.md)")->check(kPositiveFinite)->capture_default_str();
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
  add_surface_kernel_option(app, o.surface_kernel);
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

bool is_surface_input(const FrontEndOptions& o) {
  const std::string name = o.shape.substr(0, o.shape.find(':'));
  const std::vector<std::string> surfaces = surface::surface_names();
  return !o.volume.empty() || std::find(surfaces.begin(), surfaces.end(), name) != surfaces.end();
}

void check_options_for_input(const CLI::App& app, const FrontEndOptions& o) {
  auto given = [&](const char* name) { return app.get_option_no_throw(name) != nullptr && app.count(name) > 0; };
  if (is_surface_input(o)) {
    const char* what = o.volume.empty() ? "a surface" : "a volume";
    if (given("--distance"))
      throw Error(std::string("--distance is for curves: on ") + what +
                  " the kernel's distance is --surface-kernel's (chord or intrinsic), between the surfels of one connected "
                  "surface (--couple-surfaces extends it across surfaces)");
    if (given("--placement")) throw Error(std::string("--placement is for curves (pointels or linels): ") + what + " has surfels only");
    if (given("--invert")) throw Error("--invert is for images: choose a volume's object with --label or --threshold");
    if (o.normals == "exact" && !o.volume.empty())
      throw Error("--normals exact needs a reference surface (--shape sphere, ellipsoid or torus): a volume has no exact surface");
  } else if (given("--couple-surfaces")) {
    throw Error("--couple-surfaces is for surfaces and volumes (curves: --distance euclidean couples the contours)");
  } else if (given("--surface-kernel")) {
    throw Error("--surface-kernel is for surfaces and volumes (curves: --distance geodesic or euclidean)");
  }
}

void add_output_options(CLI::App& app, std::string& out_dir, bool& quiet) {
  app.add_option("--out", out_dir, "Output directory")->capture_default_str();
  app.add_flag("--quiet,-q", quiet, "No progress on stderr");
}

}  // namespace digilap::app
