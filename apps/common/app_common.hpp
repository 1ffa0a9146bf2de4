// Shared by the command-line apps: options of the pipeline, stage timing, progress on stderr.
#pragma once

#include "digilap/digilap.hpp"
#include "digilap/surface/measures.hpp"

#include <CLI/CLI.hpp>

#include <chrono>
#include <memory>
#include <string>

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
/// "" when the contours share one heat time, else a note with the range of their own times.
/// --kR as given, or the default of the dimension's II normals (curves 2, surfaces 1: two
/// studies, normals.hpp and surface/normals.hpp) when it was not.
double ii_k_R(double given, int dimension);

std::string per_contour_note(const std::vector<double>& contour_t);

/// Progress and stage timing on stderr; silent with --quiet.
class Progress {
public:
  explicit Progress(bool quiet) : quiet_(quiet) {}
  bool quiet() const { return quiet_; }
  /// Starts a stage ("normals"); finish() prints its time.
  void start(const std::string& stage);
  double finish();
  /// A progress bar for long loops: "label [#####.....]  42%".
  void bar(const std::string& label, double fraction);
  void end_bar();

private:
  bool quiet_;
  std::string stage_;
  std::chrono::steady_clock::time_point t0_;
};

struct FrontEnd {
  std::unique_ptr<Shape> shape;  // null for an image
  std::string name;              // the shape's name or the image's file name
  double exact_length = 0.0;     // the curve's length; NaN for an image (no exact curve)
  DigitalSet set;
  ContourSet contours;
  LinelNormals normals;
  Measures measures;
  double seconds_digitize = 0, seconds_contours = 0, seconds_normals = 0, seconds_measures = 0;
};

/// Shape or image -> digital set -> contours -> normals -> measures, timed stage by stage.
FrontEnd run_front_end(const FrontEndOptions& options, Progress& progress);

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
bool is_surface_input(const FrontEndOptions& options);
SurfaceFrontEnd run_surface_front_end(const FrontEndOptions& options, Progress& progress);
/// The same from voxels already read (one structure of a segmentation); `started`: the caller
/// has a progress stage open that this one finishes.
SurfaceFrontEnd surface_front_end(surface::VoxelSet voxels, const std::string& name, const FrontEndOptions& options,
                                  Progress& progress, bool started = false, const surface::Surface* shape = nullptr);
/// After parsing: refuses, with the reason, an option given explicitly that the input does not
/// use (--distance, --placement and --invert on surfaces and volumes, --normals exact on images
/// and volumes, --couple-surfaces on curves) rather than ignoring it (issue 25).
void check_options_for_input(const CLI::App& app, const FrontEndOptions& options);

/// The heat Laplacian of the front end's contours, timed as the stage "operator".
ContourOperator build_operator(const FrontEnd& fe, const HeatLaplacianOptions& options, Progress& progress);

/// --out DIR and --quiet, shared by every app.
void add_output_options(CLI::App& app, std::string& out_dir, bool& quiet);

/// Runs `body`, turning digilap::Error and std::exception into "error: ..." and exit code 1.
int guarded_main(const std::function<int()>& body);

}  // namespace digilap::app
