#include "svg_plot.hpp"

#include "digilap/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

namespace digilap::app {

namespace {
// Colour-blind-safe palette (Okabe-Ito), then greys.
const char* kColours[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00",
                          "#56B4E9", "#000000", "#F0E442", "#999999", "#666666"};
std::string esc(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else out += c;
  }
  return out;
}
std::string decade_label(int e) {
  if (e == 0) return "1";
  if (e == 1) return "10";
  return "10<tspan dy=\"-7\" font-size=\"10\">" + std::to_string(e) + "</tspan>";
}
}  // namespace

double loglog_slope(const std::vector<double>& x, const std::vector<double>& y, std::size_t first, std::size_t last) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int n = 0;
  for (std::size_t i = first; i < last && i < x.size(); ++i) {
    if (!(x[i] > 0) || !(y[i] > 0)) continue;
    const double lx = std::log(x[i]), ly = std::log(y[i]);
    sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly, ++n;
  }
  if (n < 2) return std::nan("");
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

void LogLogPlot::save(const std::string& path) const {
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (const auto& s : series)
    for (std::size_t i = 0; i < s.x.size(); ++i)
      if (s.x[i] > 0 && s.y[i] > 0 && std::isfinite(s.y[i]))
        xmin = std::min(xmin, s.x[i]), xmax = std::max(xmax, s.x[i]), ymin = std::min(ymin, s.y[i]),
        ymax = std::max(ymax, s.y[i]);
  if (xmin > xmax) throw Error("plot '" + title + "': nothing positive to plot on log axes");
  // Whole decades around the data.
  const int ex0 = static_cast<int>(std::floor(std::log10(xmin) + 1e-9)), ex1 = static_cast<int>(std::ceil(std::log10(xmax) - 1e-9));
  const int ey0 = static_cast<int>(std::floor(std::log10(ymin) + 1e-9)), ey1 = static_cast<int>(std::ceil(std::log10(ymax) - 1e-9));
  const int ex1b = std::max(ex1, ex0 + 1), ey1b = std::max(ey1, ey0 + 1);
  const double left = 80, right = width - 230, top = 50, bottom = height - 60;
  auto X = [&](double x) { return left + (std::log10(x) - ex0) / (ex1b - ex0) * (right - left); };
  auto Y = [&](double y) { return bottom - (std::log10(y) - ey0) / (ey1b - ey0) * (bottom - top); };

  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
      << "\" font-family=\"Helvetica, Arial, sans-serif\" font-size=\"13\">\n";
  svg << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  svg << "<text x=\"" << (left + right) / 2 << "\" y=\"28\" text-anchor=\"middle\" font-size=\"16\">" << esc(title) << "</text>\n";
  // Grid: decades solid, 2..9 faint.
  for (int e = ex0; e <= ex1b; ++e) {
    for (int m = 1; m <= 9 && (e < ex1b || m == 1); ++m) {
      const double x = X(m * std::pow(10.0, e));
      svg << "<line x1=\"" << x << "\" y1=\"" << top << "\" x2=\"" << x << "\" y2=\"" << bottom << "\" stroke=\""
          << (m == 1 ? "#bbb" : "#eee") << "\"/>\n";
    }
    svg << "<text x=\"" << X(std::pow(10.0, e)) << "\" y=\"" << bottom + 20 << "\" text-anchor=\"middle\">" << decade_label(e) << "</text>\n";
  }
  for (int e = ey0; e <= ey1b; ++e) {
    for (int m = 1; m <= 9 && (e < ey1b || m == 1); ++m) {
      const double y = Y(m * std::pow(10.0, e));
      svg << "<line x1=\"" << left << "\" y1=\"" << y << "\" x2=\"" << right << "\" y2=\"" << y << "\" stroke=\""
          << (m == 1 ? "#bbb" : "#eee") << "\"/>\n";
    }
    svg << "<text x=\"" << left - 8 << "\" y=\"" << Y(std::pow(10.0, e)) + 4 << "\" text-anchor=\"end\">" << decade_label(e) << "</text>\n";
  }
  svg << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << right - left << "\" height=\"" << bottom - top
      << "\" fill=\"none\" stroke=\"#333\"/>\n";
  svg << "<text x=\"" << (left + right) / 2 << "\" y=\"" << height - 18 << "\" text-anchor=\"middle\">" << esc(x_label) << "</text>\n";
  svg << "<text transform=\"translate(22," << (top + bottom) / 2 << ") rotate(-90)\" text-anchor=\"middle\">" << esc(y_label) << "</text>\n";
  svg << "<defs><clipPath id=\"plot\"><rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << right - left
      << "\" height=\"" << bottom - top << "\"/></clipPath></defs>\n";
  int colour = 0, legend_row = 0;
  for (const auto& s : series) {
    const bool dashed = !s.dash.empty();
    const char* c = dashed ? "#555" : kColours[colour++ % 10];
    std::ostringstream pts;
    for (std::size_t i = 0; i < s.x.size(); ++i)
      if (s.x[i] > 0 && s.y[i] > 0 && std::isfinite(s.y[i])) pts << X(s.x[i]) << ',' << Y(s.y[i]) << ' ';
    svg << "<polyline clip-path=\"url(#plot)\" fill=\"none\" stroke=\"" << c << "\" stroke-width=\"" << (dashed ? 1.2 : 2)
        << "\"" << (dashed ? " stroke-dasharray=\"" + s.dash + "\"" : std::string()) << " points=\"" << pts.str() << "\"/>\n";
    if (s.markers)
      for (std::size_t i = 0; i < s.x.size(); ++i)
        if (s.x[i] > 0 && s.y[i] > 0 && std::isfinite(s.y[i]))
          svg << "<circle cx=\"" << X(s.x[i]) << "\" cy=\"" << Y(s.y[i]) << "\" r=\"3.5\" fill=\"" << c << "\"/>\n";
    const double ly = top + 10 + 20 * legend_row++;
    svg << "<line x1=\"" << right + 15 << "\" y1=\"" << ly << "\" x2=\"" << right + 45 << "\" y2=\"" << ly << "\" stroke=\"" << c
        << "\" stroke-width=\"" << (dashed ? 1.2 : 2) << "\"" << (dashed ? " stroke-dasharray=\"" + s.dash + "\"" : std::string()) << "/>\n";
    svg << "<text x=\"" << right + 52 << "\" y=\"" << ly + 4 << "\">" << esc(s.label) << "</text>\n";
  }
  svg << "</svg>\n";
  std::ofstream out(path);
  if (!out) throw Error("cannot write SVG file '" + path + "'");
  out << svg.str();
}

}  // namespace digilap::app
