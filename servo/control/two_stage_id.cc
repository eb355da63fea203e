#include "servo/control/two_stage_id.h"

#include <algorithm>
#include <cmath>

#include <Eigen/SVD>

#include "dynamics/fixed_products.h"
#include "dynamics/small_cholesky.h"
#include "servo/control/contact_free_id.h"
#include "servo/control/friction_cone.h"
#include "servo/control/pivoted_qr.h"

namespace hyq::servo {
namespace {

constexpr int kB = dynamics::kNumBaseDofs;
constexpr int kJ = dynamics::kNumJoints;

using dynamics::Times;

// J_c,i v from the only nonzero columns of contact i's Jacobian: the base's and its leg's
Eigen::Vector3d FootVelocity(const ContactSet& set, int i, const VectorV& v) {
  const int first = kB + dynamics::JointIndex(set.foot[i], 0);
  Eigen::Vector3d u = set.J_c[i].leftCols<kB>() * v.head<kB>();
  u.noalias() += set.J_c[i].middleCols<dynamics::kJointsPerLeg>(first) *
                 v.segment<dynamics::kJointsPerLeg>(first);
  return u;
}

double KineticEnergy(const dynamics::CycleDynamics& dyn, const VectorV& v) {
  return dynamics::HalfQuadraticForm(dyn.M, v);
}

// The contact-free answer: τ = f_ID, v* = v + h [a_b; q̈_des].
void ContactFreeAnswer(const dynamics::CycleDynamics& dyn, const IdInput& in,
                       const VectorJ& f_id, const dynamics::Vector6d& a_b, IdOutput* out) {
  out->tau_Nm = f_id;
  out->v_star = in.v;
  out->v_star.head<kB>() += in.dt * a_b;
  out->v_star.tail<kJ>() += in.dt * in.qdd_des;
  out->kinetic_energy_J = KineticEnergy(dyn, out->v_star);
  for (auto& c : out->impulses) c = ContactImpulse{};
}

// A warm start from the previous cycle's working set can lead the dual active set into a long
// detour that a cold start avoids, so the warm attempt is capped at kWarmIterations (well above
// what a warm ID needs along a trot, where the working set changes little between cycles); past
// that the QP is solved again cold, with at most kColdIterations, and then once more by the last
// attempt below before a fallback.
constexpr int kWarmIterations = 100;
// A QP that a cold start does not solve in 100 iterations is a degenerate one, on which the
// proximal outer loop stalls at ε's floor; more iterations would only spend the cycle's time
// budget that the last attempt needs, and the last attempt solves such QPs in a few dozen.
constexpr int kColdIterations = 100;
// The last attempt, cold with a large proximal weight (relative to max H_ii): on a degenerate
// Stage II QP, where a small ε is reduced to its floor and the primal residual stops shrinking,
// a large ε converges in one outer iteration of a few active-set changes. Only a last attempt:
// as a start it would stop the flat directions early (docs/qp.md).
constexpr double kLastResortProximalWeight = 1e-2;
// Under a time budget the attempts share it: the warm one may use 40 % of what is left when it
// starts, the cold one 60 % of what is left after that, so at least 24 % of the budget is kept
// for the last attempt, which is the one that solves the degenerate QPs.
constexpr double kWarmShareOfTime = 0.4;
constexpr double kColdShareOfTime = 0.6;

// One attempt with at most max_iterations and, under a deadline, at most `share` of the time
// left. True when the attempt stopped on its own limits and the next one should run.
bool Attempt(qp::Solver& solver, const qp::Problem& p, qp::Budget budget, int max_iterations,
             double share, qp::Solution* s, qp::Status* st) noexcept {
  budget.max_iterations = std::min(budget.max_iterations, max_iterations);
  const auto final_deadline = budget.deadline;
  if (final_deadline) budget.deadline = final_deadline->Share(share);
  *st = solver.Solve(p, budget, s);
  if (*st == qp::Status::kIterationLimit) return true;
  return *st == qp::Status::kDeadline && final_deadline && !final_deadline->Passed();
}

qp::Status SolveWithRetries(qp::Solver& solver, qp::Solver& last_resort, const qp::Problem& p,
                            qp::Budget budget, qp::Solution* s) noexcept {
  // s reports the attempts together: their iterations and their time
  qp::Status st;
  int used = 0;
  double spent_s = 0.0;
  const auto account = [&] {
    used += s->iterations;
    spent_s += s->solve_time_s;
  };
  if (budget.warm_start) {
    if (!Attempt(solver, p, budget, kWarmIterations, kWarmShareOfTime, s, &st)) return st;
    account();
    budget.warm_start = false;
  }
  if (Attempt(solver, p, budget, kColdIterations, kColdShareOfTime, s, &st)) {
    account();
    st = last_resort.Solve(p, budget, s);
  }
  s->iterations += used;
  s->solve_time_s += spent_s;
  return st;
}

}  // namespace

qp::Settings IdQpSettings(double proximal_weight) noexcept {
  qp::Settings q;
  q.proximal_weight = proximal_weight;
  // Stage I's H has rank ≤ 6 and Stage II's is singular too on a trot's contact sets: an ε = 0
  // factorisation attempt fails on them and only costs time; skipping it changes no answer
  q.singular_hessian = true;
  return q;
}

const char* ToString(Fallback f) noexcept {
  switch (f) {
    case Fallback::kNone: return "none";
    case Fallback::kStage1Torque: return "stage1_torque";
    case Fallback::kContactFreeId: return "contact_free_id";
    case Fallback::kSafety: return "safety";
  }
  return "unknown";
}

bool ClampToEffortLimits(const dynamics::Model& model, VectorJ* tau_Nm) noexcept {
  bool clamped = false;
  for (int j = 0; j < kJ; ++j) {
    const double limit = model.limits[j].effort_Nm;
    if (!(limit > 0.0)) continue;  // no limit given (the URDF loader demands one)
    const double t = std::clamp((*tau_Nm)(j), -limit, limit);
    clamped |= t != (*tau_Nm)(j);
    (*tau_Nm)(j) = t;
  }
  return clamped;
}

const char* ToString(StageOneObjective o) noexcept {
  switch (o) {
    case StageOneObjective::kMaximumDissipation: return "maximum_dissipation";
    case StageOneObjective::kKineticEnergy: return "kinetic_energy";
  }
  return "unknown";
}

const char* ToString(IdStatus s) noexcept {
  switch (s) {
    case IdStatus::kOk: return "ok";
    case IdStatus::kFallback: return "fallback";
    case IdStatus::kBadInput: return "bad_input";
  }
  return "unknown";
}

TwoStageId::TwoStageId(const TwoStageSettings& settings)
    : settings_(settings),
      solver1_(IdQpSettings(settings.qp_proximal_weight)),
      solver2_(IdQpSettings(settings.qp_proximal_weight)),
      last_resort_(IdQpSettings(kLastResortProximalWeight)) {
  // combinations of the r tangent directions d_k = (cos θ_k, sin θ_k) that sum to zero: the
  // null space of the 2 × r matrix [cos; sin], orthonormal (configuration time, may allocate)
  const int r = std::clamp(settings_.tangent_directions, 1, kMaxTangents);
  Eigen::MatrixXd T(2, r);
  for (int k = 0; k < r; ++k) T.col(k) << std::cos(2 * M_PI * k / r), std::sin(2 * M_PI * k / r);
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(T, Eigen::ComputeFullV);
  const int rank = static_cast<int>((svd.singularValues().array() > 1e-9).count());
  tangent_null_ = svd.matrixV().rightCols(r - rank);
}

void TwoStageId::Reset() noexcept { have_last_ = false; }

qp::Budget TwoStageId::MakeBudget(bool warm, int max_iterations) const noexcept {
  qp::Budget b;
  b.max_iterations = max_iterations;
  b.warm_start = warm;
  if (settings_.time_budget)
    b.deadline = qp::Deadline::In(*settings_.time_budget, settings_.time_budget_clock);
  return b;
}

IdStatus TwoStageId::Solve(const dynamics::Model& model, const dynamics::CycleDynamics& dyn,
                           const dynamics::VectorV& h_bias, const IdInput& in,
                           IdOutput* out) noexcept {
  ++counters_.calls;
  *out = IdOutput{};
  if (!in.qdd_des.allFinite() || !in.v.allFinite() || !(in.dt > 0.0) || !std::isfinite(in.dt) ||
      BuildContactSet(model, dyn.feet, in, settings_.tangent_directions, &set_) !=
          ContactStatus::kOk) {
    ++counters_.bad_input;
    out->fallback = Fallback::kSafety;
    have_last_ = false;
    return IdStatus::kBadInput;
  }
  const double h = in.dt;
  dynamics::Vector6d a_b;
  const VectorJ f_id = ContactFreeId(dyn, h_bias, in.qdd_des, &a_b);

  // zero stance feet: the contact-free floating-base ID is the answer
  if (set_.count == 0) {
    ++counters_.no_contact;
    ContactFreeAnswer(dyn, in, f_id, a_b, out);
    have_last_ = false;
    return IdStatus::kOk;
  }

  consistent_ = in;
  if (settings_.project_contact_velocity) {
    // v ← v − M⁻¹J_cᵀ (J_c M⁻¹ J_cᵀ)⁻¹ J_c v: the velocity an inelastic impact of the stance
    // contacts would leave (M-orthogonal projection onto J_c v = 0), so the method does not try
    // to absorb, within h, contact-point velocities the rigid-contact model cannot have
    (void)ProjectContactVelocity(set_, dyn, &consistent_.v);
  }
  if (settings_.velocity_consistent_qdd)
    (void)MakeVelocityConsistent(set_, consistent_.v, h, &consistent_.qdd_des);
  RunStage1(dyn, h_bias, consistent_, f_id);
  out->stage1 = {true, s1_.status, s1_.objective, s1_.iterations, s1_.solve_time_s};
  if (s1_.status != qp::Status::kOptimal) {
    ++counters_.stage1_failed;
    ContactFreeAnswer(dyn, in, f_id, a_b, out);
    out->fallback = Fallback::kContactFreeId;
    if (ClampToEffortLimits(model, &out->tau_Nm)) ++counters_.clamped;
    have_last_ = false;
    return IdStatus::kFallback;
  }
  last_stance_ = in.stance;
  have_last_ = true;

  // x = (F⁻¹(v*_q − k) − G z)/h,  τ = f_ID + x   (19)
  const auto z = s1_.x.head(set_.num_impulses());
  VectorJ x = Times(dyn.inv.F_inv, v_star_q_ - k_);
  x -= Times(G_, z);
  out->tau_Nm = f_id + x / h;
  // v*_b = Z z + p   (23)
  out->v_star.head<kB>() = p_;
  out->v_star.head<kB>() += Times(Z_, z);
  out->v_star.tail<kJ>() = v_star_q_;
  out->kinetic_energy_J = KineticEnergy(dyn, out->v_star);
  ImpulsesFromZ(set_, s1_.x, &out->impulses);

  if (settings_.stage2 && !RunStage2(h, out)) {
    ++counters_.stage2_failed;
    out->fallback = Fallback::kStage1Torque;
    if (ClampToEffortLimits(model, &out->tau_Nm)) ++counters_.clamped;
    return IdStatus::kFallback;
  }
  return IdStatus::kOk;
}

// v ← v − M⁻¹J_cᵀ (J_c M⁻¹ J_cᵀ)⁻¹ J_c v.
bool ProjectContactVelocity(const ContactSet& set, const dynamics::CycleDynamics& dyn,
                            VectorV* v) noexcept {
  if (set.count == 0) return true;
  // With M's factorisation (dynamics/mass_matrix_factor.h: Y = B C⁻¹, Ā = A − Y Bᵀ) and J_c,i
  // zero outside the base columns and its own leg l_i's three (J_b,i, J_q,i), per contact
  //   S_i = J_b,iᵀ − Y_l_i J_q,iᵀ,  X_i = Ā⁻¹ S_i,  X_c,i = C_l_i⁻¹ J_q,iᵀ
  //   M⁻¹ J_c,iᵀ = [X_i; leg l: δ_l,l_i X_c,i − Y_lᵀ X_i]
  //   G_ij = J_c,i M⁻¹ J_c,jᵀ = S_iᵀ X_j + δ_ij J_q,i X_c,i      (the feet are on distinct legs)
  // so neither G nor the update needs an 18-dof solve per row of J_c
  const int nc = set.count;
  const int rows = 3 * nc;
  std::array<Eigen::Matrix<double, kB, 3>, kMaxContacts> S, X;
  std::array<Eigen::Matrix3d, kMaxContacts> Jq, Xc;
  Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, 12, 1> Jv(rows);
  for (int i = 0; i < nc; ++i) {
    const int leg = set.foot[i];
    const int first = dynamics::JointIndex(leg, 0);
    Jq[i] = set.J_c[i].middleCols<dynamics::kJointsPerLeg>(kB + first);
    Jv.segment<3>(3 * i) = FootVelocity(set, i, *v);
    S[i] = set.J_c[i].leftCols<kB>().transpose();
    S[i].noalias() -= dyn.factor.Y.middleCols<dynamics::kJointsPerLeg>(first) * Jq[i].transpose();
    X[i].noalias() = dyn.factor.Abar_inv * S[i];
    Xc[i].noalias() = dyn.factor.C_inv[leg] * Jq[i].transpose();
  }
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 12, 12> G(rows, rows);
  for (int i = 0; i < nc; ++i) {
    for (int j = i; j < nc; ++j) {
      Eigen::Matrix3d g;
      g.noalias() = S[i].transpose() * X[j];
      if (j == i) g.noalias() += Jq[i] * Xc[i];
      G.block<3, 3>(3 * i, 3 * j) = g;
      if (j != i) G.block<3, 3>(3 * j, 3 * i) = g.transpose();
    }
  }
  // λ = G⁻¹ J_c v
  if (!dynamics::CholeskyInPlace(G)) return false;
  auto& lam = Jv;
  dynamics::CholeskySolveInPlace(G, lam);
  // v −= M⁻¹ J_cᵀ λ: the base part x_b = Σ X_i λ_i; leg l: X_c,i λ_i (its own foot) − Y_lᵀ x_b
  dynamics::Vector6d x_b = dynamics::Vector6d::Zero();
  for (int i = 0; i < nc; ++i) x_b.noalias() += X[i] * lam.segment<3>(3 * i);
  v->head<kB>() -= x_b;
  for (int leg = 0; leg < dynamics::kNumLegs; ++leg) {
    const int first = dynamics::JointIndex(leg, 0);
    v->segment<dynamics::kJointsPerLeg>(kB + first).noalias() +=
        dyn.factor.Y.middleCols<dynamics::kJointsPerLeg>(first).transpose() * x_b;
  }
  for (int i = 0; i < nc; ++i) {
    const int first = dynamics::JointIndex(set.foot[i], 0);
    v->segment<dynamics::kJointsPerLeg>(kB + first).noalias() -= Xc[i] * lam.segment<3>(3 * i);
  }
  return true;
}

// Stance foot i on leg l: J_c,i (v + h v̇) = 0 with v̇ = [a_b; q̈] gives
//   q̈_l = c_i + K_i a_b,  K_i = −J_q,i⁻¹ J_b,i,  c_i = −J_q,i⁻¹ J_c,i v / h
// (J_q,i: the 3 × 3 block of the leg's joints, J_b,i: the base columns). The consistent stance
// accelerations are c + range(K); the Euclidean projection of q̈_des onto them is
// c + Π_range(K) (q̈_des − c). One foot: K is 3 × 6 of rank 3, nothing to do.
bool MakeVelocityConsistent(const ContactSet& set, const VectorV& v, double h,
                            VectorJ* qdd_des) noexcept {
  const int n = set.count;
  if (n <= 1) return true;
  Eigen::Matrix<double, Eigen::Dynamic, kB, Eigen::ColMajor, 3 * kMaxContacts, kB> K(3 * n, kB);
  Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, 3 * kMaxContacts, 1> c(3 * n), x(3 * n);
  for (int i = 0; i < n; ++i) {
    const int first = dynamics::JointIndex(set.foot[i], 0);
    const Eigen::Matrix3d Jq = set.J_c[i].middleCols<dynamics::kJointsPerLeg>(kB + first);
    const double scale = Jq.norm();
    if (!(std::abs(Jq.determinant()) > 1e-9 * scale * scale * scale)) return false;  // knee straight
    const Eigen::Matrix3d Jq_inv = Jq.inverse();
    K.middleRows<3>(3 * i).noalias() = -Jq_inv * set.J_c[i].leftCols<kB>();
    c.segment<3>(3 * i).noalias() = -Jq_inv * FootVelocity(set, i, v) / h;
    x.segment<3>(3 * i) = qdd_des->segment<dynamics::kJointsPerLeg>(first) - c.segment<3>(3 * i);
  }
  // the projection onto range(K) = span of the first rank(K) columns of K's QR: with two feet K
  // is 6 × 6 of rank 5 (turning about the line through both feet moves neither), an exact
  // deficiency whose rounding must not count as rank
  PivotedQr<3 * kMaxContacts, kB> qr;
  qr.Compute(K, 1e-9);
  const int rank = qr.rank();
  qr.ApplyQt(x, rank);
  x.tail(3 * n - rank).setZero();
  qr.ApplyQ(x, rank);
  if (!x.allFinite()) return false;
  for (int i = 0; i < n; ++i)
    qdd_des->segment<dynamics::kJointsPerLeg>(dynamics::JointIndex(set.foot[i], 0)) =
        c.segment<3>(3 * i) + x.segment<3>(3 * i);
  return true;
}

void TwoStageId::RunStage1(const dynamics::CycleDynamics& dyn, const dynamics::VectorV& h_bias,
                           const IdInput& in, const VectorJ& f_id) noexcept {
  const double h = in.dt;
  const int nz = set_.num_impulses();
  const int nc = set_.count;
  const auto R_b = set_.R.topRows<kB>();
  const auto R_q = set_.R.bottomRows<kJ>();

  // j, k (15, 16): [j; k] = v + M⁻¹ h (f_ext + [0; f_ID]),  f_ext = −h_bias
  VectorV w = -h * h_bias;
  w.tail<kJ>() += h * f_id;
  dynamics::SolveInPlace(dyn.factor, &w);
  const dynamics::Vector6d j = in.v.head<kB>() + w.head<kB>();
  k_ = in.v.tail<kJ>() + w.tail<kJ>();
  v_star_q_ = in.v.tail<kJ>() + h * in.qdd_des;  // (5)

  // Z = A⁻¹ R_b (21),  p = j − A⁻¹B (v*_q − k) (22),  G = R_q − (A⁻¹B)ᵀ R_b  (19), column by
  // column in fixed-size blocks
  Z_.resize(kB, nz);
  G_.resize(kJ, nz);
  for (int c = 0; c < nz; ++c) {
    const dynamics::Vector6d rb = R_b.col(c);
    Z_.col(c).noalias() = dyn.inv.A_inv * rb;
    G_.col(c) = R_q.col(c);
    G_.col(c).noalias() -= dyn.inv.A_inv_B.transpose() * rb;
  }
  p_ = j;
  p_ -= Times(dyn.inv.A_inv_B, v_star_q_ - k_);

  // (27): H = ZᵀAZ = R_bᵀ A⁻¹ R_b = R_bᵀ Z, the upper triangle mirrored (exactly symmetric;
  // PSD up to rounding, far inside the proximal weight both solvers add)
  p1_.SetSizes(nz, 2 * nc);  // every entry of H, g and A is written below
  for (int c = 0; c < nz; ++c) {
    const dynamics::Vector6d zc = Z_.col(c);
    for (int r = 0; r <= c; ++r) p1_.H(r, c) = p1_.H(c, r) = R_b.col(r).dot(zc);
  }
  // Rᵀ v* at z = 0: R_bᵀ p + R_qᵀ v*_q, where column c of R_q is zero outside its contact's leg
  qp::VectorN rv(nz);
  for (int c = 0; c < nz; ++c) {
    const int leg = dynamics::JointIndex(set_.foot[set_.ContactOfImpulse(c)], 0);
    rv(c) = R_b.col(c).dot(p_) + R_q.col(c).segment<dynamics::kJointsPerLeg>(leg).dot(
                                     v_star_q_.segment<dynamics::kJointsPerLeg>(leg));
  }
  if (settings_.objective == StageOneObjective::kKineticEnergy) {
    // g = ZᵀA p + ZᵀB v*_q = R_bᵀ (p + A⁻¹B v*_q)   (27 as printed)
    dynamics::Vector6d pg = p_;
    pg += Times(dyn.inv.A_inv_B, v_star_q_);
    p1_.g.noalias() = R_b.transpose() * pg;
  } else {
    // g = R_bᵀ p + R_qᵀ v*_q: then H z + g = R_bᵀ (Z z + p) + R_qᵀ v*_q = Rᵀ v*
    p1_.g = rv;
  }
  p1_.lb.setZero();  // (29); ub stays +inf
  for (int i = 0; i < nc; ++i) {
    if (Frictionless(set_, i, settings_.frictionless_mu))
      for (int k = 0; k < set_.tangents; ++k) p1_.ub(set_.TangentIndex(i, k)) = 0.0;
  }
  for (int i = 0; i < nc; ++i) {
    // (28): N_iᵀ v* = N_b,iᵀ (Z z + p) + N_q,iᵀ v*_q ≥ 0
    const int ni = set_.NormalIndex(i);
    p1_.A.row(i) = p1_.H.row(ni);  // R_b,niᵀ Z
    p1_.lbA(i) = -rv(ni);
    // (30): μ_i c_N,i − Σ_k c_D,ik ≥ 0 (servo/control/friction_cone.h)
    FrictionConeRow(set_, i, p1_.A.row(nc + i).head(nz));
    p1_.lbA(nc + i) = Frictionless(set_, i, settings_.frictionless_mu) ? -qp::kInf : 0.0;  // implied
  }
  const bool warm = have_last_ && last_stance_ == in.stance;
  (void)SolveWithRetries(solver1_, last_resort_, p1_, MakeBudget(warm, settings_.max_iterations),
                         &s1_);
}

bool TwoStageId::RunStage2(double h, IdOutput* out) noexcept {
  const int nz = set_.num_impulses();
  const int nc = set_.count;
  const auto z = s1_.x.head(nz);

  if (!BuildNullSpace()) {
    out->stage2 = {false, qp::Status::kOptimal, 0.5 * out->tau_Nm.squaredNorm(), 0, 0.0};
    return true;  // nothing to redistribute: Stage I's answer is the only one
  }
  const auto P = P_.leftCols(null_dim_);
  qp::VectorN optimal_set_row;
  const bool keep_objective = OptimalSetRow(&optimal_set_row);

  // min ½ ‖h τ_I − G P w‖² (h² × eq 7, same minimiser) s.t. z + P w ≥ 0, friction rows (8),
  // and gᵀP w = 0 (9): Stage I's objective stays at its optimum
  // G P by P's structure: an internal-force column is dense, a cancelling pair of tangent
  // directions touches only its contact's r tangent columns of G
  const int r = set_.tangents;
  GP_.resize(kJ, null_dim_);
  for (int c = 0; c < internal_cols_; ++c) GP_.col(c) = Times(G_, P.col(c));
  for (int c = internal_cols_; c < null_dim_; ++c) {
    const int first = set_.TangentIndex(cancel_contact_[c - internal_cols_], 0);
    VectorJ col = G_.col(first) * P(first, c);
    for (int k = 1; k < r; ++k) col += G_.col(first + k) * P(first + k, c);
    GP_.col(c) = col;
  }
  p2_.SetSizes(null_dim_, nz + nc + (keep_objective ? 1 : 0));  // every entry written below
  const VectorJ h_tau = h * out->tau_Nm;
  for (int c = 0; c < null_dim_; ++c) {
    const VectorJ gc = GP_.col(c);
    for (int q = 0; q <= c; ++q) p2_.H(q, c) = p2_.H(c, q) = GP_.col(q).dot(gc);
    p2_.g(c) = -gc.dot(h_tau);
  }
  // w = 0 must be exactly feasible: Stage I's z meets z ≥ 0 and the friction rows only to the
  // solver's tolerance, so the right-hand sides are clamped at 0
  p2_.A.topRows(nz) = P;
  p2_.lbA.head(nz) = (-z).cwiseMin(0.0);
  for (int i = 0; i < nc; ++i) {
    // (30) at z + P w: (μ_i e_N,i − Σ_k e_D,ik)ᵀ P w ≥ −slack(z)
    FrictionConeRowOf(set_, i, P, p2_.A.row(nz + i));
    p2_.lbA(nz + i) = std::min(-FrictionConeSlack(set_, i, z), 0.0);
    if (Frictionless(set_, i, settings_.frictionless_mu)) {
      // P keeps this contact's tangential impulses at 0: their rows and the friction row hold
      p2_.lbA(nz + i) = -qp::kInf;
      for (int k = 0; k < set_.tangents; ++k) p2_.lbA(set_.TangentIndex(i, k)) = -qp::kInf;
    }
  }
  if (keep_objective) {
    // one equality row rather than a reduced basis P · null(gᵀP): the rows z + P w ≥ 0 keep
    // P's exact zeros and w = 0 stays exactly feasible. (Both forms leave a few degenerate
    // problems, pinned to w = 0 by several feet sliding on their friction limits, at the
    // iteration budget: then Stage I's torque, which is Stage I-optimal too, is used.)
    p2_.A.row(nz + nc) = optimal_set_row.transpose();
    p2_.lbA(nz + nc) = 0.0;
    p2_.ubA(nz + nc) = 0.0;
  }
  const bool warm = last_null_dim_ == null_dim_ && have_last_;
  last_null_dim_ = null_dim_;
  const qp::Status st =
      SolveWithRetries(solver2_, last_resort_, p2_,
                       MakeBudget(warm, settings_.stage2_max_iterations), &s2_);
  out->stage2 = {true, st, 0.0, s2_.iterations, s2_.solve_time_s};
  if (st != qp::Status::kOptimal) {
    last_null_dim_ = -1;
    return false;
  }
  // z_II = z + P w,  τ_II = τ_I − G P w / h; v* (and so the kinetic energy) is unchanged
  const auto w = s2_.x.head(null_dim_);
  out->tau_Nm -= Times(GP_, w) / h;
  qp::VectorN z2 = z;
  z2.noalias() += P * w;
  ImpulsesFromZ(set_, z2, &out->impulses);
  out->stage2.objective = 0.5 * out->tau_Nm.squaredNorm();
  return true;
}

// Stage I's optimal set is {feasible z : R_b z = R_b z*, gᵀz = gᵀz*} (every minimiser of a
// convex QP has the same H z and gᵀz, and H = YᵀY with Y = L⁻¹R_b). P keeps R_b z; along it
//   f(z + P w) − f(z) = (H z + g)ᵀ P w + ½ wᵀPᵀHPw = gᵀP w        (H P = R_bᵀA⁻¹ R_b P = 0)
// which is the work Σ_i v_c,iᵀ Δimpulse_i of the redistributed impulses on the contact
// velocities (H z + g = Rᵀv*): zero on sticking contacts, not on sliding or separating ones.
// Fills *row with (Pᵀg)ᵀ / ‖Pᵀg‖ and returns true when Stage II needs the row gᵀP w = 0 (9);
// false when Pᵀg is rounding-sized (every contact sticks, or the kinetic-energy objective, whose
// g is in range(R_bᵀ)). Only the internal-force columns can contribute: a cancelling pair of
// tangent directions has R P = 0, so its entry v*ᵀ R P is exactly 0 and stays so (a row with
// rounding noise there would couple it to the others).
bool TwoStageId::OptimalSetRow(qp::VectorN* row) const noexcept {
  const int nz = set_.num_impulses();
  const auto g = p1_.g.head(nz);
  row->setZero(null_dim_);
  double c_max = 0.0, rounding = 0.0;
  for (int j = 0; j < internal_cols_; ++j) {
    (*row)(j) = P_.col(j).dot(g);
    c_max = std::max(c_max, std::abs((*row)(j)));
    rounding = std::max(rounding, P_.col(j).cwiseAbs().dot(g.cwiseAbs()));
  }
  if (!(c_max > settings_.optimal_set_tolerance * rounding)) return false;
  *row /= row->norm();
  return true;
}

bool TwoStageId::BuildNullSpace() noexcept {
  const int nc = set_.count;
  const int r = set_.tangents;
  const int nz = set_.num_impulses();
  // internal forces: F with Σ_i J_c,i,bᵀ f_i = 0, from the QR of Wᵀ; a frictionless contact
  // contributes only its normal (one row n_iᵀ J_c,i,b), the others all three directions
  std::array<int, kMaxContacts> first_row{};
  int rows = 0;
  for (int i = 0; i < nc; ++i) rows += Frictionless(set_, i, settings_.frictionless_mu) ? 1 : 3;
  Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::ColMajor, kMaxForceRows, 6> Wt(rows, 6);
  rows = 0;
  for (int i = 0; i < nc; ++i) {
    first_row[i] = rows;
    if (Frictionless(set_, i, settings_.frictionless_mu)) {
      Wt.row(rows++) = set_.normal_W[i].transpose() * set_.J_c[i].leftCols<kB>();
    } else {
      Wt.middleRows<3>(rows) = set_.J_c[i].leftCols<kB>();
      rows += 3;
    }
  }
  qr_.Compute(Wt, settings_.null_space_tolerance);
  const int internal = rows - qr_.rank();
  const int cancelling = static_cast<int>(tangent_null_.cols());
  int frictional = 0;
  for (int i = 0; i < nc; ++i) frictional += !Frictionless(set_, i, settings_.frictionless_mu);
  // with fewer than three directions a tangent force cannot always be written in them
  const bool liftable = r >= 3;
  internal_cols_ = liftable ? internal : 0;
  null_dim_ = internal_cols_ + frictional * cancelling;
  if (null_dim_ == 0) return false;
  P_.setZero(nz, null_dim_);
  int col = 0;
  if (liftable && internal > 0) {
    // the trailing columns of Q only: Q [0; I] (cheaper than evaluating all of Q)
    Qw_.setZero(rows, internal);
    Qw_.bottomRows(internal).setIdentity();
    for (int j = 0; j < internal; ++j) qr_.ApplyQ(Qw_.col(j), qr_.size());
    // f_i = a n + b t1 + c t2 lifts to z_N = a, z_D,k = (2/r)(b cos θ_k + c sin θ_k)
    for (int j = 0; j < internal; ++j, ++col) {
      const auto f = Qw_.col(j);
      for (int i = 0; i < nc; ++i) {
        if (Frictionless(set_, i, settings_.frictionless_mu)) {
          P_(set_.NormalIndex(i), col) = f(first_row[i]);
          continue;
        }
        const Eigen::Vector3d fi = f.segment<3>(first_row[i]);
        P_(set_.NormalIndex(i), col) = set_.normal_W[i].dot(fi);
        const double b = set_.t1_W[i].dot(fi), c = set_.t2_W[i].dot(fi);
        for (int k = 0; k < r; ++k)
          P_(set_.TangentIndex(i, k), col) = 2.0 / r * (b * set_.cos_k[k] + c * set_.sin_k[k]);
      }
    }
  }
  for (int i = 0; i < nc; ++i) {
    if (Frictionless(set_, i, settings_.frictionless_mu)) continue;
    for (int j = 0; j < cancelling; ++j, ++col) {
      cancel_contact_[col - internal_cols_] = i;
      for (int k = 0; k < r; ++k) P_(set_.TangentIndex(i, k), col) = tangent_null_(k, j);
    }
  }
  return true;
}

}  // namespace hyq::servo
