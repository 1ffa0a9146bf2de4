#include "svg_surface.hpp"

#include "digilap/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numeric>

namespace digilap::app {

void save_surface_panels(const std::string& path, const surface::SurfelSet& surfels, const Eigen::MatrixX3d& normals,
                         const std::vector<SurfacePanel>& panels, int columns, const std::string& title) {
  if (panels.empty() || surfels.size() == 0) throw Error("save_surface_panels: nothing to draw");
  const Eigen::Vector3d view = Eigen::Vector3d(1, -1.4, 1.1).normalized(), light = Eigen::Vector3d(0.3, -0.5, 1).normalized();
  const Eigen::Vector3d e1 = Eigen::Vector3d::UnitZ().cross(view).normalized(), e2 = view.cross(e1);
  // Visible surfels (trivial normal towards the viewer), far to near.
  std::vector<std::size_t> order;
  for (std::size_t s = 0; s < surfels.size(); ++s)
    if (surfels.trivial_normal(s).dot(view) > 0) order.push_back(s);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return surfels.centre(a).dot(view) < surfels.centre(b).dot(view);
  });
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  for (std::size_t s = 0; s < surfels.size(); ++s) {
    const Eigen::Vector3d c = surfels.centre(s);
    const Eigen::Vector2d p(c.dot(e1), -c.dot(e2));
    lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  }
  columns = std::max(1, std::min<int>(columns, static_cast<int>(panels.size())));
  const int rows = (static_cast<int>(panels.size()) + columns - 1) / columns;
  const double panel = 320, pad = 20, head = 40;
  const double scale = (panel - 2 * pad) / std::max((hi - lo).maxCoeff(), 1e-300);
  std::ofstream out(path);
  if (!out) throw Error("cannot write '" + path + "' (check the directory exists and is writable)");
  out << "<svg xmlns='http://www.w3.org/2000/svg' width='" << columns * panel << "' height='" << head + rows * (panel + 24)
      << "' font-family='sans-serif'>\n<rect width='100%' height='100%' fill='white'/>\n<text x='10' y='24' font-size='16'>"
      << title << "</text>\n";
  char buf[256];
  for (std::size_t k = 0; k < panels.size(); ++k) {
    const double ox = static_cast<double>(k % columns) * panel, oy = head + static_cast<double>(k / columns) * (panel + 24);
    out << "<text x='" << ox + 10 << "' y='" << oy + 16 << "' font-size='12'>" << panels[k].title << "</text>\n<g stroke='none'>\n";
    const double vmax = std::max(panels[k].values.cwiseAbs().maxCoeff(), 1e-300);
    for (std::size_t s : order) {
      const surface::Surfel& f = surfels.surfels[s];
      const Eigen::Vector3d c = surfels.centre(s);
      const int u = (f.axis + 1) % 3, v = (f.axis + 2) % 3;
      std::string points;
      for (const auto& [a, b] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
        Eigen::Vector3d corner = c;
        corner[u] += 0.5 * a * surfels.h, corner[v] += 0.5 * b * surfels.h;
        std::snprintf(buf, sizeof buf, "%.1f,%.1f ", ox + pad + (corner.dot(e1) - lo.x()) * scale,
                      oy + 24 + pad + (-corner.dot(e2) - lo.y()) * scale);
        points += buf;
      }
      const double value = std::clamp(panels[k].values[static_cast<Eigen::Index>(s)] / vmax, -1.0, 1.0);
      const double shade = 0.45 + 0.55 * std::max(0.0, normals.row(static_cast<Eigen::Index>(s)).dot(light));
      const double blue[3] = {33, 102, 172}, red[3] = {178, 24, 43}, white[3] = {247, 247, 247};
      const double* end = value < 0 ? blue : red;
      int rgb[3];
      for (int i = 0; i < 3; ++i) rgb[i] = static_cast<int>(shade * (white[i] + std::abs(value) * (end[i] - white[i])));
      std::snprintf(buf, sizeof buf, "<polygon points='%s' fill='#%02x%02x%02x'/>\n", points.c_str(), rgb[0], rgb[1], rgb[2]);
      out << buf;
    }
    out << "</g>\n";
  }
  out << "</svg>\n";
  if (!out) throw Error("error while writing '" + path + "' (disk full?)");
}

}  // namespace digilap::app
