#include "tall_products.hpp"

#include "lanes.hpp"

#include <algorithm>
#include <cstddef>

namespace digilap::detail {

namespace {

// Columns start anywhere: loads through Lanes8u (lanes.hpp).

inline Lanes8 load(const double* p) { return *reinterpret_cast<const Lanes8u*>(p); }

// out(i, j) += sum_r x(r, i) y(r, j) for a TI x TJ tile over `rows` rows, the TI TJ sums in
// registers: 8 loads for 16 multiply-adds.
template <int TI, int TJ>
__attribute__((always_inline)) inline void gram_tile(const double* x, Eigen::Index ldx, const double* y, Eigen::Index ldy,
                                                    Eigen::Index rows, double* out, Eigen::Index ldo) {
  Lanes8 sum[TI][TJ] = {};
  Eigen::Index r = 0;
  for (; r + 8 <= rows; r += 8) {
    Lanes8 a[TI], b[TJ];
    for (int i = 0; i < TI; ++i) a[i] = load(x + i * ldx + r);
    for (int j = 0; j < TJ; ++j) b[j] = load(y + j * ldy + r);
    for (int i = 0; i < TI; ++i)
      for (int j = 0; j < TJ; ++j) sum[i][j] += a[i] * b[j];
  }
  for (int i = 0; i < TI; ++i)
    for (int j = 0; j < TJ; ++j) {
      double s = 0;
      for (int l = 0; l < 8; ++l) s += sum[i][j][l];
      for (Eigen::Index t = r; t < rows; ++t) s += x[i * ldx + t] * y[j * ldy + t];
      out[i + j * ldo] += s;
    }
}

// The tile of the edge: TI, TJ from 1 to 4 chosen at run time.
template <int TI>
__attribute__((always_inline)) inline void gram_tile_j(int tj, const double* x, Eigen::Index ldx, const double* y, Eigen::Index ldy,
                                                      Eigen::Index rows, double* out, Eigen::Index ldo) {
  switch (tj) {
    case 4: gram_tile<TI, 4>(x, ldx, y, ldy, rows, out, ldo); break;
    case 3: gram_tile<TI, 3>(x, ldx, y, ldy, rows, out, ldo); break;
    case 2: gram_tile<TI, 2>(x, ldx, y, ldy, rows, out, ldo); break;
    default: gram_tile<TI, 1>(x, ldx, y, ldy, rows, out, ldo); break;
  }
}

// z(r, j) = (or -=) sum_i x(r, i) c(i, j) for 8 V rows and TJ columns: V loads and TJ broadcasts
// for V TJ multiply-adds, each sum in the order of i.
template <int V, int TJ>
__attribute__((always_inline)) inline void product_tile(const double* x, Eigen::Index ldx, Eigen::Index p, const double* c,
                                                       Eigen::Index ldc, double* z, Eigen::Index ldz, bool subtract) {
  Lanes8 sum[V][TJ] = {};
  for (Eigen::Index i = 0; i < p; ++i) {
    Lanes8 a[V];
    for (int v = 0; v < V; ++v) a[v] = load(x + i * ldx + 8 * v);
    for (int j = 0; j < TJ; ++j) {
      const double cij = c[i + j * ldc];
      for (int v = 0; v < V; ++v) sum[v][j] += a[v] * cij;
    }
  }
  for (int j = 0; j < TJ; ++j)
    for (int v = 0; v < V; ++v) {
      Lanes8u* target = reinterpret_cast<Lanes8u*>(z + j * ldz + 8 * v);
      *target = subtract ? *target - sum[v][j] : sum[v][j];
    }
}

template <int V>
__attribute__((always_inline)) inline void product_tile_j(int tj, const double* x, Eigen::Index ldx, Eigen::Index p, const double* c,
                                                         Eigen::Index ldc, double* z, Eigen::Index ldz, bool subtract) {
  switch (tj) {
    case 8: product_tile<V, 8>(x, ldx, p, c, ldc, z, ldz, subtract); break;
    case 7: product_tile<V, 7>(x, ldx, p, c, ldc, z, ldz, subtract); break;
    case 6: product_tile<V, 6>(x, ldx, p, c, ldc, z, ldz, subtract); break;
    case 5: product_tile<V, 5>(x, ldx, p, c, ldc, z, ldz, subtract); break;
    case 4: product_tile<V, 4>(x, ldx, p, c, ldc, z, ldz, subtract); break;
    case 3: product_tile<V, 3>(x, ldx, p, c, ldc, z, ldz, subtract); break;
    case 2: product_tile<V, 2>(x, ldx, p, c, ldc, z, ldz, subtract); break;
    default: product_tile<V, 1>(x, ldx, p, c, ldc, z, ldz, subtract); break;
  }
}

// Rows a pass of the Gram products: 256 rows of a column are 2 KB, so a tile's 4 columns of x
// stay in L1 while the columns of y go by.
constexpr Eigen::Index kGramRows = 256;

}  // namespace

__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void tall_gram(const ConstBlockRef& x,
                                                                                            const ConstBlockRef& y, BlockRef out) {
  const Eigen::Index n = x.rows(), p = x.cols(), q = y.cols();
  out.setZero();
  const Eigen::Index ldx = x.outerStride(), ldy = y.outerStride(), ldo = out.outerStride();
  for (Eigen::Index first = 0; first < n; first += kGramRows) {
    const Eigen::Index rows = std::min(kGramRows, n - first);
    for (Eigen::Index i = 0; i < p; i += 4) {
      const int ti = static_cast<int>(std::min<Eigen::Index>(4, p - i));
      for (Eigen::Index j = 0; j < q; j += 4) {
        const int tj = static_cast<int>(std::min<Eigen::Index>(4, q - j));
        const double* xi = x.data() + i * ldx + first;
        const double* yj = y.data() + j * ldy + first;
        double* o = out.data() + i + j * ldo;
        switch (ti) {
          case 4: gram_tile_j<4>(tj, xi, ldx, yj, ldy, rows, o, ldo); break;
          case 3: gram_tile_j<3>(tj, xi, ldx, yj, ldy, rows, o, ldo); break;
          case 2: gram_tile_j<2>(tj, xi, ldx, yj, ldy, rows, o, ldo); break;
          default: gram_tile_j<1>(tj, xi, ldx, yj, ldy, rows, o, ldo); break;
        }
      }
    }
  }
}

__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void tall_product(const ConstBlockRef& x,
                                                                                               const Eigen::MatrixXd& c, BlockRef out,
                                                                                               bool subtract) {
  const Eigen::Index n = x.rows(), p = x.cols(), q = c.cols();
  const Eigen::Index ldx = x.outerStride(), ldz = out.outerStride(), ldc = c.outerStride();
  Eigen::Index r = 0;
  // 16 rows at a time (2 x 8 sums per column, 8 columns: 16 registers), then 8, then one by one.
  for (; r + 16 <= n; r += 16)
    for (Eigen::Index j = 0; j < q; j += 8)
      product_tile_j<2>(static_cast<int>(std::min<Eigen::Index>(8, q - j)), x.data() + r, ldx, p, c.data() + j * ldc, ldc,
                        out.data() + r + j * ldz, ldz, subtract);
  for (; r + 8 <= n; r += 8)
    for (Eigen::Index j = 0; j < q; j += 8)
      product_tile_j<1>(static_cast<int>(std::min<Eigen::Index>(8, q - j)), x.data() + r, ldx, p, c.data() + j * ldc, ldc,
                        out.data() + r + j * ldz, ldz, subtract);
  for (; r < n; ++r)
    for (Eigen::Index j = 0; j < q; ++j) {
      double s = 0;
      for (Eigen::Index i = 0; i < p; ++i) s += x.data()[r + i * ldx] * c.data()[i + j * ldc];
      out.data()[r + j * ldz] = subtract ? out.data()[r + j * ldz] - s : s;
    }
}

}  // namespace digilap::detail
