// Sylvester count of a sparse symmetric matrix from an LDL^T factorization in
// double-word ("double-double") arithmetic, for remote_trigger's sliced verdict
// (analysis/stability/sliced/inertia.py, count_below_dw).
//
// The factorization is the up-looking one, without pivoting, of a matrix given
// by its upper triangle (CSC, rows sorted or not), in a fixed order:
//   H = A - a I = (I + L) D (I + L)^T.
// Every operation on a value of L, D or the work vector is a double-word one
// with a proved relative error bound (Joldes, Muller and Popescu, "Tight and
// rigorous error bounds for basic building blocks of double-word arithmetic",
// ACM TOMS 44(2), 2017, with Muller and Rideau, ACM TOMS 48(1), 2022):
//   addition       AccurateDWPlusDW   3 u^2 + 13 u^3
//   multiplication DWTimesDW1 (FMA)   4 u^2
//   division       DWDivDW2           15 u^2 + 56 u^3
// (u = 2^-53, no underflow); the Python side uses 16 u^2 for every operation. The diagonal
// A_kk - a is exact as a double-word (TwoSum). Only the signs of D and the
// quantities of the a-priori bound leave this file: the count of negative
// pivots, the largest row or column count of I + L, and the largest row sum
// of |I + L| |D| |I + L|^T computed in double from the leading words.
//
// Compiled without value-changing optimizations (no -ffast-math, no FMA
// contraction: the error-free transformations need every operation rounded
// as written).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace {

struct dw {
  double h, l;
};

inline dw two_sum(double a, double b) {
  const double s = a + b;
  const double bb = s - a;
  const double e = (a - (s - bb)) + (b - bb);
  return {s, e};
}

inline dw fast_two_sum(double a, double b) {  // |a| >= |b| or a == 0
  const double s = a + b;
  const double e = b - (s - a);
  return {s, e};
}

inline dw two_prod(double a, double b) {
  const double p = a * b;
  return {p, std::fma(a, b, -p)};
}

inline dw add(dw x, dw y) {  // AccurateDWPlusDW
  const dw s = two_sum(x.h, y.h);
  const dw t = two_sum(x.l, y.l);
  const double c = s.l + t.h;
  const dw v = fast_two_sum(s.h, c);
  const double w = t.l + v.l;
  return fast_two_sum(v.h, w);
}

inline dw neg(dw x) { return {-x.h, -x.l}; }

inline dw mul(dw x, dw y) {  // DWTimesDW1 with FMA
  const dw c = two_prod(x.h, y.h);
  const double tl0 = x.l * y.l;
  const double tl1 = std::fma(x.h, y.l, tl0);
  const double cl2 = std::fma(x.l, y.h, tl1);
  const double cl3 = c.l + cl2;
  return fast_two_sum(c.h, cl3);
}

inline dw mul_fp(dw x, double y) {  // DWTimesFP3 with FMA
  const dw c = two_prod(x.h, y);
  const double cl3 = std::fma(x.l, y, c.l);
  return fast_two_sum(c.h, cl3);
}

inline dw div(dw x, dw y) {  // DWDivDW2
  const double th = x.h / y.h;
  const dw r = mul_fp(y, th);
  const double pih = x.h - r.h;
  const double dl = x.l - r.l;
  const double d = pih + dl;
  const double tl = d / y.h;
  return fast_two_sum(th, tl);
}

}  // namespace

extern "C" {

// Inertia of H = A - a I from its double-word LDL^T in the given order.
//
// n, Ap (n + 1), Ai, Ax: the upper triangle of A (i <= j) in CSC, 64-bit
// indices; a: the shift. Outputs: *negative, the number of negative pivots;
// *depth, the largest row or column count of I + L; *max_row, the largest
// row sum of |I + L| |D| |I + L|^T from the leading words (double).
// Returns 0, or k + 1 if the pivot of row k is zero
// (the outputs are then not set), or -1 if memory ran out.
// Two builds of the function, chosen at load time: one with the FMA
// instruction (std::fma inline), one calling the library's fma; both
// correctly rounded, so their results are the same bits.
__attribute__((target_clones("fma", "default")))
int ldl_dd_inertia(int64_t n, const int64_t* Ap, const int64_t* Ai, const double* Ax,
                   double a, int64_t* negative, int64_t* depth, double* max_row) {
  try {
    std::vector<int64_t> parent(n), flag(n), colcount(n, 0);
    // elimination tree and the column counts of L (up-looking: row k of L is
    // the set of nodes met walking the tree from each i < k of column k of A)
    for (int64_t k = 0; k < n; ++k) {
      parent[k] = -1;
      flag[k] = k;
      for (int64_t p = Ap[k]; p < Ap[k + 1]; ++p) {
        int64_t i = Ai[p];
        if (i >= k) continue;
        while (flag[i] != k) {
          if (parent[i] == -1) parent[i] = k;
          ++colcount[i];
          flag[i] = k;
          i = parent[i];
        }
      }
    }
    std::vector<int64_t> Lp(n + 1, 0);
    for (int64_t j = 0; j < n; ++j) Lp[j + 1] = Lp[j] + colcount[j];
    const int64_t nnz = Lp[n];
    std::vector<int64_t> Li(nnz), fill(n, 0);
    std::vector<dw> Lx(nnz), D(n), y(n, dw{0.0, 0.0});
    std::vector<int64_t> pattern;
    pattern.reserve(1024);
    int64_t longest_row = 0;
    for (int64_t k = 0; k < n; ++k) {
      flag[k] = k;
      pattern.clear();
      y[k] = dw{-a, 0.0};  // A_kk - a, exact (A_kk = 0 if not stored)
      for (int64_t p = Ap[k]; p < Ap[k + 1]; ++p) {
        int64_t i = Ai[p];
        if (i > k) continue;
        if (i == k) {
          y[k] = two_sum(Ax[p], -a);
          continue;
        }
        y[i] = add(y[i], dw{Ax[p], 0.0});
        while (flag[i] != k) {
          pattern.push_back(i);
          flag[i] = k;
          i = parent[i];
        }
      }
      // parents come after their children: ascending order is topological
      std::sort(pattern.begin(), pattern.end());
      longest_row = std::max<int64_t>(longest_row, static_cast<int64_t>(pattern.size()));
      dw d = y[k];
      y[k] = dw{0.0, 0.0};
      for (const int64_t j : pattern) {
        const dw yj = y[j];
        y[j] = dw{0.0, 0.0};
        const int64_t end = Lp[j] + fill[j];
        for (int64_t p = Lp[j]; p < end; ++p) y[Li[p]] = add(y[Li[p]], neg(mul(Lx[p], yj)));
        const dw lkj = div(yj, D[j]);
        d = add(d, neg(mul(lkj, yj)));
        Li[end] = k;
        Lx[end] = lkj;
        ++fill[j];
      }
      if (d.h == 0.0) return static_cast<int>(std::min<int64_t>(k + 1, 2000000000));
      D[k] = d;
    }
    // the bound's quantities, from the leading words
    int64_t neg_count = 0, longest_col = 0;
    std::vector<double> v(n);
    for (int64_t j = 0; j < n; ++j) {
      if (D[j].h < 0.0) ++neg_count;
      longest_col = std::max(longest_col, colcount[j]);
      double w = 1.0;  // column sum of |I + L|
      for (int64_t p = Lp[j]; p < Lp[j + 1]; ++p) w += std::fabs(Lx[p].h);
      v[j] = std::fabs(D[j].h) * w;
    }
    std::vector<double> rows(v);  // rows_i = v_i + sum_j |L_ij| v_j
    for (int64_t j = 0; j < n; ++j)
      for (int64_t p = Lp[j]; p < Lp[j + 1]; ++p) rows[Li[p]] += std::fabs(Lx[p].h) * v[j];
    double mr = 0.0;
    for (int64_t i = 0; i < n; ++i) mr = std::max(mr, rows[i]);
    *negative = neg_count;
    *depth = std::max(longest_row, longest_col) + 1;
    *max_row = mr;
    return 0;
  } catch (...) {
    return -1;
  }
}

}  // extern "C"
