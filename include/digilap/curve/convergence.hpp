// digilap — multigrid convergence experiments: the error of an operator against the exact
// Laplace-Beltrami operator as h -> 0 (the paper's Fig. 5, SPEC §5).
#pragma once

#include "digilap/curve/ground_truth.hpp"
#include "digilap/curve/heat_laplacian.hpp"
#include "digilap/curve/normals.hpp"

#include <functional>
#include <string>
#include <vector>

namespace digilap {
inline namespace curve {

/// One operator of the comparison.
struct OperatorVariant {
  enum class Kind { Heat, DecNaive, DecCorrected };
  std::string name;
  Kind kind = Kind::Heat;
  HeatLaplacianOptions heat;   // for Kind::Heat
  bool exact_normals = false;  // measures from the exact normals instead of II ones
};

/// Known variant names, built on `base` (t, c_t, k of the heat variants):
///   geodesic, euclidean          heat Laplacian on pointels, II normals
///   geodesic-exact, euclidean-exact   the same with exact normals (operator error alone)
///   dgtal                         Euclidean on linel midpoints (DGtal's dual heat Laplacian)
///   richardson-geodesic, richardson-euclidean   2 L_{t/2} - L_t
///   dec-naive, dec-mu             DEC baselines with lengths h and mu
OperatorVariant operator_variant(const std::string& name, const HeatLaplacianOptions& base = {});
std::vector<std::string> operator_variant_names();

struct ConvergenceOptions {
  std::vector<double> steps{0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001};
  IINormalOptions ii;
  Sampling sampling = Sampling::ClosestPoint;
  std::vector<OperatorVariant> variants;
  /// Called with the fraction done (0..1) after each (h, variant); may be empty.
  std::function<void(double)> progress;
};

struct ConvergenceRow {
  double h = 0;
  std::string variant;
  Eigen::Index elements = 0, nonzeros = 0;
  double t = 0;
  double length_scale = 0;  // l of the measures (the default t and R follow from it)
  double max_error = 0, mean_error = 0, relative_max_error = 0;  // relative to max |Delta g|
  double length_estimate = 0, length_exact = 0;
  double seconds_front_end = 0;  // digitization + contours + normals + measures (shared by variants)
  double seconds_assembly = 0, seconds_evaluation = 0;
};

struct ConvergenceResult {
  std::vector<ConvergenceRow> rows;  // h-major, variants in the given order
  /// Rows of one variant, by decreasing h.
  std::vector<ConvergenceRow> of(const std::string& variant) const;
  /// Least-squares slope of log(relative max error) vs log(h): over all steps, or over the
  /// `finest` smallest ones (0 = all).
  double slope(const std::string& variant, std::size_t finest = 0) const;
};

/// Runs the sweep: for each h, the front end once, then every variant, its error on f.
/// Throws digilap::Error for an empty or invalid list of steps or variants.
ConvergenceResult convergence_sweep(const Shape& shape, const TestFunction& f, const ConvergenceOptions& options);

}  // namespace curve
}  // namespace digilap
