// digilap-operator: shape -> L_h, written as Matrix Market files and a CSV of the elements.
#include "../common/app_common.hpp"

#include "digilap/surface/heat_laplacian.hpp"
#include "digilap/surface/ply.hpp"

#include <cstdio>
#include <filesystem>
#include <map>

using namespace digilap;

int main(int argc, char** argv) {
  CLI::App app{"digilap-operator: the heat-kernel Laplace-Beltrami operator L_h of a digitized shape.\n"
               "Writes L.mtx, A.mtx (= M L, symmetric), M.mtx (masses) and elements.csv; with --format npz,\n"
               "L.npz, A.npz, M.npz (scipy.sparse.load_npz) and elements.npz (numpy.load)."};
  app::FrontEndOptions fe_options;
  HeatLaplacianOptions op_options;
  std::string out_dir = "out/operator";
  bool quiet = false;
  FileFormat format = FileFormat::MatrixMarket;
  app::add_front_end_options(app, fe_options);
  app.add_option("--format", format, "mtx (Matrix Market text) or npz (binary, for SciPy and NumPy)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, FileFormat>{{"mtx", FileFormat::MatrixMarket},
                                                                          {"npz", FileFormat::Npz}},
                                          CLI::ignore_case)
                      .description(""))
      ->type_name("{mtx,npz}")
      ->default_str("mtx");
  app::add_operator_options(app, op_options);
  app::add_output_options(app, out_dir, quiet);
  CLI11_PARSE(app, argc, argv);

  return app::guarded_main([&] {
    app::check_options_for_input(app, fe_options);
    app::Progress progress(quiet);
    if (app::is_surface_input(fe_options)) {  // a surface or a volume: L, A, M and surfels.ply
      const app::SurfaceFrontEnd sfe = app::run_surface_front_end(fe_options, progress);
      progress.start("operator");
      const surface::SurfaceOperator op = surface::heat_laplacian(sfe.surfels, sfe.measures, op_options);
      progress.finish();
      progress.start("write");
      std::vector<std::string> paths = save_operator(op, out_dir, "", format);
      paths.push_back(out_dir + "/surfels.ply");
      surface::save_ply(sfe.surfels, {{"mu", sfe.measures.mu}}, paths.back());
      progress.finish();
      std::printf("surface %s, h = %g: N = %ld surfels, nnz(L) = %ld, area %.8g", sfe.name.c_str(), sfe.voxels.h(),
                  static_cast<long>(op.rows()), static_cast<long>(op.L.nonZeros()), sfe.measures.total_area());
      if (sfe.shape) std::printf(" (exact %.8g)", sfe.shape->area());
      std::printf("\nlength scale l = %.6g, II radius R = %.6g, t = %.6g, cut = k sqrt(t) = %.6g\n", sfe.measures.length_scale,
                  sfe.measures.normal_radius, op.t, op.cut);
      for (const auto& path : paths) std::printf("wrote %s\n", path.c_str());
      return 0;
    }
    const app::FrontEnd fe = app::run_front_end(fe_options, progress);
    const ContourOperator op = app::build_operator(fe, op_options, progress);
    progress.start("write");
    const auto paths = save_operator(op, out_dir, "", format);
    progress.finish();
    std::printf("shape %s, h = %g: %zu contour(s), N = %ld elements, nnz(L) = %ld\n", fe.name.c_str(),
                fe.contours.h, fe.contours.contours.size(), static_cast<long>(op.rows()),
                static_cast<long>(op.L.nonZeros()));
    std::printf("length scale l = %.6g, II radius R = %.6g, t = %.6g%s, cut = k sqrt(t) = %.6g, estimated length %.10g",
                fe.measures.length_scale, fe.measures.normal_radius, op.t, app::per_contour_note(op.part_t).c_str(), op.cut,
                fe.measures.total_length());
    if (fe.shape)
      std::printf(" (exact %.10g, relative error %.2e)", fe.exact_length, fe.measures.total_length() / fe.exact_length - 1.0);
    std::printf("\n");
    for (const auto& p : paths) std::printf("wrote %s\n", p.c_str());
    return 0;
  });
}
