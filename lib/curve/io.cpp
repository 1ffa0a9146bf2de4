// Files of contour operators: the element table (CSV, .npz) beside the matrices.
#include "digilap/curve/io.hpp"

#include "digilap/core/error.hpp"
#include "core/npy_zip.hpp"

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <vector>

namespace digilap {
inline namespace curve {

void save_elements_npz(const ContourOperator& op, const std::string& path) {
  const auto n = static_cast<std::size_t>(op.rows());
  std::vector<std::int64_t> contour(n), index(n);
  for (std::size_t c = 0; c + 1 < op.row_offset.size(); ++c)
    for (Eigen::Index r = op.row_offset[c]; r < op.row_offset[c + 1]; ++r) {
      contour[static_cast<std::size_t>(r)] = static_cast<std::int64_t>(c);
      index[static_cast<std::size_t>(r)] = r - op.row_offset[c];
    }
  const Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor> positions = op.positions;  // C order: x, y per row
  detail::write_npz(path, {{"contour", "<i8", {n}, contour.data(), n * 8},
                           {"index", "<i8", {n}, index.data(), n * 8},
                           {"positions", "<f8", {n, 2}, positions.data(), n * 16},
                           {"mu", "<f8", {n}, op.mass.data(), n * 8},
                           {"s", "<f8", {n}, op.arclength.data(), n * 8}});
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
                                       const std::string& prefix, FileFormat format) {
  std::vector<std::string> paths = save_operator(static_cast<const HeatOperator&>(op), directory, prefix, format);
  const bool npz = format == FileFormat::Npz;
  paths.push_back((std::filesystem::path(directory) / (prefix + (npz ? "elements.npz" : "elements.csv"))).string());
  if (npz) save_elements_npz(op, paths.back());
  else save_elements_csv(op, paths.back());
  return paths;
}

}  // namespace curve
}  // namespace digilap
