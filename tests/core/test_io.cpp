// core/io.hpp: matrix files of any operator. Matrix Market read back bit for bit, SciPy's .npz
// layout, an operator's files, and every malformed file refused with the line.
#include "digilap/core/io.hpp"
#include "digilap/core/error.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <cstring>
#include <limits>

using namespace digilap;

namespace {
std::string scratch(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "digilap_test_core_io";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}
std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}
// A matrix of awkward doubles: thirds, a subnormal, the extremes, negative zero's neighbours.
SparseMatrix awkward_matrix() {
  SparseMatrix m(4, 5);
  m.insert(0, 0) = 1.0 / 3;
  m.insert(0, 4) = -0.1;
  m.insert(1, 2) = std::numeric_limits<double>::denorm_min();
  m.insert(2, 1) = std::numeric_limits<double>::max();
  m.insert(2, 3) = -std::numeric_limits<double>::min();
  m.insert(3, 3) = 2.0 / 3 * 1e-300;
  m.makeCompressed();
  return m;
}
}  // namespace

// The shortest text that reads back to the same double: every value comes back bit for bit.
TEST(CoreIO, MatrixMarketRoundTripIsExact) {
  const SparseMatrix m = awkward_matrix();
  const std::string path = scratch("awkward.mtx");
  save_matrix_market(m, path);
  const SparseMatrix back = load_matrix_market(path);
  ASSERT_EQ(back.rows(), 4);
  ASSERT_EQ(back.cols(), 5);
  ASSERT_EQ(back.nonZeros(), m.nonZeros());
  for (int k = 0; k < m.nonZeros(); ++k) {
    EXPECT_EQ(back.innerIndexPtr()[k], m.innerIndexPtr()[k]);
    EXPECT_EQ(std::memcmp(&back.valuePtr()[k], &m.valuePtr()[k], sizeof(double)), 0) << m.valuePtr()[k];
  }
}

// A matrix built by insert() (uncompressed storage, free slots between its rows) is written as
// its entries: the file held the free slots too, and more entries than its header declared.
TEST(CoreIO, UncompressedMatricesAreWrittenAsTheirEntries) {
  SparseMatrix m(3, 3);
  m.reserve(Eigen::VectorXi::Constant(3, 4));  // 4 slots per row, 1 used
  for (int i = 0; i < 3; ++i) m.insert(i, (i + 1) % 3) = 0.5 + i;
  ASSERT_FALSE(m.isCompressed());
  save_matrix_market(m, scratch("uncompressed.mtx"));
  const SparseMatrix back = load_matrix_market(scratch("uncompressed.mtx"));
  EXPECT_EQ(back.nonZeros(), 3);
  EXPECT_EQ((Eigen::MatrixXd(back) - Eigen::MatrixXd(m)).cwiseAbs().maxCoeff(), 0.0);
  save_npz(m, scratch("uncompressed.npz"));  // refused before: now written as its compressed form
  SparseMatrix c = m;
  c.makeCompressed();
  const std::string values(reinterpret_cast<const char*>(c.valuePtr()), sizeof(double) * 3);
  EXPECT_NE(read_all(scratch("uncompressed.npz")).find(values), std::string::npos);
}

// SciPy's csr layout (checked against scipy.sparse.load_npz by tests/npz_matches_mtx.py): the
// arrays' bytes stand in the uncompressed archive as they are in memory.
TEST(CoreIO, NpzHoldsTheCompressedRowArraysVerbatim) {
  const SparseMatrix m = awkward_matrix();
  const std::string path = scratch("awkward.npz");
  save_npz(m, path);
  const std::string bytes = read_all(path);
  ASSERT_EQ(bytes.compare(0, 4, "PK\x03\x04"), 0);
  for (const char* member : {"data.npy", "indices.npy", "indptr.npy", "format.npy", "shape.npy"})
    EXPECT_NE(bytes.find(member), std::string::npos) << member;
  const std::string values(reinterpret_cast<const char*>(m.valuePtr()), sizeof(double) * m.nonZeros());
  EXPECT_NE(bytes.find(values), std::string::npos);
  EXPECT_NE(bytes.find("'descr': '<f8'"), std::string::npos);
}

// Any operator: L, A, M (A left out when not assembled), Matrix Market or .npz, M's diagonal the mass.
TEST(CoreIO, SaveOperatorWritesItsMatrices) {
  HeatOperator op;
  op.dimension = 2;
  op.mass = Eigen::Vector3d(0.5, 0.25, 0.125);
  op.M.resize(3, 3);
  for (int i = 0; i < 3; ++i) op.M.insert(i, i) = op.mass[i];
  op.L = op.M;
  const std::string dir = scratch("operator");
  std::filesystem::remove_all(dir);
  const auto paths = save_operator(op, dir, "x_");
  ASSERT_EQ(paths.size(), 2u);  // no A
  EXPECT_EQ(std::filesystem::path(paths[0]).filename(), "x_L.mtx");
  EXPECT_EQ(std::filesystem::path(paths[1]).filename(), "x_M.mtx");
  EXPECT_EQ((Eigen::VectorXd(load_matrix_market(paths[1]).diagonal()) - op.mass).cwiseAbs().maxCoeff(), 0.0);
  op.A = op.L;
  const auto npz = save_operator(op, dir, "", FileFormat::Npz);
  ASSERT_EQ(npz.size(), 3u);
  EXPECT_EQ(std::filesystem::path(npz[1]).filename(), "A.npz");
  for (const auto& p : npz) EXPECT_TRUE(std::filesystem::exists(p)) << p;
  EXPECT_THROW(save_operator(op, "/proc/no_such_dir/op"), Error);
}

TEST(CoreIO, UnwritableOrMissingPathsAreClearErrors) {
  const SparseMatrix m = awkward_matrix();
  EXPECT_THROW(save_matrix_market(m, "/nonexistent_dir/x/L.mtx"), Error);
  EXPECT_THROW(save_npz(m, "/nonexistent_dir/x/L.npz"), Error);
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
TEST(CoreIO, SymmetricMatrixMarketIsMirrored) {
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
TEST(CoreIO, MalformedMatrixMarketIsRefusedWithTheLine) {
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
