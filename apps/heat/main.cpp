// digilap-heat: heat flow of an initial function on a digitized shape's contour.
// Writes CSV snapshots and an SVG of the contour coloured by temperature at several times, and
// prints the decay of the first mode against exp(-(2 pi / P)^2 tau).
#include "../common/app_common.hpp"
#include "digilap/core/constants.hpp"
#include "../common/svg_surface.hpp"

#include "digilap/surface/heat_laplacian.hpp"
#include "digilap/surface/matrix_free_heat_flow.hpp"
#include "digilap/surface/ply.hpp"
#include "../common/svg_contour.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>

using namespace digilap;

namespace {

// The flow from u0 for `steps` steps to tau, keeping `snapshots` states at equal times (tau = 0
// included): snapshot k after round(k steps / (snapshots - 1)) steps.
struct Snapshots {
  std::vector<Eigen::VectorXd> values;
  std::vector<double> times;
};
using Step = std::function<Eigen::VectorXd(const Eigen::VectorXd&)>;
Snapshots run_flow(const Step& step, const Eigen::VectorXd& u0, double tau, int steps, int snapshots, app::Progress& progress) {
  Snapshots out{{u0}, {0.0}};
  Eigen::VectorXd u = u0;
  for (int s = 1; s <= steps; ++s) {
    u = step(u);
    const int k = static_cast<int>(out.times.size());
    if (s == static_cast<int>(std::lround(static_cast<double>(k) * steps / (snapshots - 1)))) {
      out.values.push_back(u);
      out.times.push_back(tau * s / steps);
    }
    progress.bar("heat flow", static_cast<double>(s) / steps);
  }
  progress.end_bar();
  return out;
}

// Heat flow on a surface (SPEC §7): the same scheme on the surface operator's (A, M). Initial
// temperature: cosine = the x coordinate about the centroid (on a sphere the first mode, which
// decays like exp(-2 tau / r^2)), bump = a Gaussian around the first surfel, dirac = unit heat on
// it. Writes heat.csv, heat.ply (one field per snapshot) and heat.svg.
HeatSolver solver_named(const std::string& name) {
  return name == "cg" ? HeatSolver::ConjugateGradient : name == "factorization" ? HeatSolver::Factorization : HeatSolver::Auto;
}
const char* solver_name(HeatSolver s) { return s == HeatSolver::ConjugateGradient ? "conjugate gradients" : "factorization"; }

int surface_heat(const app::FrontEndOptions& fe_options, const HeatLaplacianOptions& op_options, const std::string& initial,
                 double tau, int steps, int snapshots, bool euler, HeatSolver solver, bool matrix_free, const std::string& out_dir,
                 app::Progress& progress) {
  const app::SurfaceFrontEnd fe = app::run_surface_front_end(fe_options, progress);
  // The assembled operator, or (--matrix-free) products on the fly: memory O(N), each step by
  // conjugate gradients on products (surface/matrix_free_heat_flow.hpp).
  std::unique_ptr<surface::SurfaceOperator> assembled;
  std::unique_ptr<surface::MatrixFreeSurfaceOperator> free;
  progress.start(matrix_free ? "matrix-free operator" : "operator");
  if (matrix_free) free = std::make_unique<surface::MatrixFreeSurfaceOperator>(fe.surfels, fe.measures, op_options);
  else assembled.reset(new surface::SurfaceOperator(surface::heat_laplacian(fe.surfels, fe.measures, op_options)));  // elided: no copy of L and A
  progress.finish();
  const Eigen::VectorXd& mass = matrix_free ? free->mass() : assembled->mass;
  const Eigen::MatrixX3d& positions = matrix_free ? free->positions() : assembled->positions;
  const double t = matrix_free ? free->t() : assembled->t;
  const Eigen::Index n = mass.size();
  const Eigen::RowVector3d centroid = (mass.transpose() * positions) / mass.sum();
  const double sigma = std::sqrt(mass.sum()) / 10;
  Eigen::VectorXd u0(n), mode(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    mode[i] = positions(i, 0) - centroid.x();
    const double d2 = (positions.row(i) - positions.row(0)).squaredNorm();
    u0[i] = initial == "cosine" ? mode[i] : (initial == "bump" ? std::exp(-d2 / (2 * sigma * sigma)) : 0.0);
  }
  if (initial == "dirac") {
    if (!(mass[0] > 0)) throw Error("the first surfel has zero area: choose another initial function");
    u0[0] = 1 / mass[0];
  }
  const TimeScheme time_scheme = euler ? TimeScheme::ImplicitEuler : TimeScheme::CrankNicolson;
  if (matrix_free && solver == HeatSolver::Factorization)
    throw Error("--solver factorization needs the assembled operator: --matrix-free solves each step by conjugate gradients");
  progress.start(solver == HeatSolver::Factorization ? "factorize" : "heat flow setup");
  std::unique_ptr<HeatFlow> flow;
  std::unique_ptr<surface::MatrixFreeHeatFlow> free_flow;
  if (matrix_free) free_flow = std::make_unique<surface::MatrixFreeHeatFlow>(*free, tau / steps, time_scheme);
  else flow = std::make_unique<HeatFlow>(*assembled, tau / steps, time_scheme, solver);
  progress.finish();
  const auto [snaps, times] = run_flow([&](const Eigen::VectorXd& u) { return matrix_free ? free_flow->step(u) : flow->step(u); }, u0, tau,
                                       steps, snapshots, progress);
  const bool sphere = fe.shape && fe.shape->name() == "sphere";
  const double first = sphere ? 2 / (fe.shape->area() / (4 * kPi)) : 0, a0 = modal_amplitude(u0, mode, mass);
  std::printf("# %s, h = %g, N = %ld surfels, l = %.4g, R = %.4g, t = %.4g, scheme %s, dt = %g, %s\n", fe.name.c_str(), fe.voxels.h(),
              static_cast<long>(n), fe.measures.length_scale, fe.measures.normal_radius, t, euler ? "euler" : "cn", tau / steps,
              matrix_free ? "matrix-free, conjugate gradients" : solver_name(flow->solver()));
  std::printf("| tau | amplitude along x a(tau)/a(0) | %s | total heat |\n|---|---|---|---|\n",
              sphere ? "exp(-2 tau / r^2) (sphere: x is the first mode)" : "(no closed form off the sphere)");
  for (std::size_t k = 0; k < snaps.size(); ++k) {
    const double ratio = a0 != 0 ? modal_amplitude(snaps[k], mode, mass) / a0 : 0;
    if (sphere) std::printf("| %.4g | %.8f | %.8f | %.10g |\n", times[k], ratio, std::exp(-first * times[k]), mass.dot(snaps[k]));
    else std::printf("| %.4g | %.8f | - | %.10g |\n", times[k], ratio, mass.dot(snaps[k]));
  }
  std::filesystem::create_directories(out_dir);
  std::ofstream csv(out_dir + "/heat.csv");
  if (!csv) throw Error("cannot write '" + out_dir + "/heat.csv'");
  csv << "row,x,y,z";
  for (double t : times) csv << ",u(" << t << ")";
  csv << '\n';
  csv.precision(12);
  for (Eigen::Index i = 0; i < n; ++i) {
    csv << i << ',' << positions(i, 0) << ',' << positions(i, 1) << ',' << positions(i, 2);
    for (const auto& snap : snaps) csv << ',' << snap[i];
    csv << '\n';
  }
  std::vector<std::pair<std::string, Eigen::VectorXd>> fields;
  std::vector<app::SurfacePanel> panels;
  for (std::size_t k = 0; k < snaps.size(); ++k) {
    fields.emplace_back("u_" + std::to_string(k), snaps[k]);
    char title[64];
    std::snprintf(title, sizeof title, "tau = %.3g", times[k]);
    panels.push_back({title, snaps[k]});
  }
  surface::save_ply(fe.surfels, fields, out_dir + "/heat.ply");
  app::save_surface_panels(out_dir + "/heat.svg", fe.surfels, fe.normals.normals, panels, 3, "Heat flow (" + initial + ") on the " + fe.name);
  std::printf("\nwrote %s/heat.csv\nwrote %s/heat.ply\nwrote %s/heat.svg\n", out_dir.c_str(), out_dir.c_str(), out_dir.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"digilap-heat: heat diffusion du/dtau = L u on the contour of a digitized shape.\n"
               "Writes <out>/heat.csv (one column per snapshot) and <out>/heat.svg."};
  app::FrontEndOptions fe_options;
  HeatLaplacianOptions op_options;
  std::string initial = "cosine", scheme = "cn", solver = "auto", out_dir = "out/heat";
  double tau = 0.5;
  int steps = 100, snapshots = 5;
  bool quiet = false, matrix_free = false;
  app::add_front_end_options(app, fe_options);
  app::add_operator_options(app, op_options);
  app.add_option("--initial", initial, "Initial temperature: cosine (cos(2 pi s / P)), bump (Gaussian of width P/20), dirac")
      ->check(CLI::IsMember({"cosine", "bump", "dirac"}))
      ->capture_default_str();
  app.add_option("--tau", tau, "Final time")->capture_default_str();
  app.add_option("--steps", steps, "Time steps")->capture_default_str();
  app.add_option("--scheme", scheme, "euler (implicit Euler) or cn (Crank-Nicolson)")
      ->check(CLI::IsMember({"euler", "cn"}))
      ->capture_default_str();
  app.add_option("--solver", solver,
                 "Each step's linear system: auto (curves: factorization; surfaces: conjugate gradients, whose memory "
                 "stays O(N) where the factors would fill in), factorization, or cg")
      ->check(CLI::IsMember({"auto", "factorization", "cg"}))
      ->capture_default_str();
  app.add_flag("--matrix-free", matrix_free,
               "Surfaces: never store L; each step by conjugate gradients on products computed on the fly (memory O(N))");
  app.add_option("--snapshots", snapshots, "Snapshots written and drawn (at equal times, tau = 0 included)")
      ->capture_default_str();
  app::add_output_options(app, out_dir, quiet);
  CLI11_PARSE(app, argc, argv);

  return app::guarded_main([&] {
    app::check_options_for_input(app, fe_options);
    if (!(tau > 0) || !std::isfinite(tau)) throw Error("--tau must be > 0 and finite");
    if (steps < 1) throw Error("--steps must be >= 1");
    if (snapshots < 2 || snapshots > steps + 1) throw Error("--snapshots must be in [2, steps + 1]");
    app::Progress progress(quiet);
    if (app::is_surface_input(fe_options))
      return surface_heat(fe_options, op_options, initial, tau, steps, snapshots, scheme == "euler", solver_named(solver), matrix_free,
                          out_dir, progress);
    if (matrix_free) throw Error("digilap-heat --matrix-free is for surfaces and volumes (contours: digilap-spectrum --matrix-free)");
    const app::FrontEnd fe = app::run_front_end(fe_options, progress);
    const ContourOperator op = app::build_operator(fe, op_options, progress);

    // Initial temperature on contour 0 (the others start cold).
    const Eigen::Index n0 = op.row_offset[1];
    const double P = op.contour_length[0];
    Eigen::VectorXd u0 = Eigen::VectorXd::Zero(op.rows()), mode = Eigen::VectorXd::Zero(op.rows());
    for (Eigen::Index r = 0; r < n0; ++r) {
      const double s = op.arclength[r], d = std::min(s, P - s), sigma = P / 20;
      mode[r] = std::cos(2 * kPi * s / P);
      if (initial == "cosine") u0[r] = mode[r];
      else if (initial == "bump") u0[r] = std::exp(-d * d / (2 * sigma * sigma));
    }
    if (initial == "dirac") {
      if (!(op.mass[0] > 0)) throw Error("the first element has zero measure: choose another initial function");
      u0[0] = 1.0 / op.mass[0];  // unit heat
    }

    progress.start(solver_named(solver) == HeatSolver::ConjugateGradient ? "heat flow setup" : "factorize");
    const HeatFlow flow(op, tau / steps, scheme == "euler" ? TimeScheme::ImplicitEuler : TimeScheme::CrankNicolson,
                        solver_named(solver));
    progress.finish();
    const auto [snaps, times] = run_flow([&](const Eigen::VectorXd& u) { return flow.step(u); }, u0, tau, steps, snapshots, progress);

    const double omega2 = std::pow(2 * kPi / P, 2), a0 = modal_amplitude(u0, mode, op.mass);
    std::printf("# %s, h = %g, N = %ld, l = %.4g, R = %.4g, t = %.4g%s, P (estimated) = %.8g, scheme %s, dt = %g\n",
                fe.name.c_str(), fe.contours.h, static_cast<long>(op.rows()), fe.measures.length_scale,
                fe.measures.normal_radius, op.t, app::per_contour_note(op.part_t).c_str(), P, scheme.c_str(), tau / steps);
    std::printf("| tau | first-mode amplitude a(tau)/a(0) | exp(-(2 pi/P)^2 tau) | relative difference | total heat |\n");
    std::printf("|---|---|---|---|---|\n");
    for (std::size_t k = 0; k < snaps.size(); ++k) {
      const double ratio = modal_amplitude(snaps[k], mode, op.mass) / a0, exact = std::exp(-omega2 * times[k]);
      std::printf("| %.4g | %.8f | %.8f | %.2e | %.10g |\n", times[k], ratio, exact, ratio / exact - 1,
                  op.mass.dot(snaps[k]));
    }

    std::filesystem::create_directories(out_dir);
    const std::string csv_path = out_dir + "/heat.csv", svg_path = out_dir + "/heat.svg";
    std::ofstream csv(csv_path);
    if (!csv) throw Error("cannot write '" + csv_path + "'");
    csv << "row,contour,index,x,y,s";
    for (double t : times) csv << ",u(" << t << ")";
    csv << '\n';
    csv.precision(12);
    for (Eigen::Index r = 0; r < op.rows(); ++r) {
      const auto [c, i] = op.element(r);
      csv << r << ',' << c << ',' << i << ',' << op.positions(r, 0) << ',' << op.positions(r, 1) << ',' << op.arclength[r];
      for (const auto& snap : snaps) csv << ',' << snap[r];
      csv << '\n';
    }
    std::vector<app::ContourPanel> panels;
    for (std::size_t k = 0; k < snaps.size(); ++k) {
      char title[64];
      std::snprintf(title, sizeof title, "tau = %.3g", times[k]);
      panels.push_back({title, snaps[k]});
    }
    app::save_contour_panels(svg_path, op.positions, op.row_offset, panels, std::min<int>(3, static_cast<int>(panels.size())),
                             "Heat flow (" + initial + ") on the " + fe.name + ", h = " + std::to_string(fe.contours.h).substr(0, 6));
    std::printf("\nwrote %s\nwrote %s\n", csv_path.c_str(), svg_path.c_str());
    return 0;
  });
}
