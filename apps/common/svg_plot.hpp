// A log-log line plot written as SVG text (no plotting dependency: an SVG is text).
#pragma once

#include <string>
#include <vector>

namespace digilap::app {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;
  std::string dash;      // SVG dash pattern for reference lines ("6,4"); empty: solid, coloured
  bool markers = true;
};

struct LogLogPlot {
  std::string title, x_label, y_label;
  std::vector<PlotSeries> series;
  int width = 760, height = 560;
  /// Writes the figure; throws digilap::Error if the file cannot be written.
  void save(const std::string& path) const;
};

/// Least-squares slope of log(y) against log(x) over points [first, last) with x, y > 0.
double loglog_slope(const std::vector<double>& x, const std::vector<double>& y, std::size_t first, std::size_t last);

}  // namespace digilap::app
