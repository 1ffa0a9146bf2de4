#include "digilap/io.hpp"

#include "digilap/error.hpp"

#include <unsupported/Eigen/SparseExtra>

#include <filesystem>
#include <fstream>
#include <iomanip>

namespace digilap {

void save_matrix_market(const SparseMatrix& matrix, const std::string& path) {
  // Eigen's MarketIO writes 17 significant digits: the values round-trip exactly.
  if (!Eigen::saveMarket(matrix, path))
    throw Error("cannot write Matrix Market file '" + path + "' (check the directory exists and is writable)");
}

SparseMatrix load_matrix_market(const std::string& path) {
  if (!std::filesystem::exists(path)) throw Error("cannot read Matrix Market file '" + path + "': no such file");
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> m;
  if (!Eigen::loadMarket(m, path)) throw Error("cannot read Matrix Market file '" + path + "'");
  return SparseMatrix(m);
}

void save_elements_csv(const ContourOperator& op, const std::string& path) {
  std::ofstream out(path);
  if (!out) throw Error("cannot write CSV file '" + path + "' (check the directory exists and is writable)");
  out << "row,contour,index,x,y,mu,s\n" << std::setprecision(17);
  for (Eigen::Index r = 0; r < op.rows(); ++r) {
    const auto [c, i] = op.element(r);
    out << r << ',' << c << ',' << i << ',' << op.positions(r, 0) << ',' << op.positions(r, 1) << ','
        << op.mass[r] << ',' << op.arclength[r] << '\n';
  }
  if (!out) throw Error("error while writing '" + path + "' (disk full?)");
}

std::vector<std::string> save_operator(const ContourOperator& op, const std::string& directory,
                                       const std::string& prefix) {
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  if (ec) throw Error("cannot create directory '" + directory + "': " + ec.message());
  const std::filesystem::path dir(directory);
  const std::vector<std::string> paths = {(dir / (prefix + "L.mtx")).string(), (dir / (prefix + "A.mtx")).string(),
                                          (dir / (prefix + "M.mtx")).string(),
                                          (dir / (prefix + "elements.csv")).string()};
  save_matrix_market(op.L, paths[0]);
  save_matrix_market(op.A, paths[1]);
  save_matrix_market(op.M, paths[2]);
  save_elements_csv(op, paths[3]);
  return paths;
}

}  // namespace digilap
