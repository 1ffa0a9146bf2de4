// curve/io.hpp: a contour operator's files (its matrices through core/io.hpp, tested in
// tests/core/test_io.cpp) and the element tables beside them.
#include "digilap/core/error.hpp"
#include "digilap/curve/io.hpp"

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
  EXPECT_THROW(save_elements_csv(op, "/nonexistent_dir/x/e.csv"), Error);
  EXPECT_THROW(save_elements_npz(op, "/nonexistent_dir/x/e.npz"), Error);
}

