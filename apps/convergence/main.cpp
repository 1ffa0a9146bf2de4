// digilap-convergence: the paper's Figure 5 as one command. Sweeps h, compares operators
// against the exact Laplace-Beltrami operator, prints a table, writes CSV and an SVG figure.
#include "digilap/core/constants.hpp"
#include "../common/app_common.hpp"
#include "digilap/surface/matrix_free.hpp"
#include "../common/svg_plot.hpp"

#include "digilap/surface/ground_truth.hpp"
#include "digilap/surface/heat_laplacian.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <tuple>

using namespace digilap;

namespace {

// The 3D experiment (SPEC §7): the surface's operator on g = x^2 or xy (coordinates relative to
// the centre), II normals ("ii") or exact ones ("exact"), against Delta_S g = tr(Hess g) -
// <n, Hess g n> - 2 H <grad g, n> at the closest points; a table, convergence.csv and the
// log-log figure.
int surface_convergence(const std::string& spec, const std::string& function, std::vector<double> steps,
                        const HeatLaplacianOptions& base, double k_R, double length_scale, const std::vector<double>& centre,
                        double rotate_degrees, bool matrix_free, bool bias_correction,
                        const std::vector<std::string>& normal_variants, const std::string& out_dir, app::Progress& progress) {
  auto shape = surface::make_surface(spec);
  surface::sample_test_function(*shape, function, Eigen::MatrixX3d(0, 3));  // an unknown name refused before any work
  const Eigen::Vector3d c = centre.empty() ? Eigen::Vector3d(0.0123, -0.0371, 0.0217) : Eigen::Vector3d(centre[0], centre[1], 0);
  shape->set_pose(c, Eigen::AngleAxisd(rotate_degrees * kPi / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix());
  const double kR = app::ii_k_R(k_R, 2);
  struct Row {
    double h, t, l, error;
    std::string variant, estimate;  // normals; "L" (L g) or "bias-corrected" (L_c g)
    Eigen::Index n, nnz;
  };
  std::vector<std::string> estimates{"L"};
  if (bias_correction) estimates.push_back("bias-corrected");
  std::vector<Row> rows;
  for (std::size_t s = 0; s < steps.size(); ++s) {
    const double h = steps[s];
    const surface::VoxelSet voxels = surface::digitize(*shape, h);
    const surface::SurfelSet surfels = surface::extract_surfels(voxels);
    const surface::SurfelNormals ii = surface::ii_normals(voxels, surfels, {kR, length_scale});
    for (const std::string& variant : normal_variants) {
      const surface::SurfelNormals normals = variant == "ii" ? ii : surface::exact_normals(*shape, surfels, ii.length_scale);
      const surface::SurfelMeasures mu = surface::measures(surfels, normals);
      const surface::SurfaceTestSamples exact = surface::sample_test_function(*shape, function, surfels.centres());
      const Eigen::VectorXd& g = exact.values;
      const Eigen::Index n_rows = g.size();
      // One product L g per h and normals (three with --bias-correction: L_c g, of which L g is
      // the first): assembled, or (--matrix-free) on the fly in O(N) memory, which is what
      // reaches h = 0.005 (the assembled L would take 10^10 bytes there).
      Eigen::VectorXd Lg, corrected;
      double t = 0;
      Eigen::Index nnz = -1;
      Eigen::MatrixXd y;
      if (matrix_free) {
        const surface::MatrixFreeSurfaceOperator op(surfels, mu, base);
        if (bias_correction) corrected = surface::bias_corrected_laplacian(op, g, &y).col(0);
        else op.apply_laplacian(g, y);
        t = op.t();
      } else {
        const surface::SurfaceOperator op = surface::heat_laplacian(surfels, mu, base);
        if (bias_correction) corrected = bias_corrected_laplacian(op, g, &y).col(0);
        else y = op.L * g;
        t = op.t, nnz = op.L.nonZeros();
      }
      Lg = y.col(0);
      rows.push_back({h, t, ii.length_scale, surface::relative_max_error(Lg, exact), variant, "L", n_rows, nnz});
      if (bias_correction)
        rows.push_back({h, t, ii.length_scale, surface::relative_max_error(corrected, exact), variant, "bias-corrected", n_rows, nnz});
    }
    progress.bar("sweep", static_cast<double>(s + 1) / static_cast<double>(steps.size()));
  }
  progress.end_bar();
  const std::string k_R_text = kR > 0 ? std::to_string(kR) : "clamp((l/h)^(1/3)/2, 1, 1.5)";
  std::printf("# %s, g = %s, R = k_R h^(1/3) l^(2/3) with k_R = %s, t = %g h^(2/3) l^(4/3), k = %g, l %s\n",
              shape->name().c_str(), function.c_str(), k_R_text.c_str(), base.c_t, base.k,
              length_scale > 0 ? "given" : "measured at each h");
  std::printf("| h | normals | estimate | N | nnz | l | t | rel max err |\n|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows)
    std::printf("| %g | %s | %s | %ld | %s | %.3g | %.3g | %.3f%% |\n", r.h, r.variant.c_str(), r.estimate.c_str(),
                static_cast<long>(r.n), r.nnz < 0 ? "(matrix-free)" : std::to_string(r.nnz).c_str(), r.l, r.t, 100 * r.error);
  std::filesystem::create_directories(out_dir);
  std::ofstream csv(out_dir + "/convergence.csv");
  if (!csv) throw Error("cannot write '" + out_dir + "/convergence.csv'");
  csv << "surface,function,h,normals,N,nnz,length_scale,t,relative_max_error,estimate\n";
  csv.precision(10);
  app::LogLogPlot plot;
  plot.title = "Laplace-Beltrami of " + function + " on the " + shape->name() + " (max error / max |Δg|)";
  plot.x_label = "grid step h";
  plot.y_label = "relative max error";
  std::printf("\n| normals | estimate | rel max err at h = %g | slope (all h) |\n|---|---|---|---|\n", steps.back());
  for (const std::string& estimate : estimates)
    for (const std::string& variant : normal_variants) {
      app::PlotSeries series;
      for (const Row& r : rows)
        if (r.variant == variant && r.estimate == estimate) {
          series.x.push_back(r.h), series.y.push_back(r.error);
          csv << shape->name() << ',' << function << ',' << r.h << ',' << variant << ',' << r.n << ',' << r.nnz << ',' << r.l
              << ',' << r.t << ',' << r.error << ',' << estimate << '\n';
        }
      const double slope = app::loglog_slope(series.x, series.y, 0, series.x.size());
      const std::string name = estimate == "L" ? "heat" : "heat, bias-corrected";
      char label[128];
      if (series.x.size() < 2) std::snprintf(label, sizeof label, "%s, %s normals (one step: no slope)", name.c_str(), variant.c_str());
      else std::snprintf(label, sizeof label, "%s, %s normals (%.2f)", name.c_str(), variant.c_str(), slope);
      series.label = label;
      char slope_text[32];
      if (series.x.size() < 2) std::snprintf(slope_text, sizeof slope_text, "one step: no slope");
      else std::snprintf(slope_text, sizeof slope_text, "%.2f", slope);  // rounded, as in the figure's legend
      std::printf("| %s | %s | %.3f%% | %s |\n", variant.c_str(), estimate.c_str(), 100 * series.y.back(), slope_text);
      plot.series.push_back(series);
    }
  const double anchor = plot.series.front().y.back(), hmin = steps.back(), hmax = steps.front();
  app::PlotSeries one;
  one.label = "slope 1";
  one.dash = "12,3,2,3";
  one.markers = false;
  one.x = {hmin, hmax};
  one.y = {anchor, anchor * (hmax / hmin)};
  plot.series.push_back(one);
  plot.save(out_dir + "/convergence.svg");
  std::printf("\nwrote %s/convergence.csv\nwrote %s/convergence.svg\n", out_dir.c_str(), out_dir.c_str());
  return 0;
}

bool names_a_surface(const std::string& spec) {
  const std::string name = spec.substr(0, spec.find(':'));
  const std::vector<std::string> surfaces = surface::surface_names();
  return std::find(surfaces.begin(), surfaces.end(), name) != surfaces.end();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"digilap-convergence: max error of digital Laplace-Beltrami operators vs h (paper's Fig. 5).\n"
               "Writes <out>/convergence.csv and <out>/convergence.svg."};
  std::string shape_name = "flower", function = "x2", sampling = "closest", out_dir = "out/convergence";
  double k_R = 0, length_scale = 0.0, length_quantile = IINormalOptions{}.length_quantile;
  HeatLaplacianOptions base;
  std::vector<double> steps{0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001};
  std::vector<std::string> operators{"geodesic", "euclidean", "geodesic-exact", "dgtal", "richardson-euclidean",
                                     "dec-naive", "dec-mu"};
  bool quiet = false;
  std::string variants;
  for (const auto& n : operator_variant_names()) variants += (variants.empty() ? "" : ", ") + n;
  app.add_option("--shape", shape_name,
                 "Reference shape, with its own parameters after a colon (keys not given keep these defaults):\n" +
                     shape_syntax() + "e.g. --shape flower:R=1.5,v=0.3,k=4")
      ->capture_default_str();
  double rotate_degrees = 0;
  std::vector<double> centre;
  app.add_option("--rotate", rotate_degrees, "Rotate the shape by this angle (degrees, counter-clockwise)")->capture_default_str();
  app.add_option("--centre", centre, "Move the shape's centre to X,Y")->delimiter(',')->expected(2);
  app.add_option("--function", function, "Test function: x2, xy, cos1 .. cos9 (cos(2 pi m s / P))")->capture_default_str();
  auto* h_option = app.add_option("--h", steps, "Grid steps, coarse to fine (surfaces: 0.1 0.07 0.05 0.035 0.025)")
                       ->capture_default_str()
                       ->expected(1, 100);
  app.add_option("--operators", operators, "Operators to compare: " + variants)->capture_default_str()->expected(1, 20);
  app.add_option("--kR", k_R, "II radius constant: R = kR h^(1/3) l^(2/3)")->check(CLI::PositiveNumber)->default_str("2 (curves), 1 to 1.5 by l / h (surfaces)");
  app.add_option("--ct", base.c_t, "Heat time t = ct h^(2/3) l^(4/3)")->capture_default_str();
  app.add_option("--length-scale", length_scale,
                 "Length scale l (0: measured at each h on the pixels; 1: the former t = ct h^(2/3), R = kR h^(1/3))")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--length-quantile", length_quantile, "Which quantile of the radii of curvature a measured l is")
      ->check(CLI::Range(1e-6, 1.0 - 1e-6))
      ->capture_default_str();
  app.add_option("--k", base.k, "Kernel cut at k * sqrt(t)")->capture_default_str();
  app.add_option("--sampling", sampling, "Where g is sampled: closest (orthogonal projection) or radial")
      ->check(CLI::IsMember({"closest", "radial"}))
      ->capture_default_str();
  app::add_surface_kernel_option(app, base.surface_kernel);
  bool bias_correction = false;
  app.add_flag("--bias-correction", bias_correction,
               "Surfaces: also measure L_c g = L g - (t/2) L (I + t L) L g, the kernel's O(t) bias removed "
               "(three products more per h; core/bias_correction.hpp)");
  std::string normals = "both";
  app.add_option("--normals", normals,
                 "Surfaces: which normals the measures come from: ii (estimated on the voxels, what a user has), "
                 "exact (the shape's, isolating the operator's own error) or both (two rows per h; exact doubles the sweep)")
      ->check(CLI::IsMember({"ii", "exact", "both"}))
      ->capture_default_str();
  bool matrix_free = false;
  app.add_flag("--matrix-free", matrix_free,
               "Surfaces: each L g computed on the fly, never stored (memory O(N): reaches h = 0.005 on the unit sphere)");
  app::add_output_options(app, out_dir, quiet);
  // Images and volumes have no exact curve or surface to measure errors against: refused with
  // that reason rather than CLI11's "argument not expected".
  std::string image, volume;
  app.add_option("--image", image)->group("");
  app.add_option("--volume", volume)->group("");
  CLI11_PARSE(app, argc, argv);

  return app::guarded_main([&] {
    if (!image.empty() || !volume.empty())
      throw Error("digilap-convergence measures errors against an exact shape (--shape); images and volumes have "
                  "none: use digilap-spectrum, digilap-heat or digilap-operator with them");
    if (names_a_surface(shape_name)) {
      if (h_option->count() == 0) steps = {0.1, 0.07, 0.05, 0.035, 0.025};
      std::sort(steps.begin(), steps.end(), std::greater<>());
      for (double h : steps)
        if (!(h > 0) || !std::isfinite(h)) throw Error("every h must be > 0 and finite, got " + std::to_string(h));
      app::Progress progress(quiet);
      const std::vector<std::string> normal_variants =
          normals == "both" ? std::vector<std::string>{"ii", "exact"} : std::vector<std::string>{normals};
      return surface_convergence(shape_name, function, steps, base, k_R, length_scale, centre, rotate_degrees, matrix_free,
                                 bias_correction, normal_variants, out_dir, progress);
    }
    if (app.count("--surface-kernel") > 0) throw Error("--surface-kernel is for surfaces (--shape sphere, ellipsoid or torus)");
    if (bias_correction) throw Error("--bias-correction is for surfaces here (--shape sphere, ellipsoid or torus)");
    if (app.count("--normals") > 0)
      throw Error("--normals is for surfaces here (contours: choose operators with exact normals by name, e.g. "
                  "--operators geodesic geodesic-exact)");
    if (matrix_free) throw Error("--matrix-free is for surfaces here (contours: the convergence sweep is assembled; digilap-spectrum --matrix-free)");
    auto shape = make_shape(shape_name);
    if (!std::isfinite(rotate_degrees)) throw Error("--rotate must be a finite angle in degrees");
    if (rotate_degrees != 0 || !centre.empty())
      shape->set_pose(centre.empty() ? Eigen::Vector2d::Zero() : Eigen::Vector2d(centre[0], centre[1]),
                      rotate_degrees * kPi / 180);
    const TestFunction f = make_test_function(function);
    ConvergenceOptions o;
    o.steps = steps;
    std::sort(o.steps.begin(), o.steps.end(), std::greater<>());
    for (double h : o.steps)
      if (!(h > 0) || !std::isfinite(h)) throw Error("every h must be > 0 and finite, got " + std::to_string(h));
    o.ii.k_R = app::ii_k_R(k_R, 1);
    o.ii.length_scale = length_scale;
    o.ii.length_quantile = length_quantile;
    base.length_scale = length_scale;
    o.sampling = sampling == "closest" ? Sampling::ClosestPoint : Sampling::Radial;
    for (const auto& name : operators) o.variants.push_back(operator_variant(name, base));
    app::Progress progress(quiet);
    o.progress = [&](double fraction) { progress.bar("sweep", fraction); };
    const ConvergenceResult r = convergence_sweep(*shape, f, o);
    progress.end_bar();

    std::printf("# %s, g = %s, sampling %s, R = %g h^(1/3) l^(2/3), t = %g h^(2/3) l^(4/3), k = %g, l %s\n",
                shape->name().c_str(), f.name.c_str(), sampling.c_str(), o.ii.k_R, base.c_t, base.k,
                length_scale > 0 ? "given" : "measured at each h");
    std::printf("| h | operator | N | nnz | l | t | max err | mean err | rel max err | length rel err | front end (s) | assembly (s) | eval (s) |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (const auto& row : r.rows)
      std::printf("| %g | %s | %ld | %ld | %.3g | %.3g | %.4g | %.4g | %.3f%% | %.2e | %.3f | %.3f | %.3f |\n", row.h,
                  row.variant.c_str(), static_cast<long>(row.elements), static_cast<long>(row.nonzeros), row.length_scale, row.t,
                  row.max_error, row.mean_error, 100 * row.relative_max_error,
                  row.length_estimate / row.length_exact - 1, row.seconds_front_end, row.seconds_assembly,
                  row.seconds_evaluation);
    // A slope needs two grid steps with a non-zero error: say so instead of printing nan.
    auto slope_text = [](double slope) {
      char text[32];
      if (std::isnan(slope)) return std::string("one step: no slope");
      std::snprintf(text, sizeof text, "%.2f", slope);
      return std::string(text);
    };
    std::printf("\n| operator | rel max err at h = %g | slope (all h) | slope (finest 3) |\n|---|---|---|---|\n", o.steps.back());
    for (const auto& name : operators)
      std::printf("| %s | %.3f%% | %s | %s |\n", name.c_str(), 100 * r.of(name).back().relative_max_error,
                  slope_text(r.slope(name)).c_str(), slope_text(r.slope(name, 3)).c_str());

    std::filesystem::create_directories(out_dir);
    const std::string csv_path = out_dir + "/convergence.csv", svg_path = out_dir + "/convergence.svg";
    std::ofstream csv(csv_path);
    if (!csv) throw Error("cannot write '" + csv_path + "'");
    csv << "shape,function,h,operator,N,nnz,t,max_error,mean_error,relative_max_error,length_estimate,length_exact,"
           "seconds_front_end,seconds_assembly,seconds_evaluation\n";
    csv.precision(10);
    for (const auto& row : r.rows)
      csv << shape->name() << ',' << f.name << ',' << row.h << ',' << row.variant << ',' << row.elements << ','
          << row.nonzeros << ',' << row.t << ',' << row.max_error << ',' << row.mean_error << ','
          << row.relative_max_error << ',' << row.length_estimate << ',' << row.length_exact << ','
          << row.seconds_front_end << ',' << row.seconds_assembly << ',' << row.seconds_evaluation << '\n';

    app::LogLogPlot plot;
    plot.title = "Laplace-Beltrami of " + f.name + " on the " + shape->name() + " (max error / max |Δg|)";
    plot.x_label = "grid step h";
    plot.y_label = "relative max error";
    double anchor = 0;
    for (const auto& name : operators) {
      app::PlotSeries s;
      char label[96];
      std::snprintf(label, sizeof label, "%s (%s)", name.c_str(), slope_text(r.slope(name)).c_str());
      s.label = label;
      for (const auto& row : r.of(name)) s.x.push_back(row.h), s.y.push_back(row.relative_max_error);
      if (name == operators.front() && !s.y.empty()) anchor = s.y.back();
      plot.series.push_back(s);
    }
    // Reference slopes through the first operator's finest point.
    const double hmin = o.steps.back(), hmax = o.steps.front();
    const std::tuple<double, const char*, const char*> references[] = {
        {1.0 / 3, "slope 1/3", "2,3"}, {2.0 / 3, "slope 2/3", "8,4"}, {1.0, "slope 1", "12,3,2,3"}};
    for (const auto& [p, label, dash] : references) {
      app::PlotSeries s;
      s.label = label;
      s.dash = dash;
      s.markers = false;
      s.x = {hmin, hmax};
      s.y = {anchor, anchor * std::pow(hmax / hmin, p)};
      plot.series.push_back(s);
    }
    plot.save(svg_path);
    std::printf("\nwrote %s\nwrote %s\n", csv_path.c_str(), svg_path.c_str());
    return 0;
  });
}
