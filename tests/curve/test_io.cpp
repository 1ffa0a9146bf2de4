// Files: Matrix Market round trip, CSV content, clear errors.
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

namespace {
std::string write_file(const std::string& name, const std::string& text) {
  const std::string path = scratch(name);
  std::ofstream(path, std::ios::binary) << text;
  return path;
}
// The message of the error load_matrix_market throws on `text`, or "" when it reads.
std::string market_error(const std::string& text) {
  try {
    load_matrix_market(write_file("bad.mtx", text));
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

// Issue 15, item 4: what SciPy's mmwrite writes for a symmetric matrix (the lower triangle
// under a 'symmetric' header) comes back whole, not as one triangle.
TEST(IO, SymmetricMatrixMarketIsMirrored) {
  const std::string path = write_file("sym.mtx",
                                      "%%MatrixMarket matrix coordinate real symmetric\n%\n3 3 4\n1 1 2.5\n2 1 -1\n3 2 0.25\n3 3 4\n");
  const Eigen::MatrixXd m(load_matrix_market(path));
  Eigen::MatrixXd expected(3, 3);
  expected << 2.5, -1, 0, -1, 0, 0.25, 0, 0.25, 4;
  EXPECT_EQ((m - expected).cwiseAbs().maxCoeff(), 0.0);
  // Integer fields, CRLF line ends, comments of any length between entries, duplicates summed.
  const std::string comment = "%" + std::string(5000, 'x') + "\r\n";
  const Eigen::MatrixXd g(load_matrix_market(write_file(
      "int.mtx", "%%MatrixMarket matrix coordinate integer general\r\n" + comment + "2 3 3\r\n1 3 7\r\n" + comment + "2 1 -2\r\n2 1 -2\r\n")));
  ASSERT_EQ(g.rows(), 2);
  ASSERT_EQ(g.cols(), 3);
  EXPECT_EQ(g(0, 2), 7.0);
  EXPECT_EQ(g(1, 0), -4.0);
  EXPECT_EQ(g.cwiseAbs().sum(), 11.0);
}

// Everything else is refused with the file, the line and the reason (each of these was read
// without a word before: a 0 x 0 or zero matrix, a triangle, entries dropped).
TEST(IO, MalformedMatrixMarketIsRefusedWithTheLine) {
  const std::string head = "%%MatrixMarket matrix coordinate real general\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "the file is empty"},
      {"garbage\n1 2 3\n", "line 1: not a Matrix Market file"},
      {"%%MatrixMarket matrix array real general\n2 2\n1\n2\n3\n4\n", "format 'array' is not supported"},
      {"%%MatrixMarket matrix coordinate complex general\n1 1 1\n1 1 1 0\n", "field 'complex' is not supported"},
      {"%%MatrixMarket matrix coordinate pattern general\n1 1 1\n1 1\n", "field 'pattern' is not supported"},
      {"%%MatrixMarket matrix coordinate real skew-symmetric\n2 2 1\n2 1 1\n", "symmetry 'skew-symmetric'"},
      {head, "no size line"},
      {head + "3 3\n", "line 2: the size line must hold 3 integers"},
      {head + "3 3 5\n1 1 1\n", "line 3: truncated: 1 of the 5 declared entries"},
      {head + "3 3 999999\n1 1 1\n", "declares 999999 entries, more than a file of"},
      {head + "3 3 5\n1 1 1\n2 2 1\n3 3 1\n2 1 1\n1 2 1\n1 3 1\n", "line 8: more entries than the 5 declared"},
      {head + "3 3 2\n1 1 1\n2 2 1\n" + std::string(40, ' ') + "\n", ""},  // trailing blanks are fine
      {head + "3 3 3\n1 1 1\n4 1 2\n3 3 1\n", "line 4: entry (4, 1) is outside the 3 x 3 matrix"},
      {head + "3 3 2\n0 1 1\n3 3 1\n", "entry (0, 1) is outside"},
      {head + "3 3 2\n1 1 1\n2 2 x\n", "line 4: the value 'x' is not a finite number"},
      {head + "3 3 2\n1 1 1\n2 2 nan\n", "the value 'nan' is not a finite number"},
      {head + "3 3 2\n1 1 1\n2 2 1 5\n", "an entry must hold 3 numbers"},
      {head + "3 -3 1\n1 1 1\n", "the columns '-3' is not a non-negative integer"},
      {"%%MatrixMarket matrix coordinate real symmetric\n2 2 1\n1 2 1\n", "lower triangle only"},
      {"%%MatrixMarket matrix coordinate real symmetric\n2 3 1\n1 1 1\n", "must be square"},
      {head + "3 3 20\n" + std::string(200, '%') + "\n1 1 1\n", "truncated: 1 of the 20 declared entries"},
  };
  for (const auto& [text, fragment] : cases) {
    const std::string message = market_error(text);
    if (fragment.empty()) {
      EXPECT_EQ(message, "") << text;
      continue;
    }
    EXPECT_NE(message.find(fragment), std::string::npos) << "message: " << message << "\nfile: " << text.substr(0, 200);
    EXPECT_NE(message.find("bad.mtx"), std::string::npos) << message;
  }
}
