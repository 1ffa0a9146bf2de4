#include "digilap/curve/digitization.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/core/error.hpp"
#include "core/runs.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace digilap {
inline namespace curve {

namespace {

void check_step(double h) { require_grid_step("grid step h", h); }


std::string index_range() { return "[-" + std::to_string(kMaxPixelIndex) + ", " + std::to_string(kMaxPixelIndex) + "]"; }

void check_index(const char* who, const char* what, std::int64_t v) {
  if (v < -kMaxPixelIndex || v > kMaxPixelIndex)
    throw Error(std::string(who) + ": " + what + " index " + std::to_string(v) + " is outside " + index_range() +
                " (pixels need room for their neighbours); translate the set towards the origin");
}

// One offset per row between the first and the last row: refuse a span that would cost far
// more than the runs themselves, before allocating it.
void check_row_span(const char* who, std::int64_t rows, std::size_t runs) {
  constexpr std::int64_t kFreeSpan = std::int64_t(1) << 24;
  if (rows > kFreeSpan && rows > 64 * static_cast<std::int64_t>(runs)) {
    std::ostringstream msg;
    msg << who << ": the pixels span " << rows << " rows but hold only " << runs
        << " runs: a set this sparse would take memory by its span (" << 8.0 * static_cast<double>(rows) / 1e9
        << " GB); split it into separate sets";
    throw Error(msg.str());
  }
}

// Makes pixel i of a row of runs (sorted, perhaps touching) in or out of the set.
void set_pixel(std::vector<Run>& row, std::int32_t i, bool inside) {
  const auto it = std::find_if(row.begin(), row.end(), [i](const Run& r) { return r.begin <= i && i < r.end; });
  if (inside == (it != row.end())) return;
  if (inside) {
    row.insert(std::upper_bound(row.begin(), row.end(), i, [](std::int32_t v, const Run& r) { return v < r.begin; }), Run{i, i + 1});
    return;
  }
  const Run after{i + 1, it->end};
  it->end = i;
  row.insert(it + 1, after);  // empty pieces are dropped when the rows are normalized
}

// One crossing of the curve with the line y = j h.
struct Crossing {
  std::int32_t row;
  double x;
};

}  // namespace

DigitalSet::DigitalSet(double h) : h_(h) { check_step(h); }

bool DigitalSet::contains(std::int32_t i, std::int32_t j) const {
  return detail::in_runs(row_runs_begin(j), row_runs_end(j), i);
}

std::int64_t DigitalSet::pixel_count() const { return detail::run_total(runs_); }

std::size_t DigitalSet::memory_bytes() const {
  return runs_.capacity() * sizeof(Run) + row_offset_.capacity() * sizeof(std::int64_t);
}

DigitalSet DigitalSet::from_rows(double h, std::int32_t row_begin, std::vector<std::vector<Run>> rows) {
  DigitalSet set(h);
  std::size_t run_total = 0;
  for (auto& r : rows) {
    detail::normalize_runs(r);
    run_total += r.size();
  }
  // Drop empty rows at both ends so that row_begin()/row_end() are tight.
  std::size_t first = 0, last = rows.size();
  while (first < last && rows[first].empty()) ++first;
  while (last > first && rows[last - 1].empty()) --last;
  if (first < last) {
    check_index("from_rows", "row", std::int64_t(row_begin) + static_cast<std::int64_t>(first));
    check_index("from_rows", "row", std::int64_t(row_begin) + static_cast<std::int64_t>(last) - 1);
    for (std::size_t r = first; r < last; ++r)
      if (!rows[r].empty()) {
        check_index("from_rows", "column", rows[r].front().begin);
        check_index("from_rows", "column", std::int64_t(rows[r].back().end) - 1);
      }
    check_row_span("from_rows", static_cast<std::int64_t>(last - first), run_total);
  }
  set.row_begin_ = row_begin + static_cast<std::int32_t>(first);
  set.row_offset_.assign(1, 0);
  for (std::size_t r = first; r < last; ++r) {
    set.runs_.insert(set.runs_.end(), rows[r].begin(), rows[r].end());
    set.row_offset_.push_back(static_cast<std::int64_t>(set.runs_.size()));
  }
  if (set.runs_.empty()) set.row_begin_ = 0, set.row_offset_.assign(1, 0);
  return set;
}

DigitalSet DigitalSet::from_bitmap(double h, int width, int height, const std::vector<std::uint8_t>& bitmap,
                                   std::int32_t col_offset, std::int32_t row_offset) {
  if (width < 0 || height < 0 || bitmap.size() != static_cast<std::size_t>(width) * height)
    throw Error("from_bitmap: the bitmap must hold width * height values");
  if (width > 0 && height > 0) {
    check_index("from_bitmap", "column", col_offset);
    check_index("from_bitmap", "column", std::int64_t(col_offset) + width - 1);
    check_index("from_bitmap", "row", row_offset);
    check_index("from_bitmap", "row", std::int64_t(row_offset) + height - 1);
  }
  std::vector<std::vector<Run>> rows(height);
  for (int r = 0; r < height; ++r) {
    const std::uint8_t* row = bitmap.data() + static_cast<std::size_t>(r) * width;
    for (int c = 0; c < width;) {
      if (!row[c]) { ++c; continue; }
      int e = c;
      while (e < width && row[e]) ++e;
      rows[r].push_back({c + col_offset, e + col_offset});
      c = e;
    }
  }
  return from_rows(h, row_offset, std::move(rows));
}

DigitalSet DigitalSet::from_pixels(double h, const std::vector<Eigen::Vector2i>& pixels) {
  if (pixels.empty()) return DigitalSet(h);
  std::int32_t jmin = pixels[0].y(), jmax = pixels[0].y();
  for (const auto& p : pixels) {
    check_index("from_pixels", "column", p.x());
    check_index("from_pixels", "row", p.y());
    jmin = std::min(jmin, p.y()), jmax = std::max(jmax, p.y());
  }
  check_row_span("from_pixels", std::int64_t(jmax) - jmin + 1, pixels.size());
  std::vector<std::vector<Run>> rows(static_cast<std::size_t>(std::int64_t(jmax) - jmin + 1));
  for (const auto& p : pixels) rows[p.y() - jmin].push_back({p.x(), p.x() + 1});
  return from_rows(h, jmin, std::move(rows));
}

// --- Gauss digitization of a shape ----------------------------------------------------------

DigitalSet digitize(const Shape& shape, double h) {
  check_step(h);
  const Eigen::AlignedBox2d box = shape.bounding_box();
  const double limit = 1e9;  // pixel indices must fit in 32 bits with room for neighbours
  if (std::max(box.min().cwiseAbs().maxCoeff(), box.max().cwiseAbs().maxCoeff()) / h > limit) {
    std::ostringstream msg;
    msg << "digitize: grid step h = " << h << " is too fine for this shape (pixel indices would "
        << "exceed 1e9); use h >= " << std::max(box.min().cwiseAbs().maxCoeff(), box.max().cwiseAbs().maxCoeff()) / limit;
    throw Error(msg.str());
  }

  // 1. Split the curve into pieces on which y(theta) is monotone, at the roots of y'(theta).
  const auto& th = shape.sample_parameters();
  const std::size_t n = th.size();
  const double two_pi = 2.0 * kPi;
  auto theta_at = [&](std::size_t k) { return k < n ? th[k] : th[k - n] + two_pi; };
  const double theta_end = theta_at(0) + two_pi;
  // The curve closes at theta = +-pi: evaluate the end as the start, so that both pieces that
  // meet there see the same point (the two parameters round to different points otherwise).
  auto at = [&](double t) { return shape.point(t >= theta_end ? theta_at(0) : t); };
  auto dy = [&](double t) { return shape.derivative(t >= theta_end ? theta_at(0) : t).y(); };
  std::vector<double> breaks{theta_at(0)};
  for (std::size_t k = 0; k < n; ++k) {
    double a = theta_at(k), b = theta_at(k + 1);
    double fa = dy(a), fb = dy(b);
    if ((fa > 0) == (fb > 0)) continue;
    for (int it = 0; it < 60; ++it) {  // bisection to full precision: y' changes sign once here
      const double m = 0.5 * (a + b);
      if (m <= a || m >= b) break;
      if ((dy(m) > 0) == (fa > 0)) a = m; else b = m;
    }
    breaks.push_back(0.5 * (a + b));
  }
  breaks.push_back(theta_end);

  // 2. On each monotone piece, one crossing per row j with j h in [min y, max y).
  std::vector<Crossing> crossings;
  for (std::size_t p = 0; p + 1 < breaks.size(); ++p) {
    const double ta = breaks[p], tb = breaks[p + 1];
    if (!(tb > ta)) continue;
    const double ya = at(ta).y(), yb = at(tb).y();
    const double ylo = std::min(ya, yb), yhi = std::max(ya, yb);
    const bool increasing = yb > ya;
    auto j = static_cast<std::int64_t>(std::ceil(ylo / h));
    while (static_cast<double>(j - 1) * h >= ylo) --j;
    while (static_cast<double>(j) * h < ylo) ++j;
    for (; static_cast<double>(j) * h < yhi; ++j) {
      const double y0 = static_cast<double>(j) * h;
      // Bracketed root of y(theta) - y0 on [ta, tb]: Newton steps, bisection when they leave.
      double lo = ta, hi = tb;
      double t = ta + (tb - ta) * (y0 - ya) / (yb - ya);
      for (int it = 0; it < 100; ++it) {
        const double f = at(t).y() - y0;
        if (f == 0) break;
        if ((f < 0) == increasing) lo = t; else hi = t;
        const double d = dy(t);
        double next = (d != 0) ? t - f / d : 0.5 * (lo + hi);
        if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
        if (next == t || hi - lo <= 4 * std::numeric_limits<double>::epsilon() * std::abs(t)) { t = next; break; }
        t = next;
      }
      crossings.push_back({static_cast<std::int32_t>(j), at(t).x()});
    }
  }
  std::sort(crossings.begin(), crossings.end(), [](const Crossing& a, const Crossing& b) {
    return a.row != b.row ? a.row < b.row : a.x < b.x;
  });

  // 3. Pair the crossings of each row (even-odd rule) into runs, each end checked exactly.
  if (crossings.empty()) return DigitalSet(h);
  const std::int32_t row0 = crossings.front().row;
  std::vector<std::vector<Run>> rows(static_cast<std::size_t>(crossings.back().row - row0) + 1);
  auto in = [&](std::int64_t i, std::int64_t j) {
    return shape.inside({static_cast<double>(i) * h, static_cast<double>(j) * h});
  };
  for (std::size_t c = 0; c < crossings.size();) {
    std::size_t e = c;
    while (e < crossings.size() && crossings[e].row == crossings[c].row) ++e;
    const std::int32_t j = crossings[c].row;
    if ((e - c) % 2 != 0) {
      std::ostringstream msg;
      msg << "digitize: the curve of '" << shape.name() << "' crosses the line y = " << j * h
          << " an odd number of times: it is not a simple closed curve at this resolution";
      throw Error(msg.str());
    }
    for (std::size_t k = c; k < e; k += 2) {
      auto b = static_cast<std::int64_t>(std::floor(crossings[k].x / h)) + 1;
      auto last = static_cast<std::int64_t>(std::ceil(crossings[k + 1].x / h)) - 1;
      // The crossing and i h may round differently: one pixel of correction on each side.
      if (b <= last && !in(b, j)) ++b;
      else if (in(b - 1, j)) --b;
      if (last >= b && !in(last, j)) --last;
      else if (in(last + 1, j)) ++last;
      if (b <= last)
        rows[j - row0].push_back({static_cast<std::int32_t>(b), static_cast<std::int32_t>(last + 1)});
    }
    c = e;
  }
  // 4. Where the curve touches a row without crossing it (y' = 0 on the line y = j h), the
  // crossings say nothing: the pixels there lie inside a run, or just outside one, and are
  // settled by the exact inside test (a run is split, or a pixel added).
  for (std::size_t b = 1; b + 1 < breaks.size(); ++b) {
    const Eigen::Vector2d p = at(breaks[b]);
    for (auto j = static_cast<std::int64_t>(std::floor(p.y() / h)); j <= static_cast<std::int64_t>(std::ceil(p.y() / h)); ++j) {
      if (j < row0 || j - row0 >= static_cast<std::int64_t>(rows.size())) continue;
      std::vector<Run>& row = rows[static_cast<std::size_t>(j - row0)];
      const auto i0 = static_cast<std::int64_t>(std::floor(p.x() / h)) - 1, i1 = static_cast<std::int64_t>(std::ceil(p.x() / h)) + 1;
      for (std::int64_t i = i0; i <= i1; ++i) set_pixel(row, static_cast<std::int32_t>(i), in(i, j));
    }
  }
  return DigitalSet::from_rows(h, row0, std::move(rows));
}

}  // namespace curve
}  // namespace digilap
