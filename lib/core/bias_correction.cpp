#include "digilap/core/bias_correction.hpp"

#include "digilap/core/error.hpp"

#include <cmath>
#include <string>

namespace digilap {

Eigen::MatrixXd bias_corrected_laplacian(const LaplacianProduct& apply_l, const Eigen::VectorXd& t_of_row, const Eigen::MatrixXd& g,
                                         Eigen::MatrixXd* plain) {
  if (t_of_row.size() != g.rows())
    throw Error("bias_corrected_laplacian: " + std::to_string(t_of_row.size()) + " heat times for " + std::to_string(g.rows()) + " rows");
  for (Eigen::Index i = 0; i < t_of_row.size(); ++i)
    if (!(std::isfinite(t_of_row[i]) && t_of_row[i] >= 0))
      throw Error("bias_corrected_laplacian: the heat time of row " + std::to_string(i) + " is " + std::to_string(t_of_row[i]) +
                  ", not a finite t >= 0");
  auto product = [&](const Eigen::MatrixXd& x) {
    Eigen::MatrixXd y;
    apply_l(x, y);
    if (y.rows() != x.rows() || y.cols() != x.cols())
      throw Error("bias_corrected_laplacian: the product returned " + std::to_string(y.rows()) + " x " + std::to_string(y.cols()) +
                  " for " + std::to_string(x.rows()) + " x " + std::to_string(x.cols()));
    return y;
  };
  const Eigen::MatrixXd lg = product(g);
  const Eigen::MatrixXd smoothed = lg + t_of_row.asDiagonal() * product(lg);  // S L g, S = I + T L
  Eigen::MatrixXd corrected = lg - 0.5 * (t_of_row.asDiagonal() * product(smoothed));
  if (plain) *plain = lg;
  return corrected;
}

Eigen::VectorXd heat_time_of_rows(const std::vector<Eigen::Index>& row_offset, const std::vector<double>& part_t) {
  if (row_offset.size() != part_t.size() + 1)
    throw Error("heat_time_of_rows: " + std::to_string(part_t.size()) + " heat times for " +
                std::to_string(row_offset.empty() ? 0 : row_offset.size() - 1) + " parts");
  Eigen::VectorXd t(row_offset.back());
  for (std::size_t p = 0; p < part_t.size(); ++p) t.segment(row_offset[p], row_offset[p + 1] - row_offset[p]).setConstant(part_t[p]);
  return t;
}

Eigen::MatrixXd bias_corrected_laplacian(const HeatOperator& op, const Eigen::MatrixXd& g, Eigen::MatrixXd* plain) {
  if (g.rows() != op.rows())
    throw Error("bias_corrected_laplacian: " + std::to_string(g.rows()) + " rows for an operator of " + std::to_string(op.rows()));
  std::vector<double> part_t(op.parts());
  for (std::size_t p = 0; p < op.parts(); ++p) part_t[p] = op.time_of_part(p);
  const Eigen::VectorXd t = op.parts() > 0 ? heat_time_of_rows(op.row_offset, part_t) : Eigen::VectorXd::Constant(op.rows(), op.t);
  return bias_corrected_laplacian([&](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) { y = op.L * x; }, t, g, plain);
}

}  // namespace digilap
