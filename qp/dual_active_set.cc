#include "qp/dual_active_set.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace hyq::qp::internal {
namespace {

// How often one row may enter dependent on W (and swap with a blocking row) per subproblem.
constexpr int kMaxDependentEntries = 2;
// A Farkas certificate is accepted when ‖Cᵀ w‖ is below this (relative, see CertificateResidual).
constexpr double kCertificateTolerance = 1e-12;
constexpr double kEpsilon = std::numeric_limits<double>::epsilon();

// m = L⁻¹ C_rowᵀ: a bound row is e_i, so m is zero above i
template <int N>
void RowVector(const Workspace& ws, int row, double* m) {
  const int n = Size<N>(ws);
  if (row < n) {
    // L⁻¹ e_row is column `row` of L⁻¹, i.e. row `row` of its transpose (contiguous)
    for (int j = 0; j < row; ++j) m[j] = 0.0;
    const double* column = &ws.linvt[row * kN];
    for (int j = row; j < n; ++j) m[j] = column[j];
  } else {
    const Problem& p = *ws.problem;
    for (int j = 0; j < n; ++j) m[j] = p.A(row - n, j);
    ForwardChol<N>(ws, m, 0);
  }
}

// m_row is zero before this entry: a bound row's m is column `row` of L⁻¹ (lower triangular),
// a row of A's is dense. Products with m start there.
template <int N = 0>
int FirstNonZero(const Workspace& ws, int row) { return row < Size<N>(ws) ? row : 0; }

double SideBound(const Workspace& ws, int row, int sign) {
  return sign > 0 ? ws.hi[row] : ws.lo[row];
}

// signed right-hand side of (2): d = s (b_s − C_row x_k + m_rowᵀ v)
template <int N>
double RightHandSide(const Workspace& ws, int row, int sign, const double* m) {
  const int f = FirstNonZero<N>(ws, row);
  return sign *
         (SideBound(ws, row, sign) - ws.cx[row] + Dot(m + f, ws.v.data() + f, Size<N>(ws) - f));
}

// Lw Dw Lwᵀ without position j: the rows below j get the rank-one term Dw_j l lᵀ back, l being
// column j of Lw below the diagonal [Gill et al. 1974, C1]; then every array closes the gap.
template <int N>
void Remove(Workspace* ws, int j) {
  const int nw = ws->nw;
  const int removed = ws->w_row[j];
  double* lw = ws->lw.data();
  double* z = ws->tmp.data();
  for (int r = j + 1; r < nw; ++r) z[r] = lw[r * kN + j];
  double a = ws->dw[j];
  for (int c = j + 1; c < nw && a != 0.0; ++c) {
    const double pz = z[c];
    const double dn = ws->dw[c] + a * pz * pz;
    const double beta = pz * a / dn;
    a = ws->dw[c] * a / dn;
    ws->dw[c] = dn;
    ws->dw_inv[c] = 1.0 / dn;
    for (int r = c + 1; r < nw; ++r) {
      z[r] -= pz * lw[r * kN + c];
      lw[r * kN + c] += beta * z[r];
    }
  }
  // close the gap: row r moves to r − 1 and loses its column j
  for (int r = j + 1; r < nw; ++r) {
    double* dst = &lw[(r - 1) * kN];
    const double* src = &lw[r * kN];
    for (int c = 0; c < j; ++c) dst[c] = src[c];
    for (int c = j + 1; c < r; ++c) dst[c - 1] = src[c];
    dst[r - 1] = 1.0;
    ws->dw[r - 1] = ws->dw[r];
    ws->dw_inv[r - 1] = ws->dw_inv[r];
    ws->w_row[r - 1] = ws->w_row[r];
    ws->w_sign[r - 1] = ws->w_sign[r];
    ws->lambda[r - 1] = ws->lambda[r];
    ws->d[r - 1] = ws->d[r];
    const double* msrc = &ws->mw[r * kN];
    double* mdst = &ws->mw[(r - 1) * kN];
    for (int k = 0; k < Size<N>(*ws); ++k) mdst[k] = msrc[k];
  }
  ws->pos_of[removed] = -1;
  ws->nw = nw - 1;
  for (int p = j; p < ws->nw; ++p) ws->pos_of[ws->w_row[p]] = p;
}

// Tries to put (row, sign) into W. Forward solve for the new row of Lw:
//   Lw r = k, k_p = s_p s m_pᵀ m,  l = Dw⁻¹ r,  pivot = mᵀm − rᵀ l                     (4)
// A pivot at or below tol·mᵀm means s m = Σ c_p s_p m_p with c = Lw⁻ᵀ l: returns false and
// leaves c in ws->tmp2 (W unchanged).
template <int N>
bool TryAppend(Workspace* ws, int row, int sign, double lambda, double tol) {
  const int n = Size<N>(*ws), nw = ws->nw;
  const double* m = ws->mnew.data();
  double* r = ws->tmp.data();
  double* l = ws->tmp2.data();
  const int first = FirstNonZero<N>(*ws, row);
  const double mm = Dot(m + first, m + first, n - first);
  for (int p = 0; p < nw; ++p) {
    const int f = std::max(first, FirstNonZero<N>(*ws, ws->w_row[p]));
    r[p] = ws->w_sign[p] * sign * Dot(&ws->mw[p * kN] + f, m + f, n - f);
  }
  double pivot = mm;
  for (int p = 0; p < nw; ++p) {
    const double* Lp = &ws->lw[p * kN];
    const double s = r[p] - Dot(Lp, r, p);
    r[p] = s;
    l[p] = s * ws->dw_inv[p];
    pivot -= s * l[p];
  }
  if (nw < n && pivot > tol * mm && mm > 0.0) {
    double* Lrow = &ws->lw[nw * kN];
    for (int q = 0; q < nw; ++q) Lrow[q] = l[q];
    Lrow[nw] = 1.0;
    ws->dw[nw] = pivot;
    ws->dw_inv[nw] = 1.0 / pivot;
    for (int k = 0; k < n; ++k) ws->mw[nw * kN + k] = m[k];
    ws->w_row[nw] = row;
    ws->w_sign[nw] = static_cast<std::int8_t>(sign);
    ws->lambda[nw] = lambda;
    ws->d[nw] = RightHandSide<N>(*ws, row, sign, m);
    ws->pos_of[row] = nw;
    ws->nw = nw + 1;
    return true;
  }
  // c = Lw⁻ᵀ l, column-oriented
  for (int p = nw - 1; p >= 0; --p) {
    const double cp = l[p];
    const double* Lp = &ws->lw[p * kN];
    for (int q = 0; q < p; ++q) l[q] -= Lp[q] * cp;
  }
  return false;
}

// The certificate from (4) satisfies Cᵀw = 0 only to the accuracy of the LDP transform; one step
// of refinement in the original data: r = Cᵀ w, then the W part of w moves by the least-squares
// correction  Kw Δy = −M_W L⁻¹ r  (the entering row's weight stays fixed).
void RefineCertificate(Workspace* ws) {
  const Problem& p = *ws->problem;
  const int n = ws->n, m = ws->m, nw = ws->nw;
  double* r = ws->u.data();
  for (int i = 0; i < n; ++i) r[i] = ws->cert[i];
  for (int k = 0; k < m; ++k) {
    const double w = ws->cert[n + k];
    if (w == 0.0) continue;
    for (int j = 0; j < n; ++j) r[j] += p.A(k, j) * w;
  }
  ForwardChol<0>(*ws, r, 0);
  double* y = ws->kvec.data();
  for (int q = 0; q < nw; ++q) {
    const double* Lq = &ws->lw[q * kN];
    y[q] = -ws->w_sign[q] * Dot(&ws->mw[q * kN], r, n) - Dot(Lq, y, q);
  }
  for (int q = 0; q < nw; ++q) y[q] *= ws->dw_inv[q];
  for (int q = nw - 1; q >= 0; --q) {
    const double* Lq = &ws->lw[q * kN];
    for (int k = 0; k < q; ++k) y[k] -= Lq[k] * y[q];
  }
  for (int q = 0; q < nw; ++q) {
    const int row = ws->w_row[q];
    ws->cert[row] += ws->w_sign[q] * y[q];
    // an inequality's weight keeps its side's sign (rounding-size entries of the other sign go)
    if (!ws->is_eq[row] && ws->w_sign[q] * ws->cert[row] < 0.0) ws->cert[row] = 0.0;
  }
}

// With W full (n independent rows) every row is a combination of W's: s C_row = Σ c_p s_p C_p.
// c from (4) goes through Kw, whose condition is that of C_W squared; when W is nearly
// dependent that is too inaccurate for a certificate, so solve the square system
//   [s_p C_pᵀ]_p c = s C_rowᵀ   by Gaussian elimination with partial pivoting, into ws->tmp2.
void SolveFullWorkingSet(Workspace* ws, int row, int sign) {
  const Problem& p = *ws->problem;
  const int n = ws->n;
  double* B = ws->square.data();  // B(i, q) = B[i + q * kN]
  double* c = ws->kvec.data();
  for (int q = 0; q < n; ++q) {
    const int r = ws->w_row[q];
    for (int i = 0; i < n; ++i)
      B[i + q * kN] = ws->w_sign[q] * (r < n ? (i == r ? 1.0 : 0.0) : p.A(r - n, i));
  }
  for (int i = 0; i < n; ++i) c[i] = sign * (row < n ? (i == row ? 1.0 : 0.0) : p.A(row - n, i));
  for (int k = 0; k < n; ++k) {
    int piv = k;
    for (int i = k + 1; i < n; ++i)
      if (std::fabs(B[i + k * kN]) > std::fabs(B[piv + k * kN])) piv = i;
    if (B[piv + k * kN] == 0.0) return;  // singular after all: keep c from (4)
    if (piv != k) {
      for (int q = k; q < n; ++q) std::swap(B[k + q * kN], B[piv + q * kN]);
      std::swap(c[k], c[piv]);
    }
    const double inv = 1.0 / B[k + k * kN];
    for (int i = k + 1; i < n; ++i) {
      const double f = B[i + k * kN] * inv;
      if (f == 0.0) continue;
      for (int q = k + 1; q < n; ++q) B[i + q * kN] -= f * B[k + q * kN];
      c[i] -= f * c[k];
    }
  }
  for (int k = n - 1; k >= 0; --k) {
    double s = c[k];
    for (int q = k + 1; q < n; ++q) s -= B[k + q * kN] * c[q];
    c[k] = s / B[k + k * kN];
  }
  for (int q = 0; q < n; ++q) ws->tmp2[q] = c[q];
}

// ‖Cᵀ w‖∞ / (‖w‖∞ · max(1, max |A_ij|)) for the certificate in ws->cert
double CertificateResidual(const Workspace& ws) {
  const Problem& p = *ws.problem;
  const int n = ws.n, m = ws.m;
  double r[kN];
  double wmax = 0.0, amax = 1.0;
  for (int i = 0; i < ws.rows; ++i) wmax = std::fmax(wmax, std::fabs(ws.cert[i]));
  for (int i = 0; i < n; ++i) r[i] = ws.cert[i];
  for (int k = 0; k < m; ++k)
    for (int j = 0; j < n; ++j) {
      r[j] += p.A(k, j) * ws.cert[n + k];
      amax = std::fmax(amax, std::fabs(p.A(k, j)));
    }
  double rmax = 0.0;
  for (int i = 0; i < n; ++i) rmax = std::fmax(rmax, std::fabs(r[i]));
  return rmax / (std::fmax(wmax, 1e-300) * amax);
}

// Whether the certificate in ws->cert proves infeasibility: Cᵀw ≈ 0 is not enough, its gap
//   β = Σ_{w_i > 0} w_i hi_i + Σ_{w_i < 0} w_i lo_i
// must be negative by more than what rows violated by the primal tolerance could make up, plus
// what the residual r = Cᵀw can contribute at the current iterate x = x_k + δ:
//   β < −(10 τ Σ |w_i| (1 + |b_i|) + ‖r‖₁ (1 + ‖x‖∞)).
// Every x meeting each row to within τ (1 + |b_i|) has Σ w_i C_i x = rᵀx ≥ β − 10 τ ..., so only
// a gap below that margin is a contradiction. At a degenerate feasible vertex (many rows active
// at zero slack, Stage II of the contact ID) a row can enter dependent on W with no blocking
// multiplier while its "violation" is only the rounding of W's rows amplified by the combination:
// then Cᵀw closes but β ≥ 0 (or ≈ 0), and the problem is feasible.
bool CertificateProvesInfeasibility(const Workspace& ws, double primal_tolerance) {
  const Problem& p = *ws.problem;
  const int n = ws.n, m = ws.m;
  double r[kN];
  double gap = 0.0, margin = 0.0;
  for (int i = 0; i < ws.rows; ++i) {
    const double w = ws.cert[i];
    if (w == 0.0) continue;
    const double b = w > 0.0 ? ws.hi[i] : ws.lo[i];
    if (!std::isfinite(b)) return false;
    gap += w * b;
    margin += std::fabs(w) * (1.0 + std::fabs(b));
  }
  margin *= 10.0 * primal_tolerance;
  for (int i = 0; i < n; ++i) r[i] = ws.cert[i];
  for (int k = 0; k < m; ++k) {
    const double w = ws.cert[n + k];
    if (w == 0.0) continue;
    for (int j = 0; j < n; ++j) r[j] += p.A(k, j) * w;
  }
  double r1 = 0.0, xmax = 0.0;
  for (int j = 0; j < n; ++j) {
    r1 += std::fabs(r[j]);
    xmax = std::fmax(xmax, std::fabs(ws.xk[j] + ws.delta[j]));
  }
  margin += r1 * (1.0 + xmax);
  return gap < -margin;
}

// Row (row, sign) entered dependent on W: s C_row ≈ Σ_p c_p s_p C_p (c in ws->tmp2). Whether it
// holds at every point where W's rows are at their bounds, i.e. at the degenerate vertex itself:
// there s C_row x = Σ c_p s_p b_p + rᵀx with r = s C_rowᵀ − Σ c_p s_p C_pᵀ, so the row's
// violation is at most  v = Σ c_p s_p b_p − s b_row + ‖r‖₁ (1 + ‖x‖∞). When v is within the
// row's own primal tolerance τ (1 + |b_row|) (plus the rounding of the sum v), the row is not
// violated at the exact vertex: the measured violation is only the rounding of W's rows
// (amplified by c) and the step the dual method would take is of length zero in x: at a vertex
// with many zero-slack rows it would swap such rows with W's forever (cycling) or, with no
// blocking row, build a "certificate" with no gap.
bool DependentRowIsImplied(const Workspace& ws, int row, int sign, const double* c,
                           double primal_tolerance) {
  const Problem& p = *ws.problem;
  const int n = ws.n;
  double r[kN];
  auto add_row = [&](int i, double w) {
    if (i < n) {
      r[i] += w;
    } else {
      for (int j = 0; j < n; ++j) r[j] += p.A(i - n, j) * w;
    }
  };
  for (int j = 0; j < n; ++j) r[j] = 0.0;
  const double b_row = SideBound(ws, row, sign);
  double v = -sign * b_row;
  double rounding = std::fabs(b_row);  // Σ |terms| of v
  add_row(row, sign);
  for (int q = 0; q < ws.nw; ++q) {
    if (c[q] == 0.0) continue;
    const int i = ws.w_row[q];
    const double b = SideBound(ws, i, ws.w_sign[q]);
    v += c[q] * ws.w_sign[q] * b;
    rounding += std::fabs(c[q] * b);
    add_row(i, -c[q] * ws.w_sign[q]);
  }
  double r1 = 0.0, xmax = 0.0;
  for (int j = 0; j < n; ++j) {
    r1 += std::fabs(r[j]);
    xmax = std::fmax(xmax, std::fabs(ws.xk[j] + ws.delta[j]));
  }
  return v + r1 * (1.0 + xmax) <=
         primal_tolerance * (1.0 + std::fabs(b_row)) + 8.0 * kEpsilon * rounding;
}

bool OutOfBudget(const InnerLimits& limits, int iterations, InnerStatus* status) {
  if (iterations >= limits.max_iterations) {
    *status = InnerStatus::kIterationLimit;
    return true;
  }
  if (limits.has_deadline && limits.deadline.Passed()) {
    *status = InnerStatus::kDeadline;
    return true;
  }
  return false;
}

// Row (row, sign) is violated at the current u: add it, first stepping λ along the dependence
// direction (−c, +1) and dropping the blocking rows while it is dependent on W.
// kSkippedInPlace: the row was left out and W, λ are untouched, so the current step (possibly
// refined) stays valid; kSkipped: left out after W changed (blocking rows removed, rebuild).
enum class EnterResult { kEntered, kSkipped, kSkippedInPlace, kStop };

template <int N>
EnterResult Enter(Workspace* ws, int row, int sign, double violation, const InnerLimits& limits,
                  int* iterations, InnerStatus* status) {
  RowVector<N>(*ws, row, ws->mnew.data());
  double lambda_new = 0.0;
  bool rebuilt = false;
  bool changed = false;  // W or λ modified (then the step must be recomputed)
  for (;;) {
    if (TryAppend<N>(ws, row, sign, lambda_new, limits.dependence_tolerance))
      return EnterResult::kEntered;
    // a row that keeps entering dependent on W at a degenerate vertex, with a violation that no
    // longer shrinks, swaps with another forever (its violation is rounding when cond(H + εI) is
    // large): skip it for this subproblem; the refinement on W afterwards makes it exact
    // (qp/solver.cc checks every row again)
    if (lambda_new == 0.0) {
      if (ws->dependent_entries[row] > 0 && violation > 0.5 * ws->entry_violation[row] &&
          ++ws->dependent_entries[row] > kMaxDependentEntries) {
        ws->skipped[row] = 1;
        return changed ? EnterResult::kSkipped : EnterResult::kSkippedInPlace;
      }
      if (ws->dependent_entries[row] == 0) ws->dependent_entries[row] = 1;
      ws->entry_violation[row] = violation;
    }
    if (ws->nw == ws->n) SolveFullWorkingSet(ws, row, sign);
    const double* c = ws->tmp2.data();
    // zero-length step: the row holds wherever W's rows do, its violation is rounding. Leave it
    // out of this subproblem instead of swapping (degeneracy) or claiming infeasibility.
    if (lambda_new == 0.0 && DependentRowIsImplied(*ws, row, sign, c, limits.primal_tolerance)) {
      ws->skipped[row] = 1;
      return changed ? EnterResult::kSkipped : EnterResult::kSkippedInPlace;
    }
    double cmax = 0.0;
    for (int p = 0; p < ws->nw; ++p) cmax = std::fmax(cmax, std::fabs(c[p]));
    int j = -1;
    double alpha = std::numeric_limits<double>::infinity();
    for (int p = 0; p < ws->nw; ++p) {
      if (ws->is_eq[ws->w_row[p]] || !(c[p] > 1e-13 * cmax)) continue;
      const double t = ws->lambda[p] / c[p];
      if (t < alpha) alpha = t, j = p;
    }
    if (j < 0) {
      // Farkas: w = signed multipliers with Cᵀ w = 0 and Σ w_i b_i < 0
      for (int i = 0; i < ws->rows; ++i) ws->cert[i] = 0.0;
      for (int p = 0; p < ws->nw; ++p) ws->cert[ws->w_row[p]] = -ws->w_sign[p] * c[p];
      ws->cert[row] = sign;
      for (int p = 0; p < ws->nw; ++p) {
        const int r = ws->w_row[p];
        if (!ws->is_eq[r] && ws->w_sign[p] * ws->cert[r] < 0.0) ws->cert[r] = 0.0;
      }
      RefineCertificate(ws);
      RefineCertificate(ws);
      // the entering row was only nearly dependent (its residual against W, pivot in (4), is
      // above rounding but below the tolerance): the certificate does not close, so the row
      // enters after all and the iteration goes on to find one that does
      if (CertificateResidual(*ws) > kCertificateTolerance) {
        if (ws->nw < ws->n && TryAppend<N>(ws, row, sign, lambda_new, 0.0))
          return EnterResult::kEntered;
        // or a rounding-size positive c_p was left out of the ratio test: let it block
        for (int p = 0; p < ws->nw; ++p) {
          if (ws->is_eq[ws->w_row[p]] || !(c[p] > 0.0)) continue;
          const double t = ws->lambda[p] / c[p];
          if (t < alpha) alpha = t, j = p;
        }
      }
      if (j < 0 && CertificateResidual(*ws) > kCertificateTolerance) {
        // the factors have drifted (many updates of an ill-conditioned Kw): refactorise W once
        // and retry; failing that, leave the row out of this subproblem rather than claim an
        // infeasibility the certificate does not prove (the outer KKT check still sees it)
        if (!rebuilt) {
          RebuildWorkingSet(ws, limits.dependence_tolerance);
          RowVector<N>(*ws, row, ws->mnew.data());
          rebuilt = true;
          changed = true;
          continue;
        }
        ws->skipped[row] = 1;
        return changed ? EnterResult::kSkipped : EnterResult::kSkippedInPlace;
      }
      if (j < 0) {
        // a closed Cᵀw = 0 whose gap is not clearly negative proves nothing: the row is
        // consistent with W (an implicit equality at a degenerate vertex) and its violation is
        // rounding, so the step towards it has length zero. Leave it out of this subproblem;
        // the refinement on W makes W's rows, and with them this one, exact, and the outer KKT
        // check sees every row again. Never claim infeasibility without a proof.
        if (!CertificateProvesInfeasibility(*ws, limits.primal_tolerance)) {
          ws->skipped[row] = 1;
          return changed ? EnterResult::kSkipped : EnterResult::kSkippedInPlace;
        }
        *status = InnerStatus::kInfeasible;
        return EnterResult::kStop;
      }
    }
    for (int p = 0; p < ws->nw; ++p) ws->lambda[p] -= alpha * c[p];
    ws->lambda[j] = 0.0;
    lambda_new += alpha;
    Remove<N>(ws, j);
    changed = true;
    ++*iterations;
    if (OutOfBudget(limits, *iterations, status)) return EnterResult::kStop;
  }
}

}  // namespace

namespace {

// H + εI = L Lᵀ and X = L⁻¹ for n = Size<N>.
template <int N>
bool Factor(Workspace* ws, double eps, double relative_floor) noexcept {
  const Problem& p = *ws->problem;
  const int n = Size<N>(*ws);
  const double* h = p.H.data();
  double* L = ws->chol.data();   // column-major, (i, k) at L[i + k * kN]: the Schur complements
  double* X = ws->linv.data();   // X = L⁻¹, row-major
  for (int j = 0; j < n; ++j) {
    for (int i = j; i < n; ++i) L[i + j * kN] = h[i + j * n];
    double* Xj = X + j * kN;
    for (int c = 0; c < j; ++c) Xj[c] = 0.0;
    Xj[j] = 1.0;
  }
  // right-looking Cholesky: the rank-one update of the trailing block by column k, whose columns
  // are independent axpys (no chains of dependent dot products), made with the unscaled column
  // and 1/d_k (A_ij −= a_ik a_jk / d_k), so that from one pivot to the next the chain holds one
  // division and no square root. L⁻¹ by the same sweep on the identity, in the same loop, off
  // that chain: row k of X scaled by 1/√d_k is final, then removed from the rows below it with
  // l_jk = a_jk / √d_k. Only the trailing block of L is kept (the solver uses L⁻¹).
  for (int k = 0; k < n; ++k) {
    const double* Lk = L + k * kN;
    const double d = Lk[k] + eps;
    if (!(d > relative_floor * (ws->hmax + eps)) || !(d > 0.0)) return false;
    const double inv_d = 1.0 / d;
    for (int j = k + 1; j < n; ++j) {
      const double f = Lk[j] * inv_d;
      double* Lj = L + j * kN;
      for (int i = j; i < n; ++i) Lj[i] -= Lk[i] * f;
    }
    const double inv = 1.0 / std::sqrt(d);
    double* Xk = X + k * kN;
    for (int c = 0; c <= k; ++c) Xk[c] *= inv;
    for (int j = k + 1; j < n; ++j) {
      const double ljk = Lk[j] * inv;
      double* Xj = X + j * kN;
      for (int c = 0; c <= k; ++c) Xj[c] -= ljk * Xk[c];
    }
  }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j <= i; ++j) ws->linvt[j * kN + i] = X[i * kN + j];
  return true;
}

}  // namespace

bool FactorHessian(Workspace* ws, double eps, double relative_floor) noexcept {
  const int n = ws->n;
  if (!WithSize(n, [&](auto size) { return Factor<size()>(ws, eps, relative_floor); }))
    return false;
  if (relative_floor <= 0.0) return true;
  // pivots can stay well above λ_min(H) (by 1/v_n² for a null vector v): the test that counts is
  // 1/λ_min = ‖L⁻¹‖₂² ≤ ‖L⁻¹‖_F² ≤ n/λ_min, i.e. reject when max H_ii ‖L⁻¹‖_F² > 1/floor
  const double* X = ws->linv.data();
  double frobenius2 = 0.0;
  for (int i = 0; i < n; ++i) frobenius2 += Dot(X + i * kN, X + i * kN, i + 1);
  return ws->hmax * frobenius2 * relative_floor <= 1.0;
}

namespace {

template <int N>
void RefreshRightHandSidesN(Workspace* ws) noexcept {
  for (int p = 0; p < ws->nw; ++p)
    ws->d[p] = RightHandSide<N>(*ws, ws->w_row[p], ws->w_sign[p], &ws->mw[p * kN]);
}

template <int N>
bool AppendIfIndependentN(Workspace* ws, int row, int sign, double lambda,
                          double dependence_tolerance) noexcept {
  if (ws->pos_of[row] >= 0) return false;
  RowVector<N>(*ws, row, ws->mnew.data());
  return TryAppend<N>(ws, row, sign, lambda, dependence_tolerance);
}

template <int N>
void RebuildWorkingSetN(Workspace* ws, double dependence_tolerance) noexcept {
  const int nw = ws->nw;
  std::array<int, kN> rows = ws->w_row;
  std::array<std::int8_t, kN> signs = ws->w_sign;
  std::array<double, kN> lambdas = ws->lambda;
  for (int p = 0; p < nw; ++p) ws->pos_of[rows[p]] = -1;
  ws->nw = 0;
  for (int p = 0; p < nw; ++p)
    AppendIfIndependentN<N>(ws, rows[p], signs[p], lambdas[p], dependence_tolerance);
}

template <int N>
void ComputeStepN(Workspace* ws) noexcept {
  const int n = Size<N>(*ws);
  double* u = ws->u.data();
  for (int k = 0; k < n; ++k) u[k] = 0.0;
  // u = −M_Wᵀ λ   (3)
  for (int p = 0; p < ws->nw; ++p) {
    const double a = -ws->w_sign[p] * ws->lambda[p];
    if (a == 0.0) continue;
    const double* mp = &ws->mw[p * kN];
    for (int k = FirstNonZero<N>(*ws, ws->w_row[p]); k < n; ++k) u[k] += a * mp[k];
  }
  // δ = L⁻ᵀ (u − v)
  double* delta = ws->delta.data();
  for (int k = 0; k < n; ++k) delta[k] = u[k] - ws->v[k];
  BackwardChol<N>(*ws, delta);
  // C δ = [δ; A δ]
  double* cd = ws->cdelta.data();
  for (int k = 0; k < n; ++k) cd[k] = delta[k];
  MultiplyA<N>(*ws->problem, delta, cd + n);
}

}  // namespace

void RefreshRightHandSides(Workspace* ws) noexcept {
  WithSize(ws->n, [&](auto n) { RefreshRightHandSidesN<n()>(ws); });
}

void RemoveFromWorkingSet(Workspace* ws, int j) noexcept { Remove<0>(ws, j); }

bool AppendIfIndependent(Workspace* ws, int row, int sign, double lambda,
                         double dependence_tolerance) noexcept {
  return WithSize(ws->n, [&](auto n) {
    return AppendIfIndependentN<n()>(ws, row, sign, lambda, dependence_tolerance);
  });
}

void RebuildWorkingSet(Workspace* ws, double dependence_tolerance) noexcept {
  WithSize(ws->n, [&](auto n) { RebuildWorkingSetN<n()>(ws, dependence_tolerance); });
}

void ComputeStep(Workspace* ws) noexcept {
  WithSize(ws->n, [&](auto n) { ComputeStepN<n()>(ws); });
}

double RefineOnWorkingSet(Workspace* ws) noexcept {
  const Problem& p = *ws->problem;
  const int n = ws->n, nw = ws->nw;
  double* rx = ws->tmp.data();
  double* x = ws->tmp2.data();
  for (int i = 0; i < n; ++i) x[i] = ws->xk[i] + ws->delta[i];
  // r_x = H x + g + ε δ + Σ s_p λ_p C_pᵀ   (H symmetric: row i = column i)
  for (int i = 0; i < n; ++i)
    rx[i] = p.g(i) + ws->eps * ws->delta[i] + Dot(p.H.data() + i * n, x, n);
  for (int q = 0; q < nw; ++q) {
    const int row = ws->w_row[q];
    const double y = ws->w_sign[q] * ws->lambda[q];
    if (row < n) {
      rx[row] += y;
    } else {
      for (int j = 0; j < n; ++j) rx[j] += p.A(row - n, j) * y;
    }
  }
  // A x for the residuals of W's rows
  double* ax = ws->cdelta.data() + n;
  if (ws->m > 0) MultiplyA(p, x, ax);
  // v' = L⁻¹ r_x; d'_p = s_p (−r_c,p + m_pᵀ v')
  ForwardChol<0>(*ws, rx, 0);
  double* dd = ws->kvec.data();
  for (int q = 0; q < nw; ++q) {
    const int row = ws->w_row[q];
    const double cxq = row < n ? x[row] : ax[row - n];
    const double rc = cxq - SideBound(*ws, row, ws->w_sign[q]);
    dd[q] = ws->w_sign[q] * (-rc + Dot(&ws->mw[q * kN], rx, n));
  }
  // Δλ = −Kw⁻¹ d'
  double* dl = ws->mnew.data();
  for (int q = 0; q < nw; ++q) {
    const double* Lq = &ws->lw[q * kN];
    dl[q] = -dd[q] - Dot(Lq, dl, q);
  }
  for (int q = 0; q < nw; ++q) dl[q] *= ws->dw_inv[q];
  for (int q = nw - 1; q >= 0; --q) {
    const double* Lq = &ws->lw[q * kN];
    for (int k = 0; k < q; ++k) dl[k] -= Lq[k] * dl[q];
  }
  // Δδ = L⁻ᵀ (−M_Wᵀ Δλ − v')
  double* dx = ws->u.data();
  for (int i = 0; i < n; ++i) dx[i] = -rx[i];
  for (int q = 0; q < nw; ++q) {
    const double a = -ws->w_sign[q] * dl[q];
    const double* mq = &ws->mw[q * kN];
    for (int i = 0; i < n; ++i) dx[i] += a * mq[i];
  }
  BackwardChol<0>(*ws, dx);
  double step = 0.0;
  for (int i = 0; i < n; ++i) {
    ws->delta[i] += dx[i];
    step = std::fmax(step, std::fabs(dx[i]));
  }
  for (int q = 0; q < nw; ++q) {
    ws->lambda[q] += dl[q];
    if (!ws->is_eq[ws->w_row[q]] && ws->lambda[q] < 0.0) ws->lambda[q] = 0.0;
  }
  return step;
}

void ComputeRowSteps(Workspace* ws) noexcept {
  const int n = ws->n;
  for (int k = 0; k < n; ++k) ws->cdelta[k] = ws->delta[k];
  if (ws->m > 0) MultiplyA(*ws->problem, ws->delta.data(), ws->cdelta.data() + n);
}

namespace {

template <int N>
InnerStatus SolveSubproblemN(Workspace* ws, const InnerLimits& limits, int* iterations,
                             bool scan_first) noexcept {
  InnerStatus status = InnerStatus::kOptimal;
  for (int i = 0; i < ws->rows; ++i) ws->skipped[i] = ws->dependent_entries[i] = 0;
  for (bool scan_next = scan_first;;) {
    const int nw = ws->nw;
    const bool scan_only = scan_next;
    scan_next = false;
    if (!scan_only) {
      // λ* = −Kw⁻¹ d   (3), Kw = Lw Dw Lwᵀ
      double* ls = ws->lambda_star.data();
      for (int p = 0; p < nw; ++p) {
        const double* Lp = &ws->lw[p * kN];
        ls[p] = -ws->d[p] - Dot(Lp, ls, p);
      }
      for (int p = 0; p < nw; ++p) ls[p] *= ws->dw_inv[p];
      for (int p = nw - 1; p >= 0; --p) {
        const double* Lp = &ws->lw[p * kN];
        const double lp = ls[p];
        for (int q = 0; q < p; ++q) ls[q] -= Lp[q] * lp;
      }
      // dual step: λ ← λ + α (λ* − λ) up to the first inequality multiplier that reaches 0
      int j = -1;
      double alpha = 1.0;
      for (int p = 0; p < nw; ++p) {
        if (ws->is_eq[ws->w_row[p]] || !(ls[p] < 0.0)) continue;
        const double t = ws->lambda[p] / (ws->lambda[p] - ls[p]);
        if (j < 0 || t < alpha) alpha = t, j = p;
      }
      if (j >= 0) {
        for (int p = 0; p < nw; ++p) ws->lambda[p] += alpha * (ls[p] - ws->lambda[p]);
        ws->lambda[j] = 0.0;
        Remove<N>(ws, j);
        ++*iterations;
        if (OutOfBudget(limits, *iterations, &status)) return status;
        continue;
      }
      for (int p = 0; p < nw; ++p) ws->lambda[p] = ls[p];
      ComputeStepN<N>(ws);
    }
    // primal step: the most violated row (relative to its bound) enters; branch-free scan over
    // bounds clamped to ±1e300 (an infinite side is never violated), W and skipped rows masked
    int enter = -1;
    double worst = limits.primal_tolerance;
    for (int i = 0; i < ws->rows; ++i) {
      const double value = ws->cx[i] + ws->cdelta[i];
      const double up = (value - ws->hi_finite[i]) * ws->hi_scale[i];
      const double down = (ws->lo_finite[i] - value) * ws->lo_scale[i];
      double v = up > down ? up : down;
      v = (ws->pos_of[i] >= 0 || ws->skipped[i]) ? -1.0 : v;
      const bool better = v > worst;
      worst = better ? v : worst;
      enter = better ? i : enter;
    }
    int enter_sign = 0;
    if (enter >= 0) {
      const double value = ws->cx[enter] + ws->cdelta[enter];
      enter_sign = value > ws->hi[enter] ? 1 : -1;
    }
    if (enter < 0) return InnerStatus::kOptimal;
    const EnterResult entered =
        Enter<N>(ws, enter, enter_sign, worst, limits, iterations, &status);
    if (entered == EnterResult::kStop) return status;
    if (entered == EnterResult::kSkipped) continue;
    // nothing changed: go on scanning the same step (recomputing it from λ would also throw
    // away a refinement of it)
    if (entered == EnterResult::kSkippedInPlace) {
      scan_next = true;
      continue;
    }
    ++*iterations;
    if (OutOfBudget(limits, *iterations, &status)) return status;
  }
}

}  // namespace

InnerStatus SolveSubproblem(Workspace* ws, const InnerLimits& limits, int* iterations,
                            bool scan_first) noexcept {
  return WithSize(ws->n, [&](auto n) {
    return SolveSubproblemN<n()>(ws, limits, iterations, scan_first);
  });
}

}  // namespace hyq::qp::internal
