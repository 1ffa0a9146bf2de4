#include "svg_contour.hpp"

#include "digilap/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace digilap::app {

namespace {

// Blue - white - red (ColorBrewer RdBu ends), linear in between; v in [-1, 1].
std::string diverging(double v) {
  v = std::clamp(v, -1.0, 1.0);
  const double blue[3] = {33, 102, 172}, red[3] = {178, 24, 43}, white[3] = {247, 247, 247};
  const double* end = v < 0 ? blue : red;
  const double a = std::abs(v);
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", static_cast<int>(white[0] + a * (end[0] - white[0])),
                static_cast<int>(white[1] + a * (end[1] - white[1])), static_cast<int>(white[2] + a * (end[2] - white[2])));
  return buf;
}

}  // namespace

void save_contour_panels(const std::string& path, const Eigen::MatrixX2d& positions,
                         const std::vector<Eigen::Index>& row_offset, const std::vector<ContourPanel>& panels,
                         int columns, const std::string& title) {
  if (panels.empty()) throw Error("save_contour_panels: no panel to draw");
  columns = std::max(1, std::min<int>(columns, static_cast<int>(panels.size())));
  const int rows = (static_cast<int>(panels.size()) + columns - 1) / columns;
  const double panel = 300, pad = 30, head = 50, bar = 60;
  const double width = columns * panel, height = head + rows * (panel + 20) + bar;
  const Eigen::Vector2d lo = positions.colwise().minCoeff().transpose(), hi = positions.colwise().maxCoeff().transpose();
  const double scale = (panel - 2 * pad) / std::max((hi - lo).maxCoeff(), 1e-300);
  double vmax = 0;
  for (const auto& p : panels) {
    if (p.values.size() != positions.rows()) throw Error("save_contour_panels: a panel has the wrong number of values");
    vmax = std::max(vmax, p.values.cwiseAbs().maxCoeff());
  }
  if (!(vmax > 0)) vmax = 1;
  // At most ~1500 segments per contour and panel: enough for the eye, small files.
  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
      << "\" font-family=\"Helvetica, Arial, sans-serif\" font-size=\"13\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  svg << "<text x=\"" << width / 2 << "\" y=\"28\" text-anchor=\"middle\" font-size=\"16\">" << title << "</text>\n";
  for (std::size_t k = 0; k < panels.size(); ++k) {
    const double ox = (k % columns) * panel, oy = head + (k / columns) * (panel + 20);
    svg << "<text x=\"" << ox + panel / 2 << "\" y=\"" << oy + 12 << "\" text-anchor=\"middle\">" << panels[k].title << "</text>\n";
    auto X = [&](Eigen::Index r) { return ox + pad + (positions(r, 0) - lo.x()) * scale; };
    auto Y = [&](Eigen::Index r) { return oy + 20 + panel - pad - (positions(r, 1) - lo.y()) * scale; };
    for (std::size_t c = 0; c + 1 < row_offset.size(); ++c) {
      const Eigen::Index a = row_offset[c], b = row_offset[c + 1], n = b - a;
      const Eigen::Index stride = std::max<Eigen::Index>(1, n / 1500);
      for (Eigen::Index i = 0; i < n; i += stride) {
        const Eigen::Index r0 = a + i, r1 = a + std::min(n, i + stride) % n;
        const double v = 0.5 * (panels[k].values[r0] + panels[k].values[r1]) / vmax;
        svg << "<line x1=\"" << X(r0) << "\" y1=\"" << Y(r0) << "\" x2=\"" << X(r1) << "\" y2=\"" << Y(r1)
            << "\" stroke=\"" << diverging(v) << "\" stroke-width=\"4\" stroke-linecap=\"round\"/>\n";
      }
    }
  }
  // Colour bar.
  const double bx = width / 2 - 150, by = height - bar + 15;
  for (int i = 0; i < 100; ++i)
    svg << "<rect x=\"" << bx + 3 * i << "\" y=\"" << by << "\" width=\"3.5\" height=\"14\" fill=\"" << diverging(i / 49.5 - 1.0) << "\"/>\n";
  char lo_label[32], hi_label[32];
  std::snprintf(lo_label, sizeof lo_label, "%.3g", -vmax);
  std::snprintf(hi_label, sizeof hi_label, "%.3g", vmax);
  svg << "<text x=\"" << bx - 6 << "\" y=\"" << by + 12 << "\" text-anchor=\"end\">" << lo_label << "</text>\n";
  svg << "<text x=\"" << bx + 306 << "\" y=\"" << by + 12 << "\">" << hi_label << "</text>\n";
  svg << "<text x=\"" << bx + 150 << "\" y=\"" << by + 32 << "\" text-anchor=\"middle\">0</text>\n</svg>\n";
  std::ofstream out(path);
  if (!out) throw Error("cannot write SVG file '" + path + "'");
  out << svg.str();
}

}  // namespace digilap::app
