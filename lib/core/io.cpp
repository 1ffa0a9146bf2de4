#include "digilap/core/io.hpp"

#include "digilap/core/error.hpp"
#include "npy_zip.hpp"

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <string_view>
#include <vector>

namespace digilap {

namespace {

// Matrix Market text, written here rather than by Eigen's saveMarket (about 85 MB/s of text,
// 7 s for the two 1e7-nonzero matrices of the flower at h = 0.001): rows are formatted in
// parallel, a block of rows per task, with std::to_chars (the shortest text that reads back to
// the same double), and the blocks are written in row order, a batch at a time.
void write_market(const SparseMatrix& m, const std::string& path) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw Error("cannot write Matrix Market file '" + path + "' (check the directory exists and is writable)");
  const std::string head = "%%MatrixMarket matrix coordinate real general\n" + std::to_string(m.rows()) + " " +
                           std::to_string(m.cols()) + " " + std::to_string(m.nonZeros()) + "\n";
  out.write(head.data(), static_cast<std::streamsize>(head.size()));
  // Blocks of about 2^16 entries (3 MB of text), 16 at a time: 50 MB of buffers whatever the size.
  constexpr Eigen::Index kBlocksPerBatch = 16;
  const Eigen::Index rows = m.outerSize();
  const Eigen::Index rows_per_block = std::max<Eigen::Index>(1, (Eigen::Index(1) << 16) * rows / std::max<Eigen::Index>(1, m.nonZeros()));
  const Eigen::Index blocks = (rows + rows_per_block - 1) / rows_per_block;
  std::vector<std::string> text(static_cast<std::size_t>(kBlocksPerBatch));
  for (Eigen::Index first = 0; first < blocks; first += kBlocksPerBatch) {
    const Eigen::Index batch = std::min(kBlocksPerBatch, blocks - first);
#pragma omp parallel for schedule(dynamic, 1)
    for (Eigen::Index b = 0; b < batch; ++b) {
      std::string& s = text[static_cast<std::size_t>(b)];
      const Eigen::Index r0 = (first + b) * rows_per_block, r1 = std::min(rows, r0 + rows_per_block);
      const int k0 = m.outerIndexPtr()[r0], k1 = m.outerIndexPtr()[r1];
      s.resize(static_cast<std::size_t>(k1 - k0) * 48);  // two 10-digit indices, a 24-character double
      char* p = s.data();
      for (Eigen::Index r = r0; r < r1; ++r)
        for (int k = m.outerIndexPtr()[r]; k < m.outerIndexPtr()[r + 1]; ++k) {
          p = std::to_chars(p, p + 12, r + 1).ptr;
          *p++ = ' ';
          p = std::to_chars(p, p + 12, m.innerIndexPtr()[k] + 1).ptr;
          *p++ = ' ';
          p = std::to_chars(p, p + 25, m.valuePtr()[k]).ptr;
          *p++ = '\n';
        }
      s.resize(static_cast<std::size_t>(p - s.data()));
    }
    for (Eigen::Index b = 0; b < batch; ++b) out.write(text[b].data(), static_cast<std::streamsize>(text[b].size()));
  }
  if (!out) throw Error("error while writing '" + path + "' (disk full?)");
}

// A matrix built by insert() is in uncompressed storage, with unused slots between its rows:
// written as it is, the file held those slots as entries (and more than the header declared).
const SparseMatrix& compressed(const SparseMatrix& m, SparseMatrix& copy) {
  if (m.isCompressed()) return m;
  copy = m;
  copy.makeCompressed();
  return copy;
}

}  // namespace

void save_matrix_market(const SparseMatrix& matrix, const std::string& path) {
  SparseMatrix copy;
  write_market(compressed(matrix, copy), path);
}

void save_npz(const SparseMatrix& given, const std::string& path) {
  SparseMatrix copy;
  const SparseMatrix& matrix = compressed(given, copy);
  // scipy.sparse.save_npz's layout for a csr_matrix: data, indices, indptr, format, shape.
  static const char format[3] = {'c', 's', 'r'};
  const std::int64_t shape[2] = {matrix.rows(), matrix.cols()};
  const auto nnz = static_cast<std::size_t>(matrix.nonZeros()), rows = static_cast<std::size_t>(matrix.rows());
  detail::write_npz(path, {{"data", "<f8", {nnz}, matrix.valuePtr(), nnz * sizeof(double)},
                           {"indices", "<i4", {nnz}, matrix.innerIndexPtr(), nnz * sizeof(int)},
                           {"indptr", "<i4", {rows + 1}, matrix.outerIndexPtr(), (rows + 1) * sizeof(int)},
                           {"format", "|S3", {}, format, 3},
                           {"shape", "<i8", {2}, shape, sizeof shape}});
}

namespace {

// A strict reader, written here because Eigen's loadMarket accepts anything: an empty or
// garbage file gives a 0 x 0 matrix, a symmetric file keeps one triangle, out-of-range or
// missing entries pass silently. This one reads the coordinate format, real or integer,
// general or symmetric (the lower triangle, mirrored: what SciPy's mmwrite writes for a
// symmetric matrix), and refuses everything else with the file and the line.
class MarketReader {
public:
  MarketReader(std::string path, std::string text) : path_(std::move(path)), text_(std::move(text)) {}

  SparseMatrix read() {
    std::string_view line;
    if (!next_line(line)) fail("the file is empty");
    std::vector<std::string> banner = words(line);
    for (auto& w : banner) std::transform(w.begin(), w.end(), w.begin(), [](unsigned char c) { return std::tolower(c); });
    if (banner.size() != 5 || banner[0] != "%%matrixmarket" || banner[1] != "matrix")
      fail("not a Matrix Market file (the first line must be '%%MatrixMarket matrix coordinate real general')");
    if (banner[2] != "coordinate") fail("format '" + banner[2] + "' is not supported (only 'coordinate')");
    if (banner[3] != "real" && banner[3] != "integer" && banner[3] != "double")
      fail("field '" + banner[3] + "' is not supported (only 'real' or 'integer')");
    if (banner[4] != "general" && banner[4] != "symmetric")
      fail("symmetry '" + banner[4] + "' is not supported (only 'general' or 'symmetric')");
    const bool symmetric = banner[4] == "symmetric";
    do {
      if (!next_line(line)) fail("no size line (rows columns entries)");
    } while (is_comment_or_blank(line));
    const std::vector<std::string> size = words(line);
    if (size.size() != 3) fail("the size line must hold 3 integers (rows columns entries)");
    const long long rows = integer(size[0], "rows"), cols = integer(size[1], "columns"), entries = integer(size[2], "entries");
    if (rows > std::numeric_limits<int>::max() || cols > std::numeric_limits<int>::max())
      fail("the matrix is too large for 32-bit indices");
    if (symmetric && rows != cols) fail("a symmetric matrix must be square");
    // Every entry takes at least 6 characters ("1 1 1\n"): a larger count cannot be in the file.
    if (static_cast<double>(entries) > static_cast<double>(text_.size()) / 6.0 + 1)
      fail("declares " + size[2] + " entries, more than a file of " + std::to_string(text_.size()) + " bytes can hold");
    std::vector<Eigen::Triplet<double, int>> triplets;
    triplets.reserve(static_cast<std::size_t>(symmetric ? 2 * entries : entries));
    for (long long e = 0; e < entries; ++e) {
      do {
        if (!next_line(line))
          fail("truncated: " + std::to_string(e) + " of the " + std::to_string(entries) + " declared entries");
      } while (is_comment_or_blank(line));
      const std::vector<std::string> w = words(line);
      if (w.size() != 3) fail("an entry must hold 3 numbers (row column value)");
      const long long i = integer(w[0], "row"), j = integer(w[1], "column");
      if (i < 1 || i > rows || j < 1 || j > cols)
        fail("entry (" + w[0] + ", " + w[1] + ") is outside the " + size[0] + " x " + size[1] + " matrix (indices start at 1)");
      if (symmetric && i < j) fail("a symmetric file stores the lower triangle only (row >= column)");
      const double v = real(w[2]);
      triplets.emplace_back(static_cast<int>(i - 1), static_cast<int>(j - 1), v);
      if (symmetric && i != j) triplets.emplace_back(static_cast<int>(j - 1), static_cast<int>(i - 1), v);
    }
    while (next_line(line))
      if (!is_comment_or_blank(line)) fail("more entries than the " + std::to_string(entries) + " declared");
    SparseMatrix m(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(cols));
    m.setFromTriplets(triplets.begin(), triplets.end());  // duplicates are summed, as SciPy does
    return m;
  }

private:
  [[noreturn]] void fail(const std::string& why) const {
    throw Error("cannot read Matrix Market file '" + path_ + "'" + (line_ > 0 ? ", line " + std::to_string(line_) : "") +
                ": " + why);
  }
  bool next_line(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    const std::size_t end = std::min(text_.find('\n', pos_), text_.size());
    line = std::string_view(text_).substr(pos_, end - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos_ = end + 1;
    ++line_;
    return true;
  }
  static bool is_comment_or_blank(std::string_view line) {
    const std::size_t first = line.find_first_not_of(" \t");
    return first == std::string_view::npos || line[first] == '%';
  }
  static std::vector<std::string> words(std::string_view line) {
    std::vector<std::string> out;
    std::size_t p = 0;
    while ((p = line.find_first_not_of(" \t", p)) != std::string_view::npos) {
      const std::size_t e = std::min(line.find_first_of(" \t", p), line.size());
      out.emplace_back(line.substr(p, e - p));
      p = e;
    }
    return out;
  }
  long long integer(const std::string& w, const char* what) const {
    long long v = 0;
    const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
    if (ec != std::errc() || end != w.data() + w.size() || v < 0)
      fail(std::string("the ") + what + " '" + w + "' is not a non-negative integer");
    return v;
  }
  double real(const std::string& w) const {
    double v = 0;
    const char* first = w.data() + (w.size() > 1 && w[0] == '+' ? 1 : 0);
    const auto [end, ec] = std::from_chars(first, w.data() + w.size(), v);
    if (ec != std::errc() || end != w.data() + w.size() || !std::isfinite(v))
      fail("the value '" + w + "' is not a finite number");
    return v;
  }

  std::string path_, text_;
  std::size_t pos_ = 0;
  long long line_ = 0;
};

}  // namespace

SparseMatrix load_matrix_market(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot read Matrix Market file '" + path + "': no such file, or not readable");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw Error("cannot read Matrix Market file '" + path + "': read error");
  return MarketReader(path, std::move(text)).read();
}

std::vector<std::string> save_operator(const HeatOperator& op, const std::string& directory, const std::string& prefix,
                                       FileFormat format) {
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  if (ec) throw Error("cannot create directory '" + directory + "': " + ec.message());
  const std::filesystem::path dir(directory);
  const bool npz = format == FileFormat::Npz;
  std::vector<std::string> paths;
  for (const auto& [name, m] : {std::pair<const char*, const SparseMatrix*>{"L", &op.L}, {"A", &op.A}, {"M", &op.M}}) {
    if (m->rows() == 0) continue;  // A: assembled without the stiffness
    paths.push_back((dir / (prefix + name + (npz ? ".npz" : ".mtx"))).string());
    if (npz) save_npz(*m, paths.back());
    else save_matrix_market(*m, paths.back());
  }
  return paths;
}

}  // namespace digilap
