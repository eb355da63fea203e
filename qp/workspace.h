// Internal: the solver's fixed-capacity workspace, shared by the proximal outer loop
// (qp/solver.cc) and the dual active-set inner solver (qp/dual_active_set.cc). Allocated once,
// by the Solver constructor; nothing here ever grows.
//
// Rows: 0..n-1 are the bounds (row i is e_iᵀ x), n..n+m-1 the rows of A. Together C = [I; A].
#pragma once

#include <array>
#include <cstdint>

#include "qp/problem.h"

namespace hyq::qp::internal {

inline constexpr int kN = kMaxVariables;

struct Workspace {
  const Problem* problem = nullptr;
  int n = 0, m = 0, rows = 0;
  double eps = 0.0;   // proximal weight: the subproblem Hessian is H + eps I
  double hmax = 0.0;  // max_i H_ii

  // row data: lo ≤ C_i x ≤ hi, equality when lo == hi
  std::array<double, kMaxRows> lo{}, hi{};
  std::array<std::uint8_t, kMaxRows> is_eq{};

  // H + eps I = L Lᵀ, L lower triangular, stored row-major: L(i, k) = chol[i * kN + k]
  std::array<double, kN * kN> chol{};

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
  std::array<double, kN> dw{};

  // scratch
  std::array<double, kN> mnew{}, kvec{}, tmp{}, tmp2{}, delta_prev{};
  std::array<double, kMaxRows> cert{};  // signed Farkas multipliers over rows
  std::array<std::uint8_t, kMaxRows> skipped{}, dependent_entries{};  // per subproblem
};

}  // namespace hyq::qp::internal
