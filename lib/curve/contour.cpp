#include "digilap/curve/contour.hpp"

#include "digilap/core/error.hpp"

#include <algorithm>
#include <numeric>

namespace digilap {
inline namespace curve {

Eigen::Vector2i step_vector(Step s) {
  switch (s) {
    case Step::East: return {1, 0};
    case Step::North: return {0, 1};
    case Step::West: return {-1, 0};
    case Step::South: return {0, -1};
  }
  return {0, 0};
}

Eigen::Vector2d linel_normal(Step s) {
  const Eigen::Vector2i d = step_vector(s);
  return {static_cast<double>(d.y()), static_cast<double>(-d.x())};
}

std::int64_t Contour::twice_signed_area() const {
  std::int64_t a = 0;
  const std::size_t n = pointels.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2i& p = pointels[i];
    const Eigen::Vector2i& q = pointels[(i + 1) % n];
    a += static_cast<std::int64_t>(p.x()) * q.y() - static_cast<std::int64_t>(q.x()) * p.y();
  }
  return a;
}

std::size_t ContourSet::linel_count() const {
  std::size_t n = 0;
  for (const auto& c : contours) n += c.size();
  return n;
}

Eigen::Vector2d ContourSet::pointel_position(std::size_t c, std::size_t i) const {
  const Eigen::Vector2i& p = contours[c].pointels[i];
  return {(p.x() + 0.5) * h, (p.y() + 0.5) * h};
}

Eigen::Vector2d ContourSet::linel_midpoint(std::size_t c, std::size_t i) const {
  const Eigen::Vector2i d = step_vector(contours[c].steps[i]);
  return pointel_position(c, i) + 0.5 * h * Eigen::Vector2d(d.x(), d.y());
}

namespace {

struct Linel {
  Eigen::Vector2i start;
  Step step;
};

// Row-major order of pointels: the order in which contours are discovered.
bool pointel_less(const Eigen::Vector2i& a, const Eigen::Vector2i& b) {
  return a.y() != b.y() ? a.y() < b.y() : a.x() < b.x();
}

// Runs of `a` not covered by `b` (both sorted, disjoint).
void difference(const Run* a, const Run* a_end, const Run* b, const Run* b_end, std::vector<Run>& out) {
  out.clear();
  for (; a != a_end; ++a) {
    std::int32_t cur = a->begin;
    while (b != b_end && b->end <= cur) ++b;
    for (const Run* it = b; it != b_end && it->begin < a->end; ++it) {
      if (it->begin > cur) out.push_back({cur, it->begin});
      cur = std::max(cur, it->end);
      if (cur >= a->end) break;
    }
    if (cur < a->end) out.push_back({cur, a->end});
  }
}

}  // namespace

ContourSet track_contours(const DigitalSet& set) {
  ContourSet result;
  result.h = set.h();
  if (set.empty()) return result;

  // 1. Every linel, oriented with the set on its left (SPEC §1).
  std::vector<Linel> linels;
  std::vector<Run> diff;
  for (std::int32_t j = set.row_begin(); j < set.row_end(); ++j) {
    for (const Run* r = set.row_runs_begin(j); r != set.row_runs_end(j); ++r) {
      linels.push_back({{r->begin - 1, j}, Step::South});  // west side of the run, going down
      linels.push_back({{r->end - 1, j - 1}, Step::North});  // east side, going up
    }
  }
  for (std::int32_t j = set.row_begin() - 1; j < set.row_end(); ++j) {
    // Between rows j and j + 1 (pointel row q = j): tops of row j, bottoms of row j + 1.
    difference(set.row_runs_begin(j), set.row_runs_end(j), set.row_runs_begin(j + 1),
               set.row_runs_end(j + 1), diff);
    for (const Run& r : diff)
      for (std::int32_t i = r.begin; i < r.end; ++i) linels.push_back({{i, j}, Step::West});
    difference(set.row_runs_begin(j + 1), set.row_runs_end(j + 1), set.row_runs_begin(j),
               set.row_runs_end(j), diff);
    for (const Run& r : diff)
      for (std::int32_t i = r.begin; i < r.end; ++i) linels.push_back({{i - 1, j}, Step::East});
  }

  // 2. Sort by start pointel; a pointel starts one linel, or two at a saddle.
  std::sort(linels.begin(), linels.end(), [](const Linel& a, const Linel& b) {
    if (a.start != b.start) return pointel_less(a.start, b.start);
    return a.step < b.step;
  });
  auto successor = [&](std::size_t k) -> std::size_t {
    const Eigen::Vector2i end = linels[k].start + step_vector(linels[k].step);
    auto first = std::lower_bound(linels.begin(), linels.end(), end,
                                  [](const Linel& l, const Eigen::Vector2i& p) { return pointel_less(l.start, p); });
    auto last = first;
    while (last != linels.end() && last->start == end) ++last;
    if (last - first == 1) return static_cast<std::size_t>(first - linels.begin());
    if (last - first != 2) throw Error("track_contours: inconsistent linels (internal error)");
    // Saddle pointel: turn left, so that pixels touching by a corner are separated.
    const Step left = static_cast<Step>((static_cast<int>(linels[k].step) + 1) % 4);
    return static_cast<std::size_t>((first->step == left ? first : first + 1) - linels.begin());
  };

  // 3. Follow the cycles.
  std::vector<bool> visited(linels.size(), false);
  for (std::size_t k0 = 0; k0 < linels.size(); ++k0) {
    if (visited[k0]) continue;
    Contour contour;
    std::size_t k = k0;
    do {
      visited[k] = true;
      contour.pointels.push_back(linels[k].start);
      contour.steps.push_back(linels[k].step);
      k = successor(k);
    } while (k != k0);
    result.contours.push_back(std::move(contour));
  }
  return result;
}

}  // namespace curve
}  // namespace digilap
