// digilap-spectrum: the smallest eigenvalues and eigenvectors of the digital Laplace-Beltrami
// operator, against the exact spectrum of the curve and the heat-kernel formula.
#include "digilap/core/constants.hpp"
#include "../common/app_common.hpp"
#include "../common/svg_contour.hpp"
#include "../common/svg_surface.hpp"
#include "label_batch.hpp"

#include "digilap/surface/heat_laplacian.hpp"
#include "digilap/surface/matrix_free.hpp"
#include "digilap/surface/ply.hpp"
#include "digilap/surface/volume.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

using namespace digilap;

namespace {

// A bar for LOBPCG: the residual's way down from its first value to the tolerance, on a log
// scale (the solver reports the largest wanted residual over the tolerance each iteration).
struct LobpcgBar {
  bool shown = false;
  double first = 0;
};
void attach_bar(SpectrumOptions& o, app::Progress& progress, LobpcgBar& bar) {
  o.progress = [&progress, &bar](int iteration, double residual) {
    bar.shown = true;
    if (iteration == 0) bar.first = std::max(residual, 1.0 + 1e-9);
    const double done = std::log(bar.first / std::max(residual, 1.0)) / std::log(bar.first);
    progress.bar("eigenpairs (LOBPCG)", std::clamp(done, 0.0, 1.0));
  };
}

// The 3D path (SPEC §7): surface -> voxels -> surfels -> II normals -> areas -> operator ->
// the smallest eigenpairs of (A, M); a table, eigenvalues.csv, surfels.ply (mu and the
// eigenvectors per surfel) and eigenvectors.svg.
int surface_spectrum(const app::FrontEndOptions& fe, const HeatLaplacianOptions& op_options, SpectrumOptions spectrum_options,
                     const std::string& out_dir, int draw, bool matrix_free, app::Progress& progress) {
  const app::SurfaceFrontEnd sfe = app::run_surface_front_end(fe, progress);
  const surface::SurfelSet& surfels = sfe.surfels;
  const surface::SurfelNormals& normals = sfe.normals;
  const auto& shape = sfe.shape;
  const std::string& name = sfe.name;
  const double h = sfe.voxels.h();
  const surface::SurfelMeasures& mu = sfe.measures;
  // The assembled operator, or (--matrix-free) products computed on the fly in O(N) memory.
  Spectrum s;
  double t = 0;
  LobpcgBar bar;
  attach_bar(spectrum_options, progress, bar);
  spectrum_options.memory_limit_bytes = op_options.memory_limit_bytes;  // --memory-limit covers the blocks
  if (matrix_free) {
    progress.start("matrix-free operator");
    const surface::MatrixFreeSurfaceOperator op(surfels, mu, op_options);
    progress.finish();
    s = smallest_eigenpairs(op, spectrum_options);
    t = op.t();
  } else {
    progress.start("operator");
    const surface::SurfaceOperator op = surface::heat_laplacian(surfels, mu, op_options);
    progress.finish();
    s = smallest_eigenpairs(op, spectrum_options);
    t = op.t;
  }
  if (bar.shown) progress.end_bar();
  const Eigen::VectorXd& lb = s.laplace_beltrami;
  // A volume has no exact area to print; a reference surface has.
  char exact_area[48] = "";
  if (shape) std::snprintf(exact_area, sizeof exact_area, " (exact %.6g)", shape->area());
  std::printf("# %s, h = %g, N = %ld surfels, area %.6g%s, l = %.4g, R = %.4g, t = %.4g%s%s\n", name.c_str(), h,
              static_cast<long>(surfels.size()), mu.total_area(), exact_area, mu.length_scale, mu.normal_radius, t,
              fe.normals == "exact" ? ", exact normals" : "", matrix_free ? ", matrix-free" : "");
  std::printf("# eigen-solver: %d iterations, %d products\n", s.iterations, s.operations);
  if (s.massless > 0)
    std::printf("# %ld surfels of zero area (II normal orthogonal to the surfel): off the support of mu, their "
                "eigenvector entries the heat-kernel average of their neighbours\n", static_cast<long>(s.massless));
  const bool sphere = shape && shape->name() == "sphere";
  const double r2 = sphere ? shape->area() / (4 * kPi) : 0;
  std::printf("lambda: the operator's eigenvalues; mu, their Laplace-Beltrami estimates: lambda = F(mu t)/t inverted, F the cut kernel's\n"
              "symbol (1 - exp(-mu t) less the cut's tail, docs/accuracy.md)%s\n",
              sphere ? "; exact: l (l + 1) / r^2, multiplicity 2l + 1" : "");
  std::printf("| k | lambda_k | mu_k |%s\n|---|---|---|%s\n", sphere ? " l | l(l+1)/r^2 | rel. diff |" : "", sphere ? "---|---|---|" : "");
  std::filesystem::create_directories(out_dir);
  std::ofstream values(out_dir + "/eigenvalues.csv");
  if (!values) throw Error("cannot write '" + out_dir + "/eigenvalues.csv'");
  values << "k,lambda,laplace_beltrami\n";
  values.precision(15);
  for (Eigen::Index k = 0; k < s.eigenvalues.size(); ++k) {
    std::printf("| %ld | %.6f | %.6f |", static_cast<long>(k), s.eigenvalues[k], lb[k]);
    if (sphere) {
      const int l = static_cast<int>(std::floor(std::sqrt(static_cast<double>(k))));  // k in [l^2, (l+1)^2)
      const double exact = l * (l + 1.0) / r2;
      if (l == 0) std::printf(" 0 | 0 | |");
      else std::printf(" %d | %.6f | %.2e |", l, exact, lb[k] / exact - 1);
    }
    std::printf("\n");
    values << k << ',' << s.eigenvalues[k] << ',' << lb[k] << '\n';
  }
  std::vector<std::pair<std::string, Eigen::VectorXd>> fields{{"mu", mu.mu}};
  std::vector<app::SurfacePanel> panels;
  for (Eigen::Index k = 1; k < s.eigenvalues.size(); ++k) {
    fields.emplace_back("phi_" + std::to_string(k), s.eigenvectors.col(k));
    char title[64];
    std::snprintf(title, sizeof title, "phi_%ld, mu = %.4g", static_cast<long>(k), lb[k]);
    if (static_cast<int>(panels.size()) < draw) panels.push_back({title, s.eigenvectors.col(k)});
  }
  // The heat kernel signature at five log-spaced times (issue 22): hks_1 ... hks_5 per surfel.
  bool has_nonzero = false;
  for (Eigen::Index k = 1; k < lb.size(); ++k) has_nonzero = has_nonzero || (std::isfinite(lb[k]) && lb[k] > 0);
  if (has_nonzero) {
    const std::vector<double> taus = heat_kernel_signature_times(s, 5);
    const Eigen::MatrixXd hks = heat_kernel_signature(s, taus);
    std::printf("# surfels.ply: hks_c = heat kernel signature sum_k exp(-mu_k tau_c) phi_k^2, tau =");
    for (std::size_t c = 0; c < taus.size(); ++c) {
      fields.emplace_back("hks_" + std::to_string(c + 1), hks.col(static_cast<Eigen::Index>(c)));
      std::printf(" %.4g", taus[c]);
    }
    std::printf("\n");
  }
  surface::save_ply(surfels, fields, out_dir + "/surfels.ply");
  if (!panels.empty())
    app::save_surface_panels(out_dir + "/eigenvectors.svg", surfels, normals.normals, panels, 4,
                             "Eigenvectors of the digital Laplace-Beltrami operator, " + name);
  std::printf("\nwrote %s/eigenvalues.csv\nwrote %s/surfels.ply\nwrote %s/eigenvectors.svg\n", out_dir.c_str(), out_dir.c_str(),
              out_dir.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"digilap-spectrum: smallest eigenpairs of -A x = lambda M x (Spectra, shift-and-invert;\n"
               "with --matrix-free: preconditioned LOBPCG on the matrix-free operator, for small h).\n"
               "The table compares lambda_k with (2 pi m / P)^2 and with m^2 lambda_1 (any simple closed contour).\n"
               "Writes <out>/eigenvalues.csv, <out>/eigenvectors.csv and <out>/eigenvectors.svg."};
  app::FrontEndOptions fe_options;
  HeatLaplacianOptions op_options;
  SpectrumOptions spectrum_options;
  spectrum_options.count = 11;
  std::string out_dir = "out/spectrum";
  int draw = 8;
  bool quiet = false, matrix_free = false, per_contour = false;
  app::add_front_end_options(app, fe_options);
  app::add_operator_options(app, op_options);
  auto* count_option = app.add_option("--count", spectrum_options.count, "Number of eigenpairs (50 with --labels)")->capture_default_str();
  auto* tolerance_option =
      app.add_option("--tolerance", spectrum_options.tolerance,
                     "The eigen-solver's relative tolerance: LOBPCG stops when every wanted residual |C x - lambda x| is at\n"
                     "most this times the spectrum's bound (eigenvalues then err by about its square). With --labels, which\n"
                     "writes eigenvalues alone, 1e-8 (they agree with 1e-10's to the 12 digits written); 1e-6 is enough for\n"
                     "ShapeDNA and takes about a third fewer products, see docs/benchmarks.md")
          ->check(CLI::Range(0.0, 1e-2))
          ->capture_default_str();
  app::LabelBatchOptions batch;
  std::string labels;
  app.add_option("--labels", labels,
                 "Volumes: the spectra of many structures in one run, 'all' or a list with ranges (3,5,10-12); writes\n"
                 "spectra.csv (one column per structure; rows area, volume, ev0 ...: Laplace-Beltrami estimates),\n"
                 "spectra_raw.csv and spectra_log.csv; a structure that fails is a column of NaN, its reason in the log");
  app.add_option("--names", batch.names, "With --labels: a table of names, 'index name ...' or FreeSurfer's LUT");
  app.add_option("--normalize", batch.normalize, "With --labels: none, surface (lambda area) or volume (lambda volume^(2/3))")
      ->transform(CLI::CheckedTransformer(std::map<std::string, app::Normalization>{{"none", app::Normalization::None},
                                                                                    {"surface", app::Normalization::Surface},
                                                                                    {"volume", app::Normalization::Volume}},
                                          CLI::ignore_case)
                      .description(""))
      ->type_name("{none,surface,volume}")
      ->default_str("none");
  app.add_flag("--reweight", batch.reweight, "With --labels: lambda_i / i (ShapeDNA's reweighting)");
  app.add_option("--draw", draw, "Eigenvectors drawn in the SVG")->capture_default_str();
  app.add_flag("--matrix-free", matrix_free,
               "Never store L: products computed on the fly and LOBPCG; memory O(N count) (curves: geodesic distance\n"
               "only; surfaces and volumes: the default, O(N) memory, preconditioned, see docs/benchmarks.md)");
  bool assembled = false;
  app.add_flag("--assembled", assembled,
               "Surfaces and volumes: store L and A and solve on them (the default there is matrix-free: faster on\n"
               "smooth surfaces, about as fast on atlases, always lighter; docs/benchmarks.md)");
  app.add_flag("--per-contour", per_contour,
               "The spectrum of each contour on its own (one table per contour; the shape descriptor of each object)");
  app::add_output_options(app, out_dir, quiet);
  CLI11_PARSE(app, argc, argv);

  return app::guarded_main([&] {
    app::check_options_for_input(app, fe_options);
    if (assembled && matrix_free) throw Error("--assembled and --matrix-free: give one of them");
    if (assembled && !app::is_surface_input(fe_options)) throw Error("--assembled is for surfaces and volumes (curves are assembled unless --matrix-free)");
    const bool surface_matrix_free = !assembled;  // surfaces and volumes
    app::Progress progress(quiet);
    if (!labels.empty()) {
      if (fe_options.volume.empty()) throw Error("--labels needs a segmentation (--volume FILE)");
      if (fe_options.label >= 0) throw Error("--labels and --label: give one of them");
      batch.labels = labels;
      batch.count = count_option->count() > 0 ? spectrum_options.count : 50;
      if (tolerance_option->count() > 0) batch.tolerance = spectrum_options.tolerance;
      batch.matrix_free = surface_matrix_free;
      app::run_label_batch(fe_options, op_options, batch, out_dir, progress);
      return 0;
    }
    if (!batch.names.empty() || batch.reweight || batch.normalize != app::Normalization::None)
      throw Error("--names, --normalize and --reweight go with --labels");
    if (app::is_surface_input(fe_options)) {
      if (per_contour) throw Error("--per-contour is for curves (per-surface spectra: smallest_eigenpairs_per_part)");
      return surface_spectrum(fe_options, op_options, spectrum_options, out_dir, draw, surface_matrix_free, progress);
    }
    const app::FrontEnd fe = app::run_front_end(fe_options, progress);
    // What the tables and files need, from either operator.
    // One spectrum for the whole set, or one per contour (vectors on the contour's own rows).
    std::vector<Spectrum> spectra;
    std::vector<double> lengths, contour_t;
    Eigen::MatrixX2d positions;
    Eigen::VectorXd arclength;
    std::vector<Eigen::Index> row_offset;
    double t = 0, P_est = 0;
    if (matrix_free) {
      progress.start("matrix-free operator");
      const MatrixFreeLaplacian op(fe.contours, fe.measures, op_options);
      progress.finish();
      spectrum_options.memory_limit_bytes = op_options.memory_limit_bytes;  // --memory-limit covers the blocks
      LobpcgBar bar;
      attach_bar(spectrum_options, progress, bar);
      if (per_contour) spectra = smallest_eigenpairs_per_contour(op, spectrum_options);
      else spectra = {smallest_eigenpairs(op, spectrum_options)};
      if (bar.shown) progress.end_bar();
      positions = op.positions();
      arclength = op.arclength();
      row_offset = op.row_offset();
      t = op.t();
      contour_t = op.contour_t();
      lengths = op.contour_lengths();
    } else {
      const ContourOperator op = app::build_operator(fe, op_options, progress);
      progress.start("eigenpairs");
      if (per_contour) spectra = smallest_eigenpairs_per_contour(op, spectrum_options);
      else spectra = {smallest_eigenpairs(op, spectrum_options)};
      progress.finish();
      positions = op.positions;
      arclength = op.arclength;
      row_offset = op.row_offset;
      t = op.t;
      contour_t = op.part_t;
      lengths = op.contour_length;
    }
    const Eigen::Index rows = positions.rows();
    const std::size_t contours = lengths.size();
    int iterations = 0, operations = 0;
    for (const Spectrum& s : spectra) iterations += s.iterations, operations += s.operations;

    // Images have no exact curve: the exact column then uses the estimated length.
    std::printf("# %s, h = %g, N = %ld, %zu contour(s), l = %.4g, R = %.4g, t = %.4g%s, %s: %d iterations, %d operator applications\n",
                fe.name.c_str(), fe.contours.h, static_cast<long>(rows), contours, fe.measures.length_scale,
                fe.measures.normal_radius, t, app::per_contour_note(contour_t).c_str(),
                matrix_free ? "matrix-free" : "factorized", iterations, operations);
    if (!per_contour && contours > 1)
      std::printf("# several contours: their spectra mix (one 0 per contour); m and the exact columns assume contour 0 "
                  "alone -- use --per-contour for a table per contour\n");
    std::filesystem::create_directories(out_dir);
    const std::string values_path = out_dir + "/eigenvalues.csv", vectors_path = out_dir + "/eigenvectors.csv",
                      svg_path = out_dir + "/eigenvectors.svg";
    std::ofstream values(values_path);
    if (!values) throw Error("cannot write '" + values_path + "'");
    values << (per_contour ? "contour," : "") << "k,m,lambda,laplace_beltrami,exact,heat_kernel_formula\n";
    values.precision(15);
    for (std::size_t part = 0; part < spectra.size(); ++part) {
      const Spectrum& s = spectra[part];
      const double P_est = lengths[part];
      const double P = fe.shape && contours == 1 ? fe.exact_length : P_est;
      const double t_part = contour_t[part];  // the joint table's m, P and t are contour 0's
      if (per_contour)
        std::printf("\n## contour %zu: %ld rows, P = %.8g (estimated %.8g), t = %.4g\n", part,
                    static_cast<long>(row_offset[part + 1] - row_offset[part]), P, P_est, t_part);
      else
        std::printf("# P = %.8g (estimated %.8g)\n", P, P_est);
      std::printf("lambda: the operator's eigenvalues; mu: their Laplace-Beltrami estimates (the cut heat kernel's symbol inverted,\n"
                  "about -ln(1 - lambda t)/t); the ratio column uses mu\n");
      std::printf("| k | m | lambda_k | (1-exp(-w^2 t))/t, w = 2 pi m/P_est | rel. diff | mu_k | (2 pi m/P)^2 | rel. diff | mu_k/mu_1 (m^2) | pair split |\n");
      std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
      for (Eigen::Index k = 0; k < s.eigenvalues.size(); ++k) {
        const int m = static_cast<int>((k + 1) / 2);
        const double exact = heat_kernel_eigenvalue(m, P, 0.0), formula = heat_kernel_eigenvalue(m, P_est, t_part);
        const double lambda = s.eigenvalues[k], mu = s.laplace_beltrami[k];
        const bool second_of_pair = m > 0 && k == 2 * m && k < s.eigenvalues.size();
        char split[32] = "", mu_text[48], mu_diff[32] = "", ratio[48] = "";
        if (second_of_pair) std::snprintf(split, sizeof split, "%.1e", std::abs(lambda - s.eigenvalues[k - 1]) / lambda);
        if (std::isinf(mu)) {
          std::snprintf(mu_text, sizeof mu_text, "undefined (lambda t >= 1)");
        } else {
          std::snprintf(mu_text, sizeof mu_text, m == 0 ? "%.3e" : "%.8f", mu);
          if (m > 0) {
            std::snprintf(mu_diff, sizeof mu_diff, "%.2e", mu / exact - 1);
            std::snprintf(ratio, sizeof ratio, "%.4f (%d)", mu / s.laplace_beltrami[1], m * m);
          }
        }
        if (m == 0)
          std::printf("| %ld | 0 | %.3e | 0 | | %s | 0 | | | |\n", static_cast<long>(k), lambda, mu_text);
        else
          std::printf("| %ld | %d | %.8f | %.8f | %.2e | %s | %.8f | %s | %s | %s |\n", static_cast<long>(k), m, lambda,
                      formula, lambda / formula - 1, mu_text, exact, mu_diff, ratio, split);
        if (per_contour) values << part << ',';
        values << k << ',' << m << ',' << lambda << ',' << mu << ',' << exact << ',' << formula << '\n';
      }
      if (s.undefined_estimates > 0)
        std::printf("%d eigenvalue(s) with lambda t >= 1 have no Laplace-Beltrami estimate (the heat-kernel operator's "
                    "spectrum stops at 1/t = %.4g): use a smaller t\n", s.undefined_estimates, 1 / t_part);
    }
    // Eigenvector k on every row: from the joint spectrum, or each contour's own k-th vector.
    Eigen::Index columns = 0;
    for (const Spectrum& s : spectra) columns = std::max(columns, s.eigenvalues.size());
    Eigen::MatrixXd phi = Eigen::MatrixXd::Zero(rows, columns);
    for (std::size_t part = 0; part < spectra.size(); ++part) {
      const Eigen::Index first = per_contour ? row_offset[part] : 0;
      const Eigen::MatrixXd& v = spectra[part].eigenvectors;
      phi.block(first, 0, v.rows(), v.cols()) = v;
    }
    std::ofstream vectors(vectors_path);
    if (!vectors) throw Error("cannot write '" + vectors_path + "'");
    vectors << "row,x,y,s";
    for (Eigen::Index k = 0; k < columns; ++k) vectors << ",phi_" << k;
    vectors << '\n';
    vectors.precision(12);
    for (Eigen::Index r = 0; r < rows; ++r) {
      vectors << r << ',' << positions(r, 0) << ',' << positions(r, 1) << ',' << arclength[r];
      for (Eigen::Index k = 0; k < columns; ++k) vectors << ',' << phi(r, k);
      vectors << '\n';
    }
    std::vector<app::ContourPanel> panels;
    for (Eigen::Index k = 1; k < columns && static_cast<int>(panels.size()) < draw; ++k) {
      char title[64];
      if (per_contour) std::snprintf(title, sizeof title, "phi_%ld of each contour", static_cast<long>(k));
      else std::snprintf(title, sizeof title, "phi_%ld, lambda = %.4g", static_cast<long>(k), spectra[0].eigenvalues[k]);
      panels.push_back({title, phi.col(k)});
    }
    if (!panels.empty())
      app::save_contour_panels(svg_path, positions, row_offset, panels, 4,
                               "Eigenvectors of the digital Laplace-Beltrami operator, " + fe.name);
    std::printf("\nwrote %s\nwrote %s\nwrote %s\n", values_path.c_str(), vectors_path.c_str(), svg_path.c_str());
    return 0;
  });
}
