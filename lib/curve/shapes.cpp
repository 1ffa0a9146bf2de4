#include "digilap/curve/shapes.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/core/error.hpp"
#include "core/shape_parameters.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <charconv>
#include <map>
#include <set>
#include <sstream>

namespace digilap {
inline namespace curve {

namespace {

// Samples of the curve for the closest-point search and for the digitization. 2^15 samples keep
// the sample spacing (about 2e-3 on the reference shapes) far below the smallest radius of
// curvature (0.04 on the sharpest accflower), so the nearest sample lies in the right basin.
constexpr int kSampleCount = 1 << 15;
// Largest turn of the tangent between two consecutive samples. The digitization splits the
// curve at the sign changes of y' seen by the samples, and the closest-point search starts
// from the nearest sample: both assume the curve is resolved. The reference shapes turn by at
// most 0.016 rad per sample (the sharpest accflower), Flower(2, 0.5, 50) by 0.16; k = 200
// already turns 1.8 rad, and k = 20000 gave 416 wrong pixels at h = 0.01.
constexpr double kMaxSampleTurn = 0.25;
// Arclength quadrature: 4096 panels of 8-point Gauss-Legendre. On the reference shapes the
// integrand is analytic and a panel is 1.5e-3 wide: the error is far below 1e-14 relative.
constexpr int kPanelCount = 4096;
constexpr std::array<double, 8> kGaussNodes = {
    -0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
    0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
constexpr std::array<double, 8> kGaussWeights = {
    0.1012285362903763, 0.2223810344533745, 0.3137066458778873, 0.3626837833783620,
    0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};

double wrap_angle(double theta) {
  double w = std::fmod(theta + kPi, 2.0 * kPi);
  if (w < 0) w += 2.0 * kPi;
  return w - kPi;
}

}  // namespace

Shape::~Shape() = default;

Eigen::Vector2d Shape::rotate(const Eigen::Vector2d& v) const {
  const double c = std::cos(rotation_), s = std::sin(rotation_);
  return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
}
Eigen::Vector2d Shape::to_world(const Eigen::Vector2d& v) const { return centre_ + rotate(v); }
Eigen::Vector2d Shape::to_local(const Eigen::Vector2d& p) const {
  const Eigen::Vector2d d = p - centre_;
  const double c = std::cos(rotation_), s = std::sin(rotation_);
  return {c * d.x() + s * d.y(), -s * d.x() + c * d.y()};
}

Eigen::Vector2d Shape::point(double theta) const { return to_world(local_point(theta)); }
Eigen::Vector2d Shape::derivative(double theta) const { return rotate(local_derivative(theta)); }
Eigen::Vector2d Shape::second_derivative(double theta) const {
  return rotate(local_second_derivative(theta));
}
Eigen::Vector2d Shape::tangent(double theta) const { return derivative(theta).normalized(); }
Eigen::Vector2d Shape::outward_normal(double theta) const {
  const Eigen::Vector2d t = tangent(theta);
  return {t.y(), -t.x()};  // the curve runs counter-clockwise: the outside is on the right
}
double Shape::curvature(double theta) const {
  const Eigen::Vector2d d1 = derivative(theta), d2 = second_derivative(theta);
  return (d1.x() * d2.y() - d1.y() * d2.x()) / std::pow(d1.norm(), 3);
}
bool Shape::inside(const Eigen::Vector2d& p) const { return local_inside(to_local(p)); }

double Shape::radial_parameter(const Eigen::Vector2d& p) const {
  const Eigen::Vector2d q = to_local(p);
  return local_polar_parameter(std::atan2(q.y(), q.x()));
}

void Shape::set_pose(const Eigen::Vector2d& centre, double rotation) {
  if (!centre.allFinite() || !std::isfinite(rotation))
    throw Error("shape pose: centre and rotation must be finite numbers");
  centre_ = centre;
  rotation_ = rotation;
  initialize();
}

void Shape::initialize() {
  build_sampling();
  build_arclength_table();
  build_sample_grid();
}

void Shape::build_sampling() {
  sample_theta_.resize(kSampleCount);
  sample_point_.resize(kSampleCount);
  bbox_.setEmpty();
  double max_step = 0.0;
  for (int k = 0; k < kSampleCount; ++k) {
    sample_theta_[k] = -kPi + 2.0 * kPi * k / kSampleCount;
    sample_point_[k] = point(sample_theta_[k]);
    if (!sample_point_[k].allFinite())
      throw Error(name() + ": the curve is not finite at theta = " +
                  std::to_string(sample_theta_[k]));
    bbox_.extend(sample_point_[k]);
    if (k > 0) max_step = std::max(max_step, (sample_point_[k] - sample_point_[k - 1]).norm());
  }
  double max_turn = 0.0, where = 0.0;
  Eigen::Vector2d previous = derivative(sample_theta_.back());
  for (int k = 0; k < kSampleCount; ++k) {
    const Eigen::Vector2d d = derivative(sample_theta_[k]);
    const double turn = std::abs(std::atan2(previous.x() * d.y() - previous.y() * d.x(), previous.dot(d)));
    if (!(turn <= max_turn)) max_turn = turn, where = sample_theta_[k];  // NaN (a zero speed) counts too
    previous = d;
  }
  if (!(max_turn <= kMaxSampleTurn)) {
    std::ostringstream msg;
    msg << name() << ": the tangent turns by " << max_turn << " rad between two of the curve's " << kSampleCount
        << " samples (near theta = " << where << "), above " << kMaxSampleTurn
        << ": its oscillations are too fine to digitize and project reliably; use fewer petals or a smaller amplitude";
    throw Error(msg.str());
  }
  // The curve cannot leave the sampled box by more than one sample step.
  bbox_.min().array() -= max_step;
  bbox_.max().array() += max_step;
}

void Shape::build_arclength_table() {
  const double width = 2.0 * kPi / kPanelCount;
  panel_arclength_.assign(kPanelCount + 1, 0.0);
  for (int p = 0; p < kPanelCount; ++p) {
    const double a = -kPi + p * width, mid = a + 0.5 * width;
    double sum = 0.0;
    for (int q = 0; q < 8; ++q) sum += kGaussWeights[q] * speed(mid + 0.5 * width * kGaussNodes[q]);
    panel_arclength_[p + 1] = panel_arclength_[p] + 0.5 * width * sum;
  }
  length_ = panel_arclength_[kPanelCount];
}

double Shape::arclength(double theta) const {
  if (!(theta >= -kPi && theta <= kPi)) theta = wrap_angle(theta);
  const double width = 2.0 * kPi / kPanelCount;
  const int p = std::min(kPanelCount - 1, static_cast<int>((theta + kPi) / width));
  const double a = -kPi + p * width;
  const double half = 0.5 * (theta - a), mid = a + half;
  double sum = 0.0;
  for (int q = 0; q < 8; ++q) sum += kGaussWeights[q] * speed(mid + half * kGaussNodes[q]);
  return panel_arclength_[p] + half * sum;
}

void Shape::build_sample_grid() {
  // About 2 samples per cell along the curve: cells of twice the mean sample spacing.
  grid_cell_ = 2.0 * length_ / kSampleCount;
  grid_origin_ = bbox_.min();
  const Eigen::Vector2d extent = bbox_.sizes();
  grid_nx_ = std::max(1, static_cast<int>(std::ceil(extent.x() / grid_cell_)) + 1);
  grid_ny_ = std::max(1, static_cast<int>(std::ceil(extent.y() / grid_cell_)) + 1);
  // Keep the grid small for elongated or huge shapes: at most 4096 cells a side.
  while (grid_nx_ > 4096 || grid_ny_ > 4096) {
    grid_cell_ *= 2.0;
    grid_nx_ = std::max(1, static_cast<int>(std::ceil(extent.x() / grid_cell_)) + 1);
    grid_ny_ = std::max(1, static_cast<int>(std::ceil(extent.y() / grid_cell_)) + 1);
  }
  auto cell_of = [&](const Eigen::Vector2d& p) {
    const int cx = std::clamp(static_cast<int>((p.x() - grid_origin_.x()) / grid_cell_), 0, grid_nx_ - 1);
    const int cy = std::clamp(static_cast<int>((p.y() - grid_origin_.y()) / grid_cell_), 0, grid_ny_ - 1);
    return cy * grid_nx_ + cx;
  };
  grid_start_.assign(static_cast<size_t>(grid_nx_) * grid_ny_ + 1, 0);
  for (const auto& p : sample_point_) ++grid_start_[cell_of(p) + 1];
  for (size_t c = 1; c < grid_start_.size(); ++c) grid_start_[c] += grid_start_[c - 1];
  grid_items_.assign(sample_point_.size(), 0);
  std::vector<int> fill(grid_start_.begin(), grid_start_.end() - 1);
  for (int k = 0; k < kSampleCount; ++k) grid_items_[fill[cell_of(sample_point_[k])]++] = k;
}

size_t Shape::nearest_sample(const Eigen::Vector2d& p) const {
  const double gx = (p.x() - grid_origin_.x()) / grid_cell_;
  const double gy = (p.y() - grid_origin_.y()) / grid_cell_;
  size_t best = 0;
  double best_d2 = std::numeric_limits<double>::infinity();
  if (!(gx >= 0 && gy >= 0 && gx < grid_nx_ && gy < grid_ny_)) {
    // Far outside the curve's box: a linear scan is cheap enough for such rare queries.
    for (size_t k = 0; k < sample_point_.size(); ++k) {
      const double d2 = (sample_point_[k] - p).squaredNorm();
      if (d2 < best_d2) best_d2 = d2, best = k;
    }
    return best;
  }
  const int cx = static_cast<int>(gx), cy = static_cast<int>(gy);
  const int max_ring = std::max(grid_nx_, grid_ny_);
  for (int ring = 0; ring <= max_ring; ++ring) {
    for (int y = cy - ring; y <= cy + ring; ++y) {
      if (y < 0 || y >= grid_ny_) continue;
      const bool edge_row = (y == cy - ring || y == cy + ring);
      for (int x = cx - ring; x <= cx + ring; x += (edge_row ? 1 : 2 * ring)) {
        if (x >= 0 && x < grid_nx_) {
          const int c = y * grid_nx_ + x;
          for (int it = grid_start_[c]; it < grid_start_[c + 1]; ++it) {
            const int k = grid_items_[it];
            const double d2 = (sample_point_[k] - p).squaredNorm();
            if (d2 < best_d2 || (d2 == best_d2 && static_cast<size_t>(k) < best)) best_d2 = d2, best = k;
          }
        }
        if (ring == 0) break;
      }
    }
    // Every sample outside the examined block is farther than ring * cell from p.
    if (best_d2 < std::numeric_limits<double>::infinity() &&
        std::sqrt(best_d2) <= ring * grid_cell_)
      break;
  }
  return best;
}

double Shape::closest_parameter(const Eigen::Vector2d& p) const {
  if (!p.allFinite()) throw Error("closest_parameter: the query point is not finite");
  const size_t k = nearest_sample(p);
  const double step = 2.0 * kPi / kSampleCount;
  // f(theta) = <gamma(theta) - p, gamma'(theta)>: half the derivative of the squared distance.
  auto f = [&](double th) { return (point(th) - p).dot(derivative(th)); };
  auto df = [&](double th) {
    const Eigen::Vector2d d1 = derivative(th);
    return d1.squaredNorm() + (point(th) - p).dot(second_derivative(th));
  };
  const double theta_k = sample_theta_[k];
  double lo = theta_k - step, hi = theta_k + step;
  double flo = f(lo), fhi = f(hi);
  if (!(flo <= 0 && fhi >= 0)) {
    // No sign change around the nearest sample (p at a centre of curvature, or on a ridge of the
    // distance): golden-section search of the distance on the two sample steps.
    auto dist2 = [&](double th) { return (point(th) - p).squaredNorm(); };
    const double g = 0.5 * (std::sqrt(5.0) - 1.0);
    double a = lo, b = hi;
    for (int it = 0; it < 200 && b - a > 1e-15; ++it) {
      const double c = b - g * (b - a), d = a + g * (b - a);
      if (dist2(c) < dist2(d)) b = d; else a = c;
    }
    return wrap_angle(0.5 * (a + b));
  }
  // Safeguarded Newton: a Newton step when it stays in the bracket, a bisection otherwise.
  double theta = theta_k;
  for (int it = 0; it < 100; ++it) {
    const double ft = f(theta);
    if (ft == 0) break;
    if (ft < 0) lo = theta; else hi = theta;
    const double d = df(theta);
    double next = (d > 0) ? theta - ft / d : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    const bool converged = std::abs(next - theta) <= 1e-16 * std::max(1.0, std::abs(theta));
    theta = next;
    if (converged || hi - lo <= 1e-16) break;
  }
  return wrap_angle(theta);
}

// --- Polar curves -------------------------------------------------------------------------

PolarCurve::PolarCurve(Function r, Function dr, Function d2r, std::string name) : name_(std::move(name)) {
  set_functions(std::move(r), std::move(dr), std::move(d2r));
}

void PolarCurve::set_functions(Function r, Function dr, Function d2r) {
  if (!r || !dr || !d2r) throw Error("PolarCurve: r, r' and r'' must all be given");
  r_ = std::move(r);
  dr_ = std::move(dr);
  d2r_ = std::move(d2r);
  for (int k = 0; k < 1024; ++k) {
    const double th = -kPi + 2.0 * kPi * k / 1024;
    if (!(r_(th) > 0)) throw Error(name_ + ": the radius r(theta) must be > 0 for a polar curve");
  }
  initialize();
}

Eigen::Vector2d PolarCurve::local_point(double th) const {
  return r_(th) * Eigen::Vector2d(std::cos(th), std::sin(th));
}
Eigen::Vector2d PolarCurve::local_derivative(double th) const {
  const double c = std::cos(th), s = std::sin(th), r = r_(th), dr = dr_(th);
  return {dr * c - r * s, dr * s + r * c};
}
Eigen::Vector2d PolarCurve::local_second_derivative(double th) const {
  const double c = std::cos(th), s = std::sin(th), r = r_(th), dr = dr_(th), d2r = d2r_(th);
  return {d2r * c - 2.0 * dr * s - r * c, d2r * s + 2.0 * dr * c - r * s};
}
bool PolarCurve::local_inside(const Eigen::Vector2d& p) const {
  return p.norm() < r_(std::atan2(p.y(), p.x()));
}

Circle::Circle(double radius) {
  require_positive("circle: radius", radius);
  name_ = "circle";
  set_functions([radius](double) { return radius; }, [](double) { return 0.0; },
                [](double) { return 0.0; });
}

Flower::Flower(double R, double v, int k, double phi) {
  if (!(R > std::abs(v)) || !std::isfinite(R) || !std::isfinite(v) || !std::isfinite(phi) || k < 1)
    throw Error("flower: need R > |v|, k >= 1 and finite parameters (got R = " + std::to_string(R) +
                ", v = " + std::to_string(v) + ", k = " + std::to_string(k) + ")");
  name_ = "flower";
  const double kk = k;
  set_functions([=](double t) { return R + v * std::cos(kk * t + phi); },
                [=](double t) { return -v * kk * std::sin(kk * t + phi); },
                [=](double t) { return -v * kk * kk * std::cos(kk * t + phi); });
}

AccFlower::AccFlower(double R, double v, int k) {
  if (!(R > std::abs(v)) || !std::isfinite(R) || !std::isfinite(v) || k < 1)
    throw Error("accflower: need R > |v|, k >= 1 and finite parameters (got R = " +
                std::to_string(R) + ", v = " + std::to_string(v) + ", k = " + std::to_string(k) + ")");
  name_ = "accflower";
  const double K = 2.0 * k / (kPi * kPi);
  set_functions(
      [=](double t) { return R + v * std::cos(K * t * t * t); },
      [=](double t) { return -v * std::sin(K * t * t * t) * 3.0 * K * t * t; },
      [=](double t) {
        const double u = K * t * t * t, du = 3.0 * K * t * t, d2u = 6.0 * K * t;
        return -v * (std::cos(u) * du * du + std::sin(u) * d2u);
      });
}

// --- Ellipse ------------------------------------------------------------------------------

Ellipse::Ellipse(double a, double b) : a_(a), b_(b) {
  if (!(a > 0) || !(b > 0) || !std::isfinite(a) || !std::isfinite(b))
    throw Error("ellipse: semi-axes a and b must be > 0 and finite");
  initialize();
}
Eigen::Vector2d Ellipse::local_point(double t) const { return {a_ * std::cos(t), b_ * std::sin(t)}; }
Eigen::Vector2d Ellipse::local_derivative(double t) const { return {-a_ * std::sin(t), b_ * std::cos(t)}; }
Eigen::Vector2d Ellipse::local_second_derivative(double t) const {
  return {-a_ * std::cos(t), -b_ * std::sin(t)};
}
bool Ellipse::local_inside(const Eigen::Vector2d& p) const {
  const double x = p.x() / a_, y = p.y() / b_;
  return x * x + y * y < 1.0;
}

double Ellipse::local_polar_parameter(double phi) const {
  // (a cos t, b sin t) is in direction phi when tan(t) = (a / b) tan(phi).
  return std::atan2(a_ * std::sin(phi), b_ * std::cos(phi));
}

// --- Factory ------------------------------------------------------------------------------

std::vector<std::string> shape_names() { return {"circle", "ellipse", "flower", "accflower"}; }

namespace {

struct ShapeKind {
  const char* name;
  std::vector<std::pair<const char*, double>> keys;  // with their defaults (SPEC §6)
};
const std::vector<ShapeKind>& shape_kinds() {
  static const std::vector<ShapeKind> kinds = {
      {"circle", {{"r", 1.0}}},
      {"ellipse", {{"a", 2.0}, {"b", 1.0}}},
      {"flower", {{"R", 2.0}, {"v", 0.5}, {"k", 5}, {"phase", 0.0}}},
      {"accflower", {{"R", 2.0}, {"v", 0.25}, {"k", 2}}},
  };
  return kinds;
}

}  // namespace

std::unique_ptr<Shape> make_shape(const std::string& spec) {
  const std::size_t colon = spec.find(':');
  const std::string name = spec.substr(0, colon);
  const auto kind = std::find_if(shape_kinds().begin(), shape_kinds().end(), [&](const ShapeKind& k) { return name == k.name; });
  if (kind == shape_kinds().end()) {
    std::string known;
    for (const auto& n : shape_names()) known += (known.empty() ? "" : ", ") + n;
    throw Error("unknown shape '" + name + "' (known shapes: " + known + ")");
  }
  std::vector<std::pair<std::string, double>> value;
  for (const auto& [key, fallback] : kind->keys) value.emplace_back(key, fallback);
  if (colon != std::string::npos) detail::read_shape_parameters(name, spec.substr(colon + 1), value);
  auto whole = [&](const char* key) {
    const double v = detail::parameter(value, key);
    if (!(v >= 1 && v <= 1e6 && v == std::floor(v)))
      throw Error(name + ": " + key + " must be a whole number from 1 to 1000000, got " + std::to_string(v));
    return static_cast<int>(v);
  };
  auto get = [&](const char* key) { return detail::parameter(value, key); };
  if (name == "circle") return std::make_unique<Circle>(get("r"));
  if (name == "ellipse") return std::make_unique<Ellipse>(get("a"), get("b"));
  if (name == "flower") return std::make_unique<Flower>(get("R"), get("v"), whole("k"), get("phase"));
  return std::make_unique<AccFlower>(get("R"), get("v"), whole("k"));
}

std::string shape_syntax() {
  std::string text;
  for (const ShapeKind& kind : shape_kinds()) {
    text += detail::syntax_line(kind.name, kind.keys);
  }
  return text;
}

}  // namespace curve
}  // namespace digilap
