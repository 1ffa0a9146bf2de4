// Files: Matrix Market round trip, CSV content, clear errors.
#include "digilap/error.hpp"
#include "digilap/io.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

using namespace digilap;

namespace {
ContourOperator small_operator() {
  const DigitalSet set = digitize(Flower(), 0.1);
  const ContourSet cs = track_contours(set);
  return heat_laplacian(cs, measures(cs, ii_normals(set, cs)));
}
std::string scratch(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "digilap_test_io";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}
}  // namespace

TEST(IO, MatrixMarketRoundTripIsExact) {
  const ContourOperator op = small_operator();
  const std::string path = scratch("L.mtx");
  save_matrix_market(op.L, path);
  const SparseMatrix back = load_matrix_market(path);
  ASSERT_EQ(back.rows(), op.L.rows());
  ASSERT_EQ(back.nonZeros(), op.L.nonZeros());
  // 17 significant digits: every double comes back bit for bit.
  EXPECT_EQ((Eigen::MatrixXd(back) - Eigen::MatrixXd(op.L)).cwiseAbs().maxCoeff(), 0.0);
}

TEST(IO, SaveOperatorWritesAllFilesAndAConsistentCsv) {
  const ContourOperator op = small_operator();
  const auto dir = scratch("op_dir");
  std::filesystem::remove_all(dir);
  const auto paths = save_operator(op, dir, "flower_");
  ASSERT_EQ(paths.size(), 4u);
  for (const auto& p : paths) EXPECT_TRUE(std::filesystem::exists(p)) << p;
  std::ifstream csv(paths[3]);
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "row,contour,index,x,y,mu,s");
  long rows = 0;
  double mu_sum = 0;
  while (std::getline(csv, line)) {
    ++rows;
    // mu is the 6th field.
    std::size_t pos = 0;
    for (int f = 0; f < 5; ++f) pos = line.find(',', pos) + 1;
    mu_sum += std::stod(line.substr(pos, line.find(',', pos) - pos));
  }
  EXPECT_EQ(rows, op.rows());
  EXPECT_NEAR(mu_sum, op.mass.sum(), 1e-12);
  const SparseMatrix M = load_matrix_market(paths[2]);
  EXPECT_EQ((Eigen::VectorXd(M.diagonal()) - op.mass).cwiseAbs().maxCoeff(), 0.0);
}

TEST(IO, UnwritableOrMissingPathsAreClearErrors) {
  const ContourOperator op = small_operator();
  EXPECT_THROW(save_matrix_market(op.L, "/nonexistent_dir/x/L.mtx"), Error);
  EXPECT_THROW(save_elements_csv(op, "/nonexistent_dir/x/e.csv"), Error);
  EXPECT_THROW(load_matrix_market("/nonexistent_dir/none.mtx"), Error);
}
