#include "app_common.hpp"

#include <cstdio>
#include <iostream>
#include <map>

namespace digilap::app {

void add_front_end_options(CLI::App& app, FrontEndOptions& o, bool with_h) {
  std::string names;
  for (const auto& n : shape_names()) names += (names.empty() ? "" : ", ") + n;
  app.add_option("--shape", o.shape, "Reference shape: " + names)->capture_default_str();
  if (with_h) app.add_option("--h", o.h, "Grid step h")->capture_default_str();
  app.add_option("--kR", o.k_R, "II radius constant: R = kR * h^(1/3)")->capture_default_str();
  app.add_option("--normals", o.normals, "Normals for the measures: ii (estimated) or exact (from the curve)")
      ->check(CLI::IsMember({"ii", "exact"}))
      ->capture_default_str();
}

void add_operator_options(CLI::App& app, HeatLaplacianOptions& o) {
  app.add_option("--t", o.t, "Heat time t (0: c_t * h^(2/3))")->capture_default_str();
  app.add_option("--ct", o.c_t, "Constant c_t of the default heat time")->capture_default_str();
  app.add_option("--k", o.k, "Kernel cut at k * sqrt(t)")->capture_default_str();
  const std::map<std::string, DistanceMode> distances{{"geodesic", DistanceMode::Geodesic},
                                                      {"euclidean", DistanceMode::Euclidean}};
  const std::map<std::string, Placement> placements{{"pointels", Placement::Pointels},
                                                    {"linels", Placement::Linels}};
  app.add_option("--distance", o.distance, "geodesic (along the contour) or euclidean")
      ->transform(CLI::CheckedTransformer(distances, CLI::ignore_case).description(""))
      ->type_name("{geodesic,euclidean}")
      ->default_str("geodesic");
  app.add_option("--placement", o.placement, "pointels (vertices) or linels (linel midpoints)")
      ->transform(CLI::CheckedTransformer(placements, CLI::ignore_case).description(""))
      ->type_name("{pointels,linels}")
      ->default_str("pointels");
  app.add_option("--memory-limit", o.memory_limit_bytes, "Refuse operators estimated larger than this many bytes")
      ->capture_default_str();
}

void Progress::start(const std::string& stage) {
  stage_ = stage;
  t0_ = std::chrono::steady_clock::now();
  if (!quiet_) std::fprintf(stderr, "  %-12s ...", stage.c_str()), std::fflush(stderr);
}

double Progress::finish() {
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  if (!quiet_) std::fprintf(stderr, " %8.3f s\n", s);
  return s;
}

void Progress::bar(const std::string& label, double fraction) {
  if (quiet_) return;
  const int width = 30, filled = static_cast<int>(fraction * width + 0.5);
  std::fprintf(stderr, "\r%s [%s%s] %3d%%", label.c_str(), std::string(filled, '#').c_str(),
               std::string(width - filled, '.').c_str(), static_cast<int>(100 * fraction + 0.5));
  std::fflush(stderr);
}

void Progress::end_bar() {
  if (!quiet_) std::fprintf(stderr, "\n");
}

FrontEnd run_front_end(const FrontEndOptions& o, double h, Progress& progress) {
  FrontEnd fe;
  fe.shape = make_shape(o.shape);
  progress.start("digitize");
  fe.set = digitize(*fe.shape, h);
  fe.seconds_digitize = progress.finish();
  if (fe.set.empty()) throw Error("the digitization at h = " + std::to_string(h) + " is empty: use a smaller h");
  progress.start("contours");
  fe.contours = track_contours(fe.set);
  fe.seconds_contours = progress.finish();
  progress.start("normals");
  fe.normals = o.normals == "exact" ? exact_normals(*fe.shape, fe.contours)
                                    : ii_normals(fe.set, fe.contours, IINormalOptions{o.k_R});
  fe.seconds_normals = progress.finish();
  progress.start("measures");
  fe.measures = measures(fe.contours, fe.normals);
  fe.seconds_measures = progress.finish();
  if (fe.measures.clamped_linels > 0 && !progress.quiet())
    std::fprintf(stderr, "warning: %zu linels got mu = 0 (normal orthogonal to the linel); k_R may be too large\n",
                 fe.measures.clamped_linels);
  return fe;
}

int guarded_main(const std::function<int()>& body) {
  try {
    return body();
  } catch (const Error& e) {
    std::cerr << "error: " << e.what() << "\n";
  } catch (const std::bad_alloc&) {
    std::cerr << "error: out of memory; use a coarser h or a smaller t\n";
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
  }
  return 1;
}

}  // namespace digilap::app
