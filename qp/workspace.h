// Internal: the solver's fixed-capacity workspace, shared by the proximal outer loop
// (qp/solver.cc) and the dual active-set inner solver (qp/dual_active_set.cc). Allocated once,
// by the Solver constructor; nothing here ever grows.
//
// Rows: 0..n-1 are the bounds (row i is e_iᵀ x), n..n+m-1 the rows of A. Together C = [I; A].
#pragma once

#include <array>
#include <cstdint>
#include <type_traits>

#include "qp/problem.h"

namespace hyq::qp::internal {

inline constexpr int kN = kMaxVariables;

/// aᵀb with four independent partial sums: a single running sum is a chain of dependent
/// additions (latency-bound, and the compiler may not reorder it), four chains run in parallel.
inline double Dot(const double* a, const double* b, int n) noexcept {
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    s0 += a[i] * b[i];
    s1 += a[i + 1] * b[i + 1];
    s2 += a[i + 2] * b[i + 2];
    s3 += a[i + 3] * b[i + 3];
  }
  for (; i < n; ++i) s0 += a[i] * b[i];
  return (s0 + s1) + (s2 + s3);
}

inline constexpr std::array<double, kMaxRows> Filled(double value) {
  std::array<double, kMaxRows> a{};
  for (double& x : a) x = value;
  return a;
}

struct Workspace {
  const Problem* problem = nullptr;
  int n = 0, m = 0, rows = 0;
  double eps = 0.0;   // proximal weight: the subproblem Hessian is H + eps I
  double hmax = 0.0;  // max_i H_ii

  // row data: lo ≤ C_i x ≤ hi, equality when lo == hi
  std::array<double, kMaxRows> lo{}, hi{};
  std::array<std::uint8_t, kMaxRows> is_eq{};

  // FactorHessian's scratch, column-major (entry (i, k) at chol[i + k * kN]): the lower triangle
  // of H, reduced column by column to the Schur complements of H + eps I (the solver uses L⁻¹)
  std::array<double, kN * kN> chol{};
  // L⁻¹ (lower triangular, row-major: linv[i * kN + j] = (L⁻¹)(i, j)): with the inverse, L⁻¹ c
  // and L⁻ᵀ c are matrix-vector products whose rows are independent, instead of triangular
  // solves whose every step waits for the previous one
  std::array<double, kN * kN> linv{};
  std::array<double, kN * kN> linvt{};  // the same transposed: linvt[j * kN + i] = (L⁻¹)(i, j)
  // 1 / (1 + |bound|) per row and side, to rank violations without dividing
  // (kept from solve to solve, recomputed for a bound that changed: initially all bounds 0)
  std::array<double, kMaxRows> lo_scale = Filled(1.0), hi_scale = Filled(1.0);
  std::array<double, kMaxRows> lo_finite{}, hi_finite{};  // lo, hi with ±inf as ∓1e300

  // proximal centre x_k, its row values C x_k, gradient q = H x_k + g, v = L⁻¹ q
  std::array<double, kN> xk{}, q{}, v{};
  std::array<double, kMaxRows> cx{};

  // inner iterate: u (LDP variable), δ = L⁻ᵀ (u − v), C δ
  std::array<double, kN> u{}, delta{};
  std::array<double, kMaxRows> cdelta{};

  // working set W (positions 0..nw-1): row index, side (+1 upper, −1 lower), multiplier λ ≥ 0
  // (free for equalities), m_p = L⁻¹ c_row (row-major, mw[p * kN + j]), signed rhs d_p
  int nw = 0;
  std::array<int, kN> w_row{};
  std::array<std::int8_t, kN> w_sign{};
  std::array<double, kN> lambda{}, lambda_star{}, d{};
  std::array<double, kN * kN> mw{};
  std::array<int, kMaxRows> pos_of{};  // position in W, −1 when not in W

  // K = M_W M_Wᵀ = Lw Dw Lwᵀ, Lw unit lower triangular, row-major: Lw(p, q) = lw[p * kN + q]
  std::array<double, kN * kN> lw{};
  std::array<double, kN> dw{}, dw_inv{};

  // H x and A x at the iterate of the last KKT check (valid while products_valid): the next
  // proximal centre is that iterate
  std::array<double, kN> kkt_hx{};
  std::array<double, kMaxConstraints> kkt_ax{};
  bool products_valid = false;

  // scratch
  std::array<double, kN> mnew{}, kvec{}, tmp{}, tmp2{};
  std::array<double, kMaxRows> cert{};  // signed Farkas multipliers over rows
  std::array<std::uint8_t, kMaxRows> skipped{}, dependent_entries{};  // per subproblem
  std::array<double, kMaxRows> entry_violation{};  // at the last dependent entry
  std::array<double, kN * kN> square{};  // a full working set's rows, for a direct solve

  // the H and A that L and W belong to: a warm start with the same matrices keeps them
  bool factor_valid = false;
  int factor_n = 0, factor_m = 0;
  std::array<double, kN * kN> h_copy{};
  std::array<double, kMaxConstraints * kN> a_copy{};
  std::array<std::int8_t, kMaxRows> warm_side{};  // +1, −1, 2 (equality), 0 from a Solution
  std::array<double, kMaxRows> warm_y{};
};

// The problem size: N when the caller was compiled for it (N > 0), else the run-time n. The
// solver's hot functions are instantiated for the sizes the contact ID produces (WithSize) and
// once for any size: with n known at compile time their short loops lose the vectorisation
// prologues and remainder branches (5–10 % of a solve, the same arithmetic in the same order).
template <int N>
inline int Size(const Workspace& ws) {
  return N > 0 ? N : ws.n;
}

// f(std::integral_constant<int, n>) for the sizes the contact ID's QPs take (Stage I: 5 unknowns
// per stance foot; Stage II: the dimension of Stage I's null space, 5, 9 and 14 with two, three
// and four stance feet, none frictionless), else f(std::integral_constant<int, 0>), the
// run-time instance
template <class F>
inline decltype(auto) WithSize(int n, F&& f) {
  switch (n) {
    case 5: return f(std::integral_constant<int, 5>{});
    case 9: return f(std::integral_constant<int, 9>{});
    case 10: return f(std::integral_constant<int, 10>{});
    case 14: return f(std::integral_constant<int, 14>{});
    case 15: return f(std::integral_constant<int, 15>{});
    case 20: return f(std::integral_constant<int, 20>{});
    default: return f(std::integral_constant<int, 0>{});
  }
}

// z = L⁻¹ z in place, z zero above `first`. For a size known at compile time, column by column
// (z_i += X(i, c) t_c for i ≥ c, column c of X contiguous in linvt) with every loop unrolled: the
// triangle becomes straight-line code, without the loop and remainder branches of short dot
// products of every length; otherwise rows of L⁻¹ times z, each independent.
template <int N>
void ForwardChol(const Workspace& ws, double* z, int first) {
  double t[kN];
  const int n = Size<N>(ws);
  if constexpr (N > 0) {
    for (int i = 0; i < N; ++i) t[i] = i >= first ? z[i] : 0.0;
    double out[N] = {};
#pragma GCC unroll 32
    for (int c = 0; c < N; ++c) {
      const double tc = t[c];
      const double* column = &ws.linvt[c * kN];
#pragma GCC unroll 32
      for (int i = c; i < N; ++i) out[i] += column[i] * tc;
    }
    for (int i = first; i < N; ++i) z[i] = out[i];
  } else {
    for (int i = first; i < n; ++i) t[i] = z[i];
    for (int i = first; i < n; ++i) z[i] = Dot(&ws.linv[i * kN] + first, t + first, i - first + 1);
  }
}

// z = L⁻ᵀ z in place: for a compile-time size, row by row of X (z_j += X(i, j) t_i for j ≤ i),
// unrolled as in ForwardChol; otherwise z_j = (column j of L⁻¹)ᵀ z, each independent
template <int N>
void BackwardChol(const Workspace& ws, double* z) {
  double t[kN];
  const int n = Size<N>(ws);
  for (int i = 0; i < n; ++i) t[i] = z[i];
  if constexpr (N > 0) {
    double out[N] = {};
#pragma GCC unroll 32
    for (int i = 0; i < N; ++i) {
      const double ti = t[i];
      const double* row = &ws.linv[i * kN];
#pragma GCC unroll 32
      for (int j = 0; j <= i; ++j) out[j] += row[j] * ti;
    }
    for (int j = 0; j < N; ++j) z[j] = out[j];
  } else {
    for (int j = 0; j < n; ++j) z[j] = Dot(&ws.linvt[j * kN] + j, t + j, n - j);
  }
}

/// ComputeKktResiduals that also leaves H x (n entries) in hx and A x (m entries) in ax, for the
/// next proximal centre x_k = x (Linearise then needs no products of its own). support, when not
/// null: the support_size rows (bounds 0..n−1, then A's) outside which y_bounds and
/// y_constraints are zero (the solver's working set); the sums over multipliers then skip the
/// rest.
KktResiduals KktResidualsAndProducts(const Problem& p, const VectorN& x, const VectorN& y_bounds,
                                     const VectorM& y_constraints, double* hx, double* ax,
                                     const int* support = nullptr,
                                     int support_size = 0) noexcept;

/// out = A x (m entries, overwritten), four columns of A per pass over out; n = N when N > 0.
template <int N = 0>
inline void MultiplyA(const Problem& p, const double* x, double* out) noexcept {
  const int n = N > 0 ? N : p.n(), m = p.m();
  const double* a = p.A.data();
  for (int i = 0; i < m; ++i) out[i] = 0.0;
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    const double* c0 = a + j * m;
    const double* c1 = c0 + m;
    const double* c2 = c1 + m;
    const double* c3 = c2 + m;
    const double x0 = x[j], x1 = x[j + 1], x2 = x[j + 2], x3 = x[j + 3];
    for (int i = 0; i < m; ++i) out[i] += (c0[i] * x0 + c1[i] * x1) + (c2[i] * x2 + c3[i] * x3);
  }
  for (; j < n; ++j) {
    const double* c = a + j * m;
    for (int i = 0; i < m; ++i) out[i] += c[i] * x[j];
  }
}

}  // namespace hyq::qp::internal
