// The apps' command-line options of the pipeline (CLI11), checked against the input they are
// given to.
#pragma once

#include "digilap/digilap.hpp"
#include "digilap/surface/normals.hpp"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace digilap::app {

/// Everything before the operator: which shape or image, at which h, with which normals.
struct FrontEndOptions {
  std::string shape = "flower";
  std::string image;            // a PBM/PGM/PNG file instead of a shape
  std::string volume;           // a 3-D .npy file (digilap-spectrum): a surface from voxels
  std::int64_t label = -1;      // volumes: foreground = this label (else every non-zero voxel)
  double rotate_degrees = 0.0;  // pose of the shape
  std::vector<double> centre;   // empty, or x, y
  double h = 0.0;               // 0: 0.01 for shapes, 1 / max(width, height) for images
  /// II radius constant; 0 (not given): each dimension's default (ii_k_R()).
  double k_R = 0;
  double length_scale = 0.0;   // l of R and t; 0 = measured on the set (length_scale.hpp)
  double length_quantile = IINormalOptions{}.length_quantile;
  std::string normals = "ii";   // "ii" (Integral Invariants) or "exact" (reference shapes only)
  double threshold = 0.5;       // images: foreground = value < threshold * maxval ...
  bool threshold_given = false; // volumes without --label: foreground = value >= threshold when given, else >= 1
  bool invert = false;          // ... or >= with --invert
  bool largest = false;         // images: keep the largest contour only
  std::size_t min_linels = 8;   // images: drop contours with fewer linels (with a warning)
};

void add_front_end_options(CLI::App& app, FrontEndOptions& options, bool with_h = true);
void add_operator_options(CLI::App& app, HeatLaplacianOptions& options);
/// --surface-kernel {chord,intrinsic} (part of add_operator_options; the distributed app's own).
void add_surface_kernel_option(CLI::App& app, SurfaceKernel& kernel);
/// --kR as given, or the default of the dimension's II normals (curves 2, surfaces 1: two
/// studies, normals.hpp and surface/normals.hpp) when it was not.
double ii_k_R(double given, int dimension);
/// "" when the contours share one heat time, else a note with the range of their own times.
std::string per_contour_note(const std::vector<double>& contour_t);

/// A reference surface (--shape sphere, ellipsoid, torus) or a volume: the surface front end.
bool is_surface_input(const FrontEndOptions& options);

/// After parsing: refuses, with the reason, an option given explicitly that the input does not
/// use (--distance, --placement and --invert on surfaces and volumes, --normals exact on images
/// and volumes, --couple-surfaces on curves) rather than ignoring it (issue 25).
void check_options_for_input(const CLI::App& app, const FrontEndOptions& options);

/// --out DIR and --quiet, shared by every app.
void add_output_options(CLI::App& app, std::string& out_dir, bool& quiet);

}  // namespace digilap::app
