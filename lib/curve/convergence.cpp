#include "digilap/curve/convergence.hpp"

#include "digilap/core/error.hpp"
#include "digilap/curve/measures.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

namespace digilap {
inline namespace curve {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

std::vector<std::string> operator_variant_names() {
  return {"geodesic",   "euclidean", "geodesic-exact", "euclidean-exact", "dgtal", "richardson-geodesic",
          "richardson-euclidean", "dec-naive", "dec-mu"};
}

OperatorVariant operator_variant(const std::string& name, const HeatLaplacianOptions& base) {
  OperatorVariant v;
  v.name = name;
  v.heat = base;
  v.heat.richardson = false;
  v.heat.placement = Placement::Pointels;
  if (name == "geodesic" || name == "geodesic-exact" || name == "richardson-geodesic") {
    v.heat.distance = DistanceMode::Geodesic;
  } else if (name == "euclidean" || name == "euclidean-exact" || name == "richardson-euclidean") {
    v.heat.distance = DistanceMode::Euclidean;
  } else if (name == "dgtal") {
    v.heat.distance = DistanceMode::Euclidean;
    v.heat.placement = Placement::Linels;
  } else if (name == "dec-naive") {
    v.kind = OperatorVariant::Kind::DecNaive;
  } else if (name == "dec-mu") {
    v.kind = OperatorVariant::Kind::DecCorrected;
  } else {
    std::string known;
    for (const auto& n : operator_variant_names()) known += (known.empty() ? "" : ", ") + n;
    throw Error("unknown operator '" + name + "' (known: " + known + ")");
  }
  v.exact_normals = name.size() > 6 && name.compare(name.size() - 6, 6, "-exact") == 0;
  v.heat.richardson = name.compare(0, 10, "richardson") == 0;
  return v;
}

std::vector<ConvergenceRow> ConvergenceResult::of(const std::string& variant) const {
  std::vector<ConvergenceRow> out;
  for (const auto& r : rows)
    if (r.variant == variant) out.push_back(r);
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.h > b.h; });
  return out;
}

double ConvergenceResult::slope(const std::string& variant, std::size_t finest) const {
  const auto r = of(variant);
  const std::size_t first = (finest == 0 || finest >= r.size()) ? 0 : r.size() - finest;
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int n = 0;
  for (std::size_t i = first; i < r.size(); ++i) {
    if (!(r[i].relative_max_error > 0)) continue;
    const double x = std::log(r[i].h), y = std::log(r[i].relative_max_error);
    sx += x, sy += y, sxx += x * x, sxy += x * y, ++n;
  }
  if (n < 2) return std::nan("");
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

ConvergenceResult convergence_sweep(const Shape& shape, const TestFunction& f, const ConvergenceOptions& o) {
  if (o.steps.empty()) throw Error("convergence_sweep: the list of grid steps is empty");
  if (o.variants.empty()) throw Error("convergence_sweep: the list of operators is empty");
  ConvergenceResult result;
  const double total = static_cast<double>(o.steps.size() * o.variants.size());
  std::size_t done = 0;
  for (double h : o.steps) {
    auto t0 = std::chrono::steady_clock::now();
    const DigitalSet set = digitize(shape, h);
    if (set.empty()) throw Error("convergence_sweep: the digitization at h = " + std::to_string(h) + " is empty");
    const ContourSet contours = track_contours(set);
    const bool need_ii = std::any_of(o.variants.begin(), o.variants.end(), [](const auto& v) { return !v.exact_normals; });
    const bool need_exact = std::any_of(o.variants.begin(), o.variants.end(), [](const auto& v) { return v.exact_normals; });
    Measures mu_ii, mu_exact;
    if (need_ii) mu_ii = measures(contours, ii_normals(set, contours, o.ii));
    // The same l for both, so that they lead to the same t.
    if (need_exact) mu_exact = measures(contours, exact_normals(shape, contours, need_ii ? mu_ii.length_scale : o.ii.length_scale));
    const double front_end = seconds_since(t0);
    // Exact values at the closest points, per placement (pointels and linels differ).
    std::map<int, std::pair<Eigen::VectorXd, Eigen::VectorXd>> truth;
    for (const auto& v : o.variants) {
      const Measures& mu = v.exact_normals ? mu_exact : mu_ii;
      t0 = std::chrono::steady_clock::now();
      const ContourOperator op =  // one expression: the operator is elided, never copied
          v.kind == OperatorVariant::Kind::Heat
              ? heat_laplacian(contours, mu, v.heat)
              : dec_laplacian(contours, mu, v.kind == OperatorVariant::Kind::DecNaive ? DecLengths::Naive : DecLengths::Corrected);
      ConvergenceRow row;
      row.seconds_assembly = seconds_since(t0);
      t0 = std::chrono::steady_clock::now();
      const int key = static_cast<int>(op.placement);
      if (!truth.count(key)) {
        const Eigen::VectorXd theta = sample_parameters(shape, op.positions, o.sampling);
        truth[key] = {sample_values(shape, f, theta), sample_laplacian(shape, f, theta)};
      }
      const auto& [g, lap] = truth[key];
      const Eigen::VectorXd err = (op.L * g - lap).cwiseAbs();
      row.h = h;
      row.variant = v.name;
      row.elements = op.rows();
      row.nonzeros = op.L.nonZeros();
      row.t = op.t;
      row.length_scale = mu.length_scale;
      row.max_error = err.maxCoeff();
      row.mean_error = err.mean();
      row.relative_max_error = row.max_error / lap.cwiseAbs().maxCoeff();
      row.length_estimate = mu.total_length();
      row.length_exact = shape.length();
      row.seconds_front_end = front_end;
      row.seconds_evaluation = seconds_since(t0);
      result.rows.push_back(row);
      if (o.progress) o.progress(static_cast<double>(++done) / total);
    }
  }
  return result;
}

}  // namespace curve
}  // namespace digilap
