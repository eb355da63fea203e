// The two-stage contact-aware ID checked as physics, not only as code: the impulse-momentum
// equation (6) with the returned τ and impulses, the constraints (2)–(5), Stage II's energy and
// torque-norm properties, agreement with the no-slip ID where both apply, friction behaviour,
// Fig. 1's chatter through contact changes, the fallback chain and the heap.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <random>

#include <gtest/gtest.h>

#include "servo/control/contact_free_id.h"
#include "servo/control/controller.h"
#include "tests/servo/id_fixture.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::servo {
namespace {

using dynamics::CycleDynamics;
using testing::HyqModel;
using testing::NearRel;

constexpr std::array<bool, 4> kAll{true, true, true, true};
constexpr std::array<bool, 4> kLfRh{true, false, false, true};
constexpr std::array<std::array<bool, 4>, 3> kSlipperyStances{
    kAll, std::array<bool, 4>{true, true, false, true}, kLfRh};
constexpr std::array<bool, 4> kRfLh{false, true, true, false};

std::unique_ptr<CycleDynamics> Dyn(const IdInput& in) {
  auto d = std::make_unique<CycleDynamics>();
  EXPECT_EQ(dynamics::ComputeCycleDynamics(HyqModel(), in.q, in.v, d.get()),
            dynamics::DynamicsStatus::kOk);
  return d;
}

// Σ_i J_c,iᵀ (c_N n + c_T) from the reported per-foot impulses: the generalized impulse R z.
VectorV GeneralizedImpulse(const CycleDynamics& d, const IdInput& in, const IdOutput& out) {
  ContactSet set;
  EXPECT_EQ(BuildContactSet(HyqModel(), d.feet, in, 4, &set), ContactStatus::kOk);
  VectorV Rz = VectorV::Zero();
  for (int i = 0; i < set.count; ++i) {
    const ContactImpulse& c = out.impulses[set.foot[i]];
    EXPECT_TRUE(c.active);
    Rz += set.J_c[i].transpose() * (c.normal_Ns * set.normal_W[i] + c.tangent_Ns_W);
  }
  return Rz;
}

// v* from the equation of motion (6) itself: M (v* − v) = R z + h (f_ext + [0; τ]), f_ext = −h_bias
VectorV VStarFromMomentum(const CycleDynamics& d, const IdInput& in, const IdOutput& out) {
  VectorV rhs = GeneralizedImpulse(d, in, out) - in.dt * d.bias;
  rhs.tail<12>() += in.dt * out.tau_Nm;
  return in.v + d.M.llt().solve(rhs);
}

// Stage I's objective (27, with the maximal-dissipation linear term of docs/inverse_dynamics.md)
// rebuilt from M and h_bias alone, as a function of the reported per-foot impulses. With
// v*_q = q̇ + h q̈_des (5) and the base rows of (6) at zero impulse,
// p = v_b − A⁻¹(h h_b + B (v*_q − q̇)), and
//   f(z) = ½ zᵀ R_bᵀ A⁻¹ R_b z + zᵀ R_bᵀ p + zᵀ R_qᵀ v*_q = ½ (R_b z)ᵀ A⁻¹ (R_b z) + (R z)ᵀ [p; v*_q]
// which needs only R z = Σ_i J_c,iᵀ impulse_i. *scale: the sum of the magnitudes of its terms.
double StageOneObjectiveAt(const CycleDynamics& d, const IdInput& in, const IdOutput& out,
                           double* scale) {
  const dynamics::Matrix6d A = d.M.topLeftCorner<6, 6>();
  const Eigen::LLT<dynamics::Matrix6d> llt_A(A);
  const VectorJ vq = in.v.tail<12>() + in.dt * in.qdd_des;
  const dynamics::Vector6d p =
      in.v.head<6>() - llt_A.solve(in.dt * d.bias.head<6>() +
                                   d.M.topRightCorner<6, 12>() * (vq - in.v.tail<12>()));
  VectorV u;
  u << p, vq;
  const VectorV Rz = GeneralizedImpulse(d, in, out);
  const dynamics::Vector6d Rbz = Rz.head<6>();
  const double quadratic = 0.5 * Rbz.dot(llt_A.solve(Rbz));
  *scale = quadratic + Rz.cwiseAbs().dot(u.cwiseAbs());
  return quadratic + Rz.dot(u);
}

// The forward contact model, which needs nothing of the ID (DESIGN.md §9): given τ, the
// impulses over the same pyramid minimise the kinetic energy after the step,
//   v*(z) = v_τ + M⁻¹ R z,   v_τ = v + h M⁻¹(−h_bias + [0; τ])                          (6)
//   min ½ v*ᵀ M v* = ½ zᵀ Rᵀ M⁻¹ R z + zᵀ Rᵀ v_τ + const  s.t. z ≥ 0 (29), (30), Nᵀv* ≥ 0 (28)
// (maximal dissipation: the gradient Rᵀ v* is the contact velocity). Returns v*, NaN if the QP
// did not solve.
VectorV ForwardContactStep(const CycleDynamics& d, const IdInput& in, const VectorJ& tau) {
  ContactSet set;
  EXPECT_EQ(BuildContactSet(HyqModel(), d.feet, in, 4, &set), ContactStatus::kOk);
  const int nz = set.num_impulses(), nc = set.count;
  const Eigen::LLT<dynamics::MatrixV> llt(d.M);
  VectorV rhs = -in.dt * d.bias;
  rhs.tail<12>() += in.dt * tau;
  const VectorV v_tau = in.v + llt.solve(rhs);
  const Eigen::MatrixXd R = set.R;
  const Eigen::MatrixXd Y = llt.matrixL().solve(R);  // Rᵀ M⁻¹ R = YᵀY, exactly symmetric
  const Eigen::MatrixXd MiR = llt.solve(R);
  qp::Problem p;
  p.Resize(nz, 2 * nc);
  p.H = Y.transpose() * Y;
  p.g = R.transpose() * v_tau;
  p.lb.setZero();
  for (int i = 0; i < nc; ++i) {
    const int ni = set.NormalIndex(i);
    p.A.row(i) = R.col(ni).transpose() * MiR;
    p.lbA(i) = -R.col(ni).dot(v_tau);
    p.A(nc + i, ni) = set.mu[i];
    for (int k = 0; k < set.tangents; ++k) p.A(nc + i, set.TangentIndex(i, k)) = -1.0;
    p.lbA(nc + i) = 0.0;
  }
  qp::Solver solver;
  qp::Solution s;
  qp::Budget budget;
  budget.max_iterations = 5000;
  if (solver.Solve(p, budget, &s) != qp::Status::kOptimal)
    return VectorV::Constant(std::numeric_limits<double>::quiet_NaN());
  return v_tau + MiR * s.x.head(nz);
}

std::string Describe(const IdOutput& o) {
  return std::string("fallback ") + ToString(o.fallback) + ", stage1 " +
         qp::ToString(o.stage1.status) + " (" + std::to_string(o.stage1.iterations) +
         " it), stage2 " + qp::ToString(o.stage2.status) + " (" +
         std::to_string(o.stage2.iterations) + " it)";
}

// Stage II held in Stage I's optimal set (9): the default, spelled out for the tests about it.
TwoStageSettings WithEq9() {
  TwoStageSettings s;
  s.optimal_set_tolerance = 1e-9;
  return s;
}

// in with q̈_des replaced by its velocity-level consistent projection (MakeVelocityConsistent),
// what the ID solves with (v is contact-consistent in these tests, so the ID's projection of v
// changes nothing): the equations checked below then hold with in.qdd_des itself.
IdInput Projected(IdInput in) {
  const auto d = Dyn(in);
  ContactSet set;
  EXPECT_EQ(BuildContactSet(HyqModel(), d->feet, in, 4, &set), ContactStatus::kOk);
  EXPECT_TRUE(MakeVelocityConsistent(set, in.v, in.dt, &in.qdd_des));
  return in;
}

// The same problem solved by an ID with settings `sa` into *a and one with `sb` into *b (each
// asserted to solve).
void SolveWithBoth(const TwoStageSettings& sa, const TwoStageSettings& sb, const CycleDynamics& d,
                   const IdInput& in, IdOutput* a, IdOutput* b) {
  TwoStageId id_a(sa), id_b(sb);
  ASSERT_EQ(id_a.Solve(HyqModel(), d, in, a), IdStatus::kOk) << Describe(*a);
  ASSERT_EQ(id_b.Solve(HyqModel(), d, in, b), IdStatus::kOk) << Describe(*b);
}

// Stage I alone.
TwoStageSettings StageOneOnly() {
  TwoStageSettings s;
  s.stage2 = false;
  return s;
}

// Stage I, or Stage II, given no iterations: it cannot finish, and the ID falls back.
TwoStageSettings StageOneCannotFinish() {
  TwoStageSettings s;
  s.max_iterations = 0;
  return s;
}
TwoStageSettings StageTwoCannotFinish() {
  TwoStageSettings s;
  s.stage2_max_iterations = 0;
  return s;
}

// Stage I alone and both stages with (9) on the same problem (each asserted to solve).
void SolveBothStages(const CycleDynamics& d, const IdInput& in, IdOutput* o1, IdOutput* o2) {
  SolveWithBoth(StageOneOnly(), WithEq9(), d, in, o1, o2);
}

// Fig. 1: contact conditions 2 → 4 → 2 → 4 → 2 feet while the body sways with all feet kept
// still (contact-consistent motion at the acceleration level). Chatter = total variation
// Σ‖τ_k − τ_{k−1}‖ over the sequence, and the largest single jump. Returns {tv1, tv2, jump1, jump2}.
std::array<double, 4> SwayChatter(const TwoStageSettings& settings) {
  const std::array<std::array<bool, 4>, 5> phases{kLfRh, kAll, kRfLh, kAll, kLfRh};
  TwoStageSettings s1 = settings;
  s1.stage2 = false;
  TwoStageId stage1(s1), both(settings);
  std::mt19937_64 rng0(42);
  const IdInput base = testing::StandingInput(&rng0, kAll, 0.0);
  double tv1 = 0, tv2 = 0, jump1 = 0, jump2 = 0;
  VectorJ prev1 = VectorJ::Zero(), prev2 = VectorJ::Zero();
  constexpr int kPerPhase = 100;
  for (int k = 0; k < 5 * kPerPhase; ++k) {
    const double w = 2 * M_PI * 1.0, t = k * 1e-3;
    IdInput in = base;
    dynamics::Vector6d vb = dynamics::Vector6d::Zero(), ab = dynamics::Vector6d::Zero();
    // sway: lateral and vertical body motion, the feet fixed on the ground
    in.q(1) += 0.03 * std::sin(w * t);
    in.q(2) += 0.02 * std::sin(2 * w * t);
    vb(1) = 0.03 * w * std::cos(w * t);
    vb(2) = 0.04 * w * std::cos(2 * w * t);
    ab(1) = -0.03 * w * w * std::sin(w * t);
    ab(2) = -0.08 * w * w * std::sin(2 * w * t);
    std::mt19937_64 rng(1);
    testing::MakeContactConsistent(&in, vb, ab, &rng);  // all four feet consistent
    in.stance = phases[k / kPerPhase];
    const auto d = Dyn(in);
    IdOutput o1, o2;
    EXPECT_EQ(stage1.Solve(HyqModel(), *d, in, &o1), IdStatus::kOk) << Describe(o1);
    EXPECT_EQ(both.Solve(HyqModel(), *d, in, &o2), IdStatus::kOk) << Describe(o2);
    if (k > 0) {
      tv1 += (o1.tau_Nm - prev1).norm();
      tv2 += (o2.tau_Nm - prev2).norm();
      jump1 = std::max(jump1, (o1.tau_Nm - prev1).norm());
      jump2 = std::max(jump2, (o2.tau_Nm - prev2).norm());
    }
    prev1 = o1.tau_Nm;
    prev2 = o2.tau_Nm;
  }
  return {tv1, tv2, jump1, jump2};
}

class TwoStage : public ::testing::Test {
 protected:
  std::mt19937_64 rng_{42};
  IdInput Consistent(std::array<bool, 4> stance, double scale = 1.0, bool velocity_level = false) {
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    IdInput in = testing::StandingInput(&rng_, stance);
    dynamics::Vector6d vb, ab;
    for (int i = 0; i < 6; ++i) vb(i) = 0.2 * scale * u(rng_);
    for (int i = 0; i < 6; ++i) ab(i) = 1.0 * scale * u(rng_);
    testing::MakeContactConsistent(&in, vb, ab, &rng_, velocity_level);
    return in;
  }

  // A fresh problem on slippery ground: contact-consistent v (the ID's velocity projection is
  // then a no-op), μ in [0.05, 0.3] per foot, and a q̈_des far from contact-consistent (base
  // accelerations up to 3 m/s² and 3 rad/s², then up to ±20 rad/s² on every joint), so that
  // stance feet slide and some lift off.
  // The 40 slippery problems of the eq 9 tests (seed 16), each with Stage I's answer and that of
  // both stages with (9).
  template <class F>
  void ForEachSlipperyProblem(F&& check) {
    rng_.seed(16);
    for (int trial = 0; trial < 40; ++trial) {
      const IdInput in = Projected(Slippery(kSlipperyStances[trial % 3]));
      const auto d = Dyn(in);
      IdOutput o1, o2;
      ASSERT_NO_FATAL_FAILURE(SolveBothStages(*d, in, &o1, &o2)) << "trial " << trial;
      check(trial, *d, in, o1, o2);
    }
  }

  IdInput Slippery(std::array<bool, 4> stance) {
    std::uniform_real_distribution<double> u(-1.0, 1.0), mu(0.05, 0.3);
    IdInput in = Consistent(stance, 3.0);
    for (double& m : in.mu) m = mu(rng_);
    for (int j = 0; j < 12; ++j) in.qdd_des(j) += 20.0 * u(rng_);
    return in;
  }
  // Counts the stance contacts of in that slide (push, c_N > 0, with a tangential velocity) or
  // separate (no push, moving away) under out.v_star. (A sliding contact of the velocity-level
  // model also moves away by up to μ times its slip speed: the convex relaxation of (2)–(4).)
  static void CountContactModes(const CycleDynamics& d, const IdInput& in, const IdOutput& out,
                                int* sliding, int* separating) {
    ContactSet set;
    ASSERT_EQ(BuildContactSet(HyqModel(), d.feet, in, 4, &set), ContactStatus::kOk);
    for (int i = 0; i < set.count; ++i) {
      const Eigen::Vector3d v_c = set.J_c[i] * out.v_star;
      const double vn = set.normal_W[i].dot(v_c);
      const double vt = (v_c - vn * set.normal_W[i]).norm();
      const bool pushes = out.impulses[set.foot[i]].normal_Ns > 1e-9;
      if (!pushes && vn > 1e-6) ++*separating;
      else if (pushes && vt > 1e-6) ++*sliding;
    }
  }
};

// The velocity projection by M's factorisation and J_c's structure against the dense formula
// v − M⁻¹J_cᵀ (J_c M⁻¹ J_cᵀ)⁻¹ J_c v with a general inverse of M, for 1 to 4 stance feet in any
// combination, tilted bases and random velocities
TEST(ContactVelocityProjection, MatchesTheDenseFormulaAndStopsEveryContact) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto dyn = std::make_unique<CycleDynamics>();
  int cases = 0;
  for (int mask = 1; mask < 16; ++mask) {
    for (int t = 0; t < 4; ++t, ++cases) {
      const std::array<bool, 4> stance = {(mask & 1) != 0, (mask & 2) != 0, (mask & 4) != 0,
                                          (mask & 8) != 0};
      IdInput in = testing::StandingInput(&rng, stance, 0.2);
      for (int k = 0; k < dynamics::kNv; ++k) in.v(k) = u(rng);
      ASSERT_EQ(dynamics::ComputeCycleDynamics(HyqModel(), in.q, in.v, dyn.get()),
                dynamics::DynamicsStatus::kOk);
      ContactSet set;
      ASSERT_EQ(BuildContactSet(HyqModel(), dyn->feet, in, 4, &set), ContactStatus::kOk);
      Eigen::MatrixXd Jc(3 * set.count, dynamics::kNv);
      for (int i = 0; i < set.count; ++i) Jc.middleRows<3>(3 * i) = set.J_c[i];
      const Eigen::MatrixXd Minv = Eigen::MatrixXd(dyn->M).inverse();
      const Eigen::MatrixXd G = Jc * Minv * Jc.transpose();
      const Eigen::VectorXd ref = in.v - Minv * Jc.transpose() * G.ldlt().solve(Jc * in.v);
      VectorV v = in.v;
      ASSERT_TRUE(ProjectContactVelocity(set, *dyn, &v)) << "stance mask " << mask;
      EXPECT_LT((v - ref).lpNorm<Eigen::Infinity>(), 1e-10 * (1.0 + ref.lpNorm<Eigen::Infinity>()))
          << "stance mask " << mask;
      EXPECT_LT((Jc * v).lpNorm<Eigen::Infinity>(), 1e-10) << "stance mask " << mask;
      // a projection: applying it again changes nothing
      VectorV again = v;
      ASSERT_TRUE(ProjectContactVelocity(set, *dyn, &again));
      EXPECT_LT((again - v).lpNorm<Eigen::Infinity>(), 1e-12 * (1.0 + v.lpNorm<Eigen::Infinity>()));
    }
  }
  EXPECT_EQ(cases, 60);
}

// Which deadline fallbacks a stalled thread caused (the servo summary counts them apart)
TEST(IdFallbackKinds, DeadlineSpentByAStallOnlyWhenTheQpTimeIsFarFromTheBudget) {
  const double budget_s = 400e-6;
  IdOutput out;
  out.fallback = Fallback::kContactFreeId;  // Stage I failed
  out.stage1.status = qp::Status::kDeadline;
  for (const auto& [time_s, stalled] : std::initializer_list<std::pair<double, bool>>{
           {17.7e-6, true}, {150e-6, true}, {405e-6, false}, {480e-6, false}, {600e-6, true},
           {3.4e-3, true}}) {
    out.stage1.solve_time_s = time_s;
    EXPECT_TRUE(FellBackOnDeadline(out));
    EXPECT_EQ(DeadlineSpentByAStall(out, budget_s), stalled) << time_s;
  }
  out.stage1.status = qp::Status::kIterationLimit;  // not a deadline fallback at all
  out.stage1.solve_time_s = 17.7e-6;
  EXPECT_FALSE(DeadlineSpentByAStall(out, budget_s));
  out.fallback = Fallback::kStage1Torque;  // Stage II failed: its report counts
  out.stage1.status = qp::Status::kOptimal;
  out.stage2.status = qp::Status::kDeadline;
  out.stage2.solve_time_s = 420e-6;
  EXPECT_FALSE(DeadlineSpentByAStall(out, budget_s));
  out.stage2.solve_time_s = 20e-6;
  EXPECT_TRUE(DeadlineSpentByAStall(out, budget_s));
}

TEST_F(TwoStage, MomentumEquationAndJointRowsHold) {
  for (const auto& stance : {kAll, kLfRh, kRfLh, std::array<bool, 4>{true, true, true, false}}) {
    for (int trial = 0; trial < 20; ++trial) {
      const IdInput in = Projected(Consistent(stance));
      const auto d = Dyn(in);
      TwoStageId id;
      IdOutput out;
      ASSERT_EQ(id.Solve(HyqModel(), *d, in, &out), IdStatus::kOk) << Describe(out);
      EXPECT_EQ(out.stage1.status, qp::Status::kOptimal);
      EXPECT_EQ(out.stage2.status, qp::Status::kOptimal);
      const VectorV v_star = VStarFromMomentum(*d, in, out);
      // (6) with the returned τ and impulses reproduces the method's own v*
      EXPECT_TRUE(NearRel(v_star, out.v_star, 1e-8));
      // (5): the joint rows give v*_q = q̇ + h q̈_des
      const VectorJ vq = in.v.tail<12>() + in.dt * in.qdd_des;
      EXPECT_TRUE(NearRel(VectorJ(v_star.tail<12>()), vq, 1e-8));
    }
  }
}

TEST_F(TwoStage, VelocityConsistentQddLeavesStickingFeetAtRest) {
  // High friction, three and four feet, a q̈_des consistent at the acceleration level plus
  // ±5 rad/s² of feedback-like noise on every joint. Projected, some base motion keeps every
  // stance foot at rest after the step, so on μ = 10 no pushing foot slides; unprojected the prescribed
  // joints drag the feet. The projection is idempotent and leaves swing legs alone.
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const std::array<std::array<bool, 4>, 3> stances{kAll, std::array<bool, 4>{true, true, false, true},
                                                   kLfRh};
  double worst_on = 0.0, least_off = 1e9;
  for (int trial = 0; trial < 30; ++trial) {
    const std::array<bool, 4> stance = stances[trial % 3];
    IdInput in = Consistent(stance);
    in.mu = {10.0, 10.0, 10.0, 10.0};
    for (int j = 0; j < 12; ++j) in.qdd_des(j) += 5.0 * u(rng_);
    const auto d = Dyn(in);
    ContactSet set;
    ASSERT_EQ(BuildContactSet(HyqModel(), d->feet, in, 4, &set), ContactStatus::kOk);
    VectorJ once = in.qdd_des, twice;
    ASSERT_TRUE(MakeVelocityConsistent(set, in.v, in.dt, &once));
    twice = once;
    ASSERT_TRUE(MakeVelocityConsistent(set, in.v, in.dt, &twice));
    EXPECT_LT((twice - once).lpNorm<Eigen::Infinity>(), 1e-9) << "trial " << trial;
    for (int leg = 0; leg < 4; ++leg) {
      if (stance[leg]) continue;
      EXPECT_EQ(once.segment<3>(3 * leg), in.qdd_des.segment<3>(3 * leg)) << "trial " << trial;
    }
    TwoStageSettings off;
    off.velocity_consistent_qdd = false;
    IdOutput o_on, o_off;
    ASSERT_NO_FATAL_FAILURE(SolveWithBoth({}, off, *d, in, &o_on, &o_off)) << "trial " << trial;
    // the ID's joint rows follow the projected q̈ (5)
    EXPECT_TRUE(NearRel(VectorJ(o_on.v_star.tail<12>()), VectorJ(in.v.tail<12>() + in.dt * once),
                        1e-8)) << "trial " << trial;
    // a contact that pushes sticks (a consistent motion may also lift a foot: no push, moving
    // away); unprojected, the fastest contact point
    double on = 0.0, off_speed = 0.0;
    for (int i = 0; i < set.count; ++i) {
      if (o_on.impulses[set.foot[i]].normal_Ns > 1e-9)
        on = std::max(on, (set.J_c[i] * o_on.v_star).norm());
      off_speed = std::max(off_speed, (set.J_c[i] * o_off.v_star).norm());
    }
    worst_on = std::max(worst_on, on);
    least_off = std::min(least_off, off_speed);
  }
  std::printf("stance feet after the step: projected, pushing feet at most %.2g m/s; unprojected at "
              "least %.2g m/s\n", worst_on, least_off);
  EXPECT_LT(worst_on, 1e-7);
  EXPECT_GT(least_off, 1e-4);
}

TEST_F(TwoStage, NonPenetrationAndFrictionHold) {
  for (const auto& stance : {kAll, kLfRh}) {
    for (int trial = 0; trial < 20; ++trial) {
      IdInput in = Consistent(stance, 3.0);
      in.mu = {0.3, 0.5, 0.7, 0.2};
      const auto d = Dyn(in);
      TwoStageId id;
      IdOutput out;
      ASSERT_EQ(id.Solve(HyqModel(), *d, in, &out), IdStatus::kOk) << Describe(out);
      ContactSet set;
      ASSERT_EQ(BuildContactSet(HyqModel(), d->feet, in, 4, &set), ContactStatus::kOk);
      for (int i = 0; i < set.count; ++i) {
        const ContactImpulse& c = out.impulses[set.foot[i]];
        // (2): normal velocity of the contact point after the step, (3), (4)
        EXPECT_GE(set.normal_W[i].dot(set.J_c[i] * out.v_star), -1e-9);
        EXPECT_GE(c.normal_Ns, -1e-10);
        EXPECT_LE(c.tangent_Ns_W.norm(), in.mu[set.foot[i]] * c.normal_Ns + 1e-9);
        EXPECT_NEAR(c.tangent_Ns_W.dot(set.normal_W[i]), 0.0, 1e-12);
      }
    }
  }
}

TEST_F(TwoStage, StageTwoKeepsEnergyAndNeverRaisesTorque) {
  int strictly_lower = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const IdInput in = Consistent(trial % 2 ? kAll : kLfRh);
    const auto d = Dyn(in);
    IdOutput o1, o2;
    ASSERT_NO_FATAL_FAILURE(SolveBothStages(*d, in, &o1, &o2)) << "trial " << trial;
    // (9): the kinetic energy after the step, from (6) with Stage II's τ and impulses
    const VectorV v2 = VStarFromMomentum(*d, in, o2);
    const double ke2 = 0.5 * v2.dot(d->M * v2);
    EXPECT_NEAR(ke2, o1.kinetic_energy_J, 1e-9 * std::max(1.0, o1.kinetic_energy_J));
    EXPECT_LE(o2.tau_Nm.norm(), o1.tau_Nm.norm() * (1 + 1e-12));
    if (o2.tau_Nm.norm() < 0.99 * o1.tau_Nm.norm()) ++strictly_lower;
  }
  std::printf("Stage II lowered ||tau|| by more than 1%% in %d of 40 cases\n", strictly_lower);
  EXPECT_GT(strictly_lower, 0);
}

TEST_F(TwoStage, StageTwoStaysInStageOnesOptimalSetOnSlidingContacts) {
  // (9): Stage II may only choose among Stage I's minimisers. Along null(R_b) the Stage I
  // objective changes by the work of the redistributed impulses on the contact velocities,
  // which is not zero for contacts that slide or separate. Checked with the objective rebuilt
  // from the dynamics (StageOneObjectiveAt), at Stage I's and at Stage II's impulses.
  int sliding = 0, separating = 0, off = 0;
  double worst = 0.0;
  ForEachSlipperyProblem([&](int trial, const CycleDynamics& d, const IdInput& in,
                             const IdOutput& o1, const IdOutput& o2) {
    CountContactModes(d, in, o1, &sliding, &separating);
    double scale1 = 0.0, scale2 = 0.0;
    const double f1 = StageOneObjectiveAt(d, in, o1, &scale1);
    const double f2 = StageOneObjectiveAt(d, in, o2, &scale2);
    const double tol = 1e-8 * std::max(scale1, scale2);
    // the test's objective is the one Stage I minimised
    EXPECT_NEAR(o1.stage1.objective, f1, tol) << "trial " << trial;
    EXPECT_NEAR(f2, f1, tol) << "trial " << trial << ": Stage II left Stage I's optimum";
    if (std::abs(f2 - f1) > tol) ++off;
    worst = std::max(worst, f2 - f1);
  });
  std::printf("%d sliding and %d separating contacts; Stage II off Stage I's optimum in %d of 40, "
              "worst by %.3g J\n", sliding, separating, off, worst);
  EXPECT_GT(sliding, 10);
  EXPECT_GT(separating, 3);
}

TEST_F(TwoStage, StageTwoTorqueReproducesJointVelocitiesOnSlidingContacts) {
  // τ fed back through the forward contact model (ForwardContactStep, nothing of the ID) must
  // give the joints v*_q = q̇ + h q̈_des (5), for Stage II's torque as for Stage I's.
  double worst1 = 0.0, worst2 = 0.0;
  int missed = 0;
  ForEachSlipperyProblem([&](int trial, const CycleDynamics& d, const IdInput& in,
                             const IdOutput& o1, const IdOutput& o2) {
    const VectorJ vq = in.v.tail<12>() + in.dt * in.qdd_des;
    const VectorV v1 = ForwardContactStep(d, in, o1.tau_Nm);
    const VectorV v2 = ForwardContactStep(d, in, o2.tau_Nm);
    ASSERT_TRUE(v1.allFinite() && v2.allFinite()) << "trial " << trial;
    const double e1 = (v1.tail<12>() - vq).lpNorm<Eigen::Infinity>();
    const double e2 = (v2.tail<12>() - vq).lpNorm<Eigen::Infinity>();
    EXPECT_LT(e1, 1e-5) << "trial " << trial << ": Stage I's torque";
    EXPECT_LT(e2, 1e-5) << "trial " << trial << ": Stage II's torque";
    if (e2 >= 1e-5) ++missed;
    worst1 = std::max(worst1, e1);
    worst2 = std::max(worst2, e2);
  });
  std::printf("forward model, largest |v*_q - (qd + h qdd_des)|: Stage I %.3g rad/s, "
              "Stage II %.3g rad/s (missed 1e-5 in %d of 40)\n", worst1, worst2, missed);
}

TEST_F(TwoStage, StageTwoRemovesNothingOnStickingContacts) {
  // velocity-level consistent motion on high friction: every contact sticks, gᵀP = 0, and
  // Stage II keeps the whole null space of R_b (four feet: 6 internal forces + 2 cancelling
  // pairs per foot) with no row for (9)
  for (int trial = 0; trial < 10; ++trial) {
    IdInput in = Consistent(kAll, 1.0, true);
    in.mu = {10.0, 10.0, 10.0, 10.0};
    const auto d = Dyn(in);
    TwoStageId id(WithEq9());
    IdOutput out;
    ASSERT_EQ(id.Solve(HyqModel(), *d, in, &out), IdStatus::kOk) << Describe(out);
    int sliding = 0, separating = 0;
    CountContactModes(*d, in, out, &sliding, &separating);
    ASSERT_EQ(sliding + separating, 0);
    EXPECT_EQ(id.stage2_problem().n(), 6 + 4 * 2) << "trial " << trial;
    EXPECT_EQ(id.stage2_problem().m(), 5 * 4 + 4) << "trial " << trial;  // z ≥ 0, (30), no (9)
  }
}

TEST_F(TwoStage, MatchesNoSlipIdOnHighFrictionWhenConsistent) {
  // From rest (v = 0, so velocity- and acceleration-level contact conditions coincide) with
  // contact-consistent q̈_des and μ high enough never to bind. With three or four feet the
  // contacts fix the whole base motion: both methods give the same accelerations. Two feet
  // cannot resist rotation about the line between them: there the two-stage ID follows the
  // dynamics while Mistry's decomposition picks the minimum-norm base acceleration, so only the
  // contact-constrained parts are compared.
  // The comparison needs a q̈_des that the contact model can produce: the no-slip answer must
  // push (c_N ≥ 0) and stay inside the friction pyramid; other draws are skipped and counted.
  constexpr std::array<bool, 4> kThree{true, true, false, true};
  int compared = 0, inadmissible = 0;
  for (const auto& stance : {kAll, kThree, kLfRh, kRfLh}) {
    const bool determined = stance != kLfRh && stance != kRfLh;
    for (int trial = 0; trial < 20; ++trial) {
      std::uniform_real_distribution<double> u(-1.0, 1.0);
      IdInput in = testing::StandingInput(&rng_, stance);
      dynamics::Vector6d ab;
      for (int i = 0; i < 6; ++i) ab(i) = 0.5 * u(rng_);
      testing::MakeContactConsistent(&in, dynamics::Vector6d::Zero(), ab, &rng_);
      in.v.setZero();
      in.mu = {10.0, 10.0, 10.0, 10.0};
      const auto d = Dyn(in);
      TwoStageId two;
      NoSlipId noslip;
      IdOutput a, b;
      ASSERT_EQ(two.Solve(HyqModel(), *d, in, &a), IdStatus::kOk) << Describe(a);
      ASSERT_EQ(noslip.Solve(HyqModel(), *d, in, &b), IdStatus::kOk) << Describe(b);
      bool admissible = true;
      for (int f = 0; f < 4; ++f)
        if (in.stance[f] && (b.impulses[f].normal_Ns < 0.0 ||
                             b.impulses[f].tangent_Ns_W.lpNorm<1>() > in.mu[f] * b.impulses[f].normal_Ns))
          admissible = false;
      if (!admissible) {
        ++inadmissible;
        continue;
      }
      ++compared;
      const VectorV acc_two = (a.v_star - in.v) / in.dt;
      const VectorV acc_noslip = (b.v_star - in.v) / in.dt;
      EXPECT_TRUE(NearRel(VectorJ(acc_two.tail<12>()), VectorJ(acc_noslip.tail<12>()), 1e-9));
      ContactSet set;
      ASSERT_EQ(BuildContactSet(HyqModel(), d->feet, in, 4, &set), ContactStatus::kOk);
      for (int i = 0; i < set.count; ++i) {
        EXPECT_LT((set.J_c[i] * acc_two).norm(), 1e-6) << "foot " << set.foot[i];
        EXPECT_LT((set.J_c[i] * acc_noslip).norm(), 1e-6) << "foot " << set.foot[i];
      }
      if (determined) {
        EXPECT_TRUE(NearRel(acc_two, acc_noslip, 1e-6));
        EXPECT_TRUE(NearRel(acc_two.head<6>(), ab, 1e-6));
      }
    }
  }
  std::printf("compared %d consistent draws, skipped %d that need pulling or slipping contacts\n",
              compared, inadmissible);
  EXPECT_GE(compared, 40);
}

TEST_F(TwoStage, FrictionlessFeetGetNoTangentialImpulse) {
  IdInput in = Consistent(kAll, 3.0);
  in.mu = {1e-9, 1e-9, 1e-9, 1e-9};
  const auto d = Dyn(in);
  TwoStageId id;
  IdOutput out;
  ASSERT_EQ(id.Solve(HyqModel(), *d, in, &out), IdStatus::kOk) << Describe(out);
  for (int f = 0; f < 4; ++f) {
    EXPECT_TRUE(out.impulses[f].active);
    EXPECT_LE(out.impulses[f].tangent_Ns_W.norm(), 1e-8) << f;
  }
}

TEST_F(TwoStage, OneSlipperyFootIsTheOnlyOneBounded) {
  // push the body sideways and forwards: the feet must push tangentially
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  IdInput in = testing::StandingInput(&rng_, kAll);
  dynamics::Vector6d ab;
  ab << 0, 0, 0, 3.0, 2.0, 0;
  testing::MakeContactConsistent(&in, dynamics::Vector6d::Zero(), ab, &rng_);
  in.v.setZero();
  in.mu = {1.0, 1.0, 0.05, 1.0};  // lh on ice
  const auto d = Dyn(in);
  TwoStageId id;
  IdOutput out;
  ASSERT_EQ(id.Solve(HyqModel(), *d, in, &out), IdStatus::kOk) << Describe(out);
  const auto ratio = [&](int f) {
    return out.impulses[f].tangent_Ns_W.norm() / out.impulses[f].normal_Ns;
  };
  EXPECT_LE(ratio(2), 0.05 + 1e-9);
  double max_other = std::max({ratio(0), ratio(1), ratio(3)});
  std::printf("|c_T|/c_N: lf %.3f rf %.3f lh %.3f (mu 0.05) rh %.3f\n", ratio(0), ratio(1),
              ratio(2), ratio(3));
  EXPECT_GT(max_other, 0.05);
}

TEST_F(TwoStage, StageTwoRemovesChatterThroughContactChanges) {
  // Default settings (q̈_des made velocity-level consistent, eq 9 held): what Stage II removes
  // is the redistribution at contact changes. Without the projection, Stage I's feet micro-slide
  // by h J̇_c v and its torque chatters far more; a Stage II free to leave Stage I's optimum then
  // halves that (the paper's Fig. 1), while with eq 9 it would be pinned to Stage I's torque.
  const auto [tv1, tv2, jump1, jump2] = SwayChatter({});
  std::printf("chatter (total variation of tau, N m): Stage I %.1f, Stage I+II %.1f; "
              "largest jump %.1f vs %.1f\n", tv1, tv2, jump1, jump2);
  EXPECT_LT(tv2, 0.9 * tv1);
  EXPECT_LT(jump2, 0.85 * jump1);
  TwoStageSettings raw;
  raw.velocity_consistent_qdd = false;
  raw.optimal_set_tolerance = 1.0;
  const auto [rtv1, rtv2, rjump1, rjump2] = SwayChatter(raw);
  std::printf("without the velocity-level projection: Stage I %.1f, Stage I+II %.1f; "
              "largest jump %.1f vs %.1f\n", rtv1, rtv2, rjump1, rjump2);
  EXPECT_LT(rtv2, 0.5 * rtv1);
}

TEST_F(TwoStage, MeasuredContactVelocityIsTreatedAsAnImpact) {
  // the robot standing, its base sinking at 1 cm/s into a compliant ground
  IdInput in = testing::StandingInput(&rng_, kAll);
  in.v.setZero();
  in.v(2) = -0.01;
  const auto d = Dyn(in);
  TwoStageSettings off;
  off.project_contact_velocity = false;
  IdOutput a, b;  // projected, raw
  ASSERT_NO_FATAL_FAILURE(SolveWithBoth({}, off, *d, in, &a, &b));
  double na = 0, nb = 0;
  for (int f = 0; f < 4; ++f) {
    na += a.impulses[f].normal_Ns;
    nb += b.impulses[f].normal_Ns;
  }
  const double weight_impulse = HyqModel().TotalMass() * 9.81 * in.dt;
  std::printf("normal impulse with projection %.3f N s, without %.3f N s (weight x h = %.3f)\n",
              na, nb, weight_impulse);
  EXPECT_NEAR(na, weight_impulse, 0.05 * weight_impulse);  // holds the weight, nothing more
  EXPECT_GT(nb, 1.5 * weight_impulse);                      // stops the sinking within h
  // the projected answer is the answer for the contact-consistent velocity
  ContactSet set;
  ASSERT_EQ(BuildContactSet(HyqModel(), d->feet, in, 4, &set), ContactStatus::kOk);
  for (int i = 0; i < set.count; ++i) EXPECT_LT((set.J_c[i] * a.v_star).norm(), 1e-9);
}

TEST_F(TwoStage, ZeroStanceIsContactFreeId) {
  IdInput in = Consistent({false, false, false, false});
  const auto d = Dyn(in);
  TwoStageId id;
  IdOutput out;
  ASSERT_EQ(id.Solve(HyqModel(), *d, in, &out), IdStatus::kOk) << Describe(out);
  EXPECT_FALSE(out.stage1.ran);
  EXPECT_EQ(id.counters().no_contact, 1u);
  // M v̇ + h = [0; τ] with v̇ = (v* − v)/h
  const VectorV vdot = (out.v_star - in.v) / in.dt;
  VectorV lhs = d->M * vdot + d->bias;
  EXPECT_LT(lhs.head<6>().norm(), 1e-9 * d->bias.norm());  // the free base receives nothing
  EXPECT_TRUE(NearRel(VectorJ(lhs.tail<12>()), out.tau_Nm, 1e-9));
}

// Hard random ID problems: 1–4 stance feet, μ from 0 (frictionless) to 10, feet on
// slopes (normals tilted up to 30°), h from 0.5 to 4 ms, base twists up to 0.5 m/s and 1 rad/s,
// base accelerations up to 5 m/s² and 5 rad/s², references consistent at the velocity or the
// acceleration level plus up to ±10 rad/s² of feedback on every joint. Each is solved cold and,
// in runs of 20 with the same stance and small changes, warm. Every answer is finite; a
// fallback would be counted and its torque within the effort limits; the servo needs none, and
// none there are (docs/inverse_dynamics.md, "Fallbacks").
TEST_F(TwoStage, HardRandomProblemsSolveWithoutFallback) {
  // HYQ_ID_GENERATOR_SEED: another draw of the same generator (the test asserts on the default)
  const char* seed = std::getenv("HYQ_ID_GENERATOR_SEED");
  std::mt19937_64 rng(seed ? std::strtoull(seed, nullptr, 10) : 1616);
  std::uniform_real_distribution<double> u(-1.0, 1.0), unit(0.0, 1.0);
  TwoStageId warm;
  TwoStageId cold;
  int problems = 0, frictionless = 0, fallbacks = 0, most_iterations = 0;
  double slowest_qp_s = 0.0;
  std::array<int, 5> by_feet{};
  for (int run = 0; run < 150; ++run) {
    std::array<bool, 4> stance{};
    const int mask = 1 + static_cast<int>(unit(rng) * 15.0) % 15;
    for (int f = 0; f < 4; ++f) stance[f] = (mask >> f) & 1;
    IdInput base = testing::StandingInput(&rng, stance, 0.3);
    base.dt = 0.5e-3 + 3.5e-3 * unit(rng);
    for (int f = 0; f < 4; ++f) {
      const double m = unit(rng);
      base.mu[f] = m < 0.15 ? 0.0 : std::pow(10.0, -2.0 + 3.0 * unit(rng));
      frictionless += stance[f] && base.mu[f] == 0.0;
      const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), 0.0).normalized();
      base.normal_W[f] = Eigen::AngleAxisd(0.5236 * unit(rng), axis) * Eigen::Vector3d::UnitZ();
    }
    dynamics::Vector6d vb, ab;
    for (int i = 0; i < 3; ++i) vb(i) = 0.5 * u(rng), vb(3 + i) = 1.0 * u(rng);
    for (int i = 0; i < 6; ++i) ab(i) = 5.0 * u(rng);
    const bool velocity_level = unit(rng) < 0.5;
    warm.Reset();
    for (int k = 0; k < 20; ++k, ++problems) {
      IdInput in = base;
      in.q(0) += 1e-4 * k;  // a small drift between consecutive cycles
      testing::MakeContactConsistent(&in, vb * (1.0 + 0.01 * k), ab, &rng, velocity_level);
      for (int j = 0; j < 12; ++j) in.qdd_des(j) += 10.0 * u(rng);
      ++by_feet[static_cast<std::size_t>(std::count(stance.begin(), stance.end(), true))];
      const auto d = Dyn(in);
      IdOutput o_warm, o_cold;
      cold.Reset();
      const IdStatus sw = warm.Solve(HyqModel(), *d, in, &o_warm);
      const IdStatus sc = cold.Solve(HyqModel(), *d, in, &o_cold);
      for (const auto& [st, o] : {std::pair{sw, &o_warm}, std::pair{sc, &o_cold}}) {
        ASSERT_NE(st, IdStatus::kBadInput) << "run " << run << " cycle " << k;
        ASSERT_TRUE(o->tau_Nm.allFinite()) << "run " << run << " cycle " << k << ": " << Describe(*o);
        fallbacks += st == IdStatus::kFallback;
        for (const StageReport* r : {&o->stage1, &o->stage2}) {
          most_iterations = std::max(most_iterations, r->iterations);
          slowest_qp_s = std::max(slowest_qp_s, r->solve_time_s);
        }
        if (st != IdStatus::kFallback) continue;
        for (int j = 0; j < 12; ++j)
          EXPECT_LE(std::abs(o->tau_Nm(j)), HyqModel().limits[j].effort_Nm) << Describe(*o);
      }
    }
  }
  const FallbackCounters& w = warm.counters();
  const FallbackCounters& c = cold.counters();
  std::printf("%d problems (1/2/3/4 feet: %d/%d/%d/%d, %d frictionless stance feet): warm Stage I "
              "%llu, Stage II %llu fallbacks; cold Stage I %llu, Stage II %llu\n",
              problems, by_feet[1], by_feet[2], by_feet[3], by_feet[4], frictionless,
              static_cast<unsigned long long>(w.stage1_failed),
              static_cast<unsigned long long>(w.stage2_failed),
              static_cast<unsigned long long>(c.stage1_failed),
              static_cast<unsigned long long>(c.stage2_failed));
  std::printf("the longest QP (all its attempts): %d iterations; the slowest: %.0f us\n",
              most_iterations, 1e6 * slowest_qp_s);
  EXPECT_EQ(static_cast<std::uint64_t>(fallbacks),
            w.stage1_failed + w.stage2_failed + c.stage1_failed + c.stage2_failed);
  EXPECT_EQ(fallbacks, 0);
  EXPECT_EQ(w.calls + c.calls, 2u * static_cast<std::uint64_t>(problems));
}

TEST_F(TwoStage, FallbackChainIsCountedNeverThrown) {
  const IdInput in = Consistent(kAll);
  const auto d = Dyn(in);
  {  // Stage II cannot finish → Stage I's torque
    TwoStageId id(StageTwoCannotFinish()), stage1(StageOneOnly());
    IdOutput out, out1;
    EXPECT_EQ(id.Solve(HyqModel(), *d, in, &out), IdStatus::kFallback);
    EXPECT_EQ(out.fallback, Fallback::kStage1Torque);
    EXPECT_EQ(id.counters().stage2_failed, 1u);
    ASSERT_EQ(stage1.Solve(HyqModel(), *d, in, &out1), IdStatus::kOk) << Describe(out1);
    EXPECT_TRUE(NearRel(out.tau_Nm, out1.tau_Nm, 1e-12));
  }
  {  // Stage I cannot finish → contact-free ID
    TwoStageId id(StageOneCannotFinish());
    IdOutput out;
    EXPECT_EQ(id.Solve(HyqModel(), *d, in, &out), IdStatus::kFallback);
    EXPECT_EQ(out.fallback, Fallback::kContactFreeId);
    EXPECT_EQ(id.counters().stage1_failed, 1u);
    EXPECT_TRUE(NearRel(out.tau_Nm, ContactFreeId(*d, in.qdd_des), 1e-12));
  }
  {  // nothing usable → the caller's safety controller
    IdInput bad = in;
    bad.qdd_des(3) = std::nan("");
    TwoStageId id;
    IdOutput out;
    EXPECT_EQ(id.Solve(HyqModel(), *d, bad, &out), IdStatus::kBadInput);
    EXPECT_EQ(out.fallback, Fallback::kSafety);
    EXPECT_EQ(id.counters().bad_input, 1u);
    EXPECT_EQ(out.tau_Nm, VectorJ::Zero());
    bad = in;
    bad.normal_W[0].setZero();
    EXPECT_EQ(id.Solve(HyqModel(), *d, bad, &out), IdStatus::kBadInput);
    bad = in;
    bad.mu[1] = -0.5;
    EXPECT_EQ(id.Solve(HyqModel(), *d, bad, &out), IdStatus::kBadInput);
  }
}

TEST_F(TwoStage, FallbackTorqueIsClampedToTheEffortLimits) {
  // a q̈_des no actuator can follow (up to ±2000 rad/s²): both fallbacks' torques would be many
  // times the model's effort limits; what is sent is clamped per joint, and counted
  IdInput in = Consistent(kAll);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int j = 0; j < 12; ++j) in.qdd_des(j) = 2000.0 * u(rng_);
  const auto d = Dyn(in);
  VectorJ limit;
  for (int j = 0; j < 12; ++j) limit(j) = HyqModel().limits[j].effort_Nm;
  const auto clamp = [&](const VectorJ& tau) { return VectorJ(tau.cwiseMax(-limit).cwiseMin(limit)); };
  const auto ratio = [&](const VectorJ& tau) { return tau.cwiseAbs().cwiseQuotient(limit).maxCoeff(); };
  {  // Stage I cannot finish → contact-free ID, clamped
    TwoStageId id(StageOneCannotFinish());
    IdOutput out;
    EXPECT_EQ(id.Solve(HyqModel(), *d, in, &out), IdStatus::kFallback);
    EXPECT_EQ(out.fallback, Fallback::kContactFreeId);
    const VectorJ f_id = ContactFreeId(*d, in.qdd_des);
    ASSERT_GT(ratio(f_id), 2.0);
    EXPECT_EQ(out.tau_Nm, clamp(f_id));
    EXPECT_LE(ratio(out.tau_Nm), 1.0);
    EXPECT_EQ(id.counters().stage1_failed, 1u);
    EXPECT_EQ(id.counters().clamped, 1u);
    std::printf("contact-free fallback: %.1f x the effort limit before the clamp\n", ratio(f_id));
  }
  {  // Stage II cannot finish → Stage I's torque, clamped
    TwoStageId id(StageTwoCannotFinish()), stage1(StageOneOnly());
    IdOutput out, out1;
    EXPECT_EQ(id.Solve(HyqModel(), *d, in, &out), IdStatus::kFallback);
    EXPECT_EQ(out.fallback, Fallback::kStage1Torque);
    ASSERT_EQ(stage1.Solve(HyqModel(), *d, in, &out1), IdStatus::kOk) << Describe(out1);
    ASSERT_GT(ratio(out1.tau_Nm), 2.0);
    EXPECT_TRUE(NearRel(out.tau_Nm, clamp(out1.tau_Nm), 1e-12));
    EXPECT_LE(ratio(out.tau_Nm), 1.0);
    EXPECT_EQ(id.counters().stage2_failed, 1u);
    EXPECT_EQ(id.counters().clamped, 1u);
    EXPECT_EQ(stage1.counters().clamped, 0u);  // the method's own answer is not a fallback
    std::printf("Stage I torque fallback: %.1f x the effort limit before the clamp\n",
                ratio(out1.tau_Nm));
  }
  {  // a fallback within the limits is left as it is and not counted as clamped
    const IdInput ok = Consistent(kAll);
    const auto dok = Dyn(ok);
    TwoStageId id(StageTwoCannotFinish()), stage1(StageOneOnly());
    IdOutput out, out1;
    EXPECT_EQ(id.Solve(HyqModel(), *dok, ok, &out), IdStatus::kFallback);
    ASSERT_EQ(stage1.Solve(HyqModel(), *dok, ok, &out1), IdStatus::kOk) << Describe(out1);
    ASSERT_LT(ratio(out1.tau_Nm), 1.0);
    EXPECT_TRUE(NearRel(out.tau_Nm, out1.tau_Nm, 1e-12));
    EXPECT_EQ(id.counters().stage2_failed, 1u);
    EXPECT_EQ(id.counters().clamped, 0u);
  }
}

TEST_F(TwoStage, NoSlipIdSatisfiesItsEquations) {
  // M v̇ + h = Sᵀτ + J_cᵀ λ (λ = impulse / h) and J_c v̇ + J̇_c v = 0. With two feet the base
  // rotation about the support line is unconstrained and Mistry's min-norm v̇ need not be
  // dynamically feasible: there only the joint rows and the contact rows are exact.
  for (const auto& stance : {kAll, std::array<bool, 4>{true, true, false, true}, kLfRh}) {
    for (int trial = 0; trial < 10; ++trial) {
      const IdInput in = Consistent(stance);
      const auto d = Dyn(in);
      NoSlipId id;
      IdOutput out;
      ASSERT_EQ(id.Solve(HyqModel(), *d, in, &out), IdStatus::kOk) << Describe(out);
      const VectorV vdot = (out.v_star - in.v) / in.dt;
      VectorV rhs = GeneralizedImpulse(*d, in, out) / in.dt;
      rhs.tail<12>() += out.tau_Nm;
      const VectorV lhs = d->M * vdot + d->bias;
      EXPECT_TRUE(NearRel(VectorJ(lhs.tail<12>()), VectorJ(rhs.tail<12>()), 1e-8));
      if (stance != kLfRh) {
        EXPECT_TRUE(NearRel(lhs, rhs, 1e-8));
      }
      ContactSet set;
      ASSERT_EQ(BuildContactSet(HyqModel(), d->feet, in, 4, &set), ContactStatus::kOk);
      for (int i = 0; i < set.count; ++i)
        EXPECT_LT((set.J_c[i] * vdot + set.Jdot_c_v[i]).norm(), 1e-8);
    }
  }
}

TEST_F(TwoStage, NoHeapInAnyControllerAfterWarmup) {
  HYQ_REQUIRE_HEAP_HOOKS();
  ControllerConfig cfg;
  cfg.feedback.kp_acc.setConstant(100.0);
  cfg.feedback.kd_acc.setConstant(20.0);
  cfg.pid.kp.setConstant(300.0);
  cfg.pid.kd.setConstant(10.0);
  Controller ctl(HyqModel(), cfg);
  JointReference ref;
  ref.q = HyqModel().q_standing;
  ContactEnvironment env;
  env.mu = {0.6, 0.0, 1.0, 0.05};  // one frictionless foot exercises that path too
  const IdInput a = Consistent(kAll), b = Consistent(kLfRh);
  const auto da = Dyn(a), db = Dyn(b);
  IdOutput out;
  cfg.pd_gravity.kp.setConstant(300.0);
  for (auto kind : {ControllerKind::kTwoStageId, ControllerKind::kStage1Id,
                    ControllerKind::kNoSlipId, ControllerKind::kPid, ControllerKind::kPdGravity}) {
    ctl.SetKind(kind);
    ref.stance = kAll;
    (void)ctl.Compute(*da, a.q, a.v, ref, env, 1e-3, &out);  // warm-up
    ref.stance = kLfRh;
    (void)ctl.Compute(*db, b.q, b.v, ref, env, 1e-3, &out);
    testing::NoHeapGuard guard;
    for (int k = 0; k < 5; ++k) {
      ref.stance = kAll;
      (void)ctl.Compute(*da, a.q, a.v, ref, env, 1e-3, &out);
      ref.stance = kLfRh;
      (void)ctl.Compute(*db, b.q, b.v, ref, env, 1e-3, &out);
      ref.stance = {false, false, false, false};
      (void)ctl.Compute(*db, b.q, b.v, ref, env, 1e-3, &out);
    }
    EXPECT_EQ(guard.allocations(), 0u) << ToString(kind);
  }
}

TEST(Pid, AntiWindupAndLimits) {
  PidGains g;
  g.kp.setConstant(100.0);
  g.ki.setConstant(1000.0);
  g.kd.setConstant(1.0);
  g.i_limit.setConstant(20.0);
  VectorJ limit = VectorJ::Constant(150.0);
  PidController pid(g, limit);
  VectorJ q = VectorJ::Zero(), qd = VectorJ::Zero(), ref = VectorJ::Constant(0.1);
  VectorJ tau;
  for (int k = 0; k < 1000; ++k) tau = pid.Compute(q, qd, ref, qd, 1e-3);
  EXPECT_NEAR(tau(0), 100.0 * 0.1 + 20.0, 1e-9);  // integral clamped at i_limit
  ref.setConstant(10.0);                            // a huge error saturates the output
  tau = pid.Compute(q, qd, ref, qd, 1e-3);
  EXPECT_DOUBLE_EQ(tau(0), 150.0);
  pid.Reset();
  g.i_limit.setConstant(1000.0);
  pid.set_gains(g);
  for (int k = 0; k < 1000; ++k) tau = pid.Compute(q, qd, ref, qd, 1e-3);
  EXPECT_DOUBLE_EQ(pid.integral()(0), 0.0);  // saturated along e: no integration
}

// the ID kinds' integral torque: Ki_τ e dt per cycle, clamped at ±i_limit_τ, added
// on top of ID + PD; cleared by Reset and by a change of controller
TEST_F(TwoStage, IdIntegralGrowsToItsLimitAndResets) {
  ControllerConfig cfg;
  cfg.kind = ControllerKind::kNoSlipId;
  cfg.feedback.ki_tau.setConstant(1000.0);
  cfg.feedback.i_limit_tau.setConstant(20.0);
  Controller ctl(HyqModel(), cfg);
  const IdInput a = Consistent(kAll);
  const auto da = Dyn(a);
  JointReference ref;
  ref.q = a.q.tail<kNumJoints>() + VectorJ::Constant(0.01);
  ref.qd = a.v.tail<kNumJoints>();
  ContactEnvironment env;
  IdOutput out;
  (void)ctl.Compute(*da, a.q, a.v, ref, env, 1e-3, &out);
  EXPECT_NEAR(ctl.id_integral()(0), 1000.0 * 0.01 * 1e-3, 1e-12);  // one step of Ki e dt
  IdOutput no_i;
  ControllerConfig plain = cfg;
  plain.feedback.ki_tau.setZero();
  Controller ref_ctl(HyqModel(), plain);
  for (int k = 0; k < 3000; ++k) (void)ctl.Compute(*da, a.q, a.v, ref, env, 1e-3, &out);
  (void)ref_ctl.Compute(*da, a.q, a.v, ref, env, 1e-3, &no_i);
  EXPECT_DOUBLE_EQ(ctl.id_integral().maxCoeff(), 20.0);  // 3 s × 10 N·m/s, clamped at 20
  EXPECT_TRUE((out.tau_Nm - no_i.tau_Nm).isApprox(VectorJ::Constant(20.0), 1e-6));
  ctl.Reset();
  EXPECT_DOUBLE_EQ(ctl.id_integral().norm(), 0.0);
  (void)ctl.Compute(*da, a.q, a.v, ref, env, 1e-3, &out);
  ctl.SetKind(ControllerKind::kTwoStageId);
  EXPECT_DOUBLE_EQ(ctl.id_integral().norm(), 0.0);
}

// ControllerConfig's swing scales (the IDs', the PID's, PD + g's): each controller's kp/kd
// feedback on the joints of a swing leg is scaled by its own, stance legs' untouched, the
// feed-forward and the integral not at all: the difference between a scaled and an unscaled
// controller is exactly (1 − s) × that leg's PD; the other controllers' scales change nothing
TEST_F(TwoStage, SwingGainScaleScalesOnlyTheSwingLegsFeedback) {
  const IdInput a = Consistent(kLfRh);  // LF and RH in stance, RF and LH in swing
  const auto da = Dyn(a);
  JointReference ref;
  ref.q = a.q.tail<kNumJoints>() + VectorJ::LinSpaced(-0.02, 0.03);
  ref.qd = a.v.tail<kNumJoints>() + VectorJ::Constant(0.1);
  ref.stance = kLfRh;
  ContactEnvironment env;
  const double s = 0.3;
  for (ControllerKind kind : {ControllerKind::kPid, ControllerKind::kPdGravity,
                              ControllerKind::kNoSlipId, ControllerKind::kTwoStageId}) {
    ControllerConfig cfg;
    cfg.kind = kind;
    cfg.pid.kp.setConstant(400.0);
    cfg.pid.kd.setConstant(20.0);
    cfg.pd_gravity.kp.setConstant(400.0);
    cfg.pd_gravity.kd.setConstant(20.0);
    cfg.feedback.kp_tau.setConstant(400.0);
    cfg.feedback.kd_tau.setConstant(20.0);
    ControllerConfig scaled = cfg;
    // each controller takes its own scale, and only its own
    (kind == ControllerKind::kPid         ? scaled.pid_swing_gain_scale
     : kind == ControllerKind::kPdGravity ? scaled.pdg_swing_gain_scale
                                          : scaled.swing_gain_scale) = s;
    ControllerConfig others = cfg;  // every other controller's scale set: no effect on this one
    others.swing_gain_scale = others.pid_swing_gain_scale = others.pdg_swing_gain_scale = 0.5;
    (kind == ControllerKind::kPid         ? others.pid_swing_gain_scale
     : kind == ControllerKind::kPdGravity ? others.pdg_swing_gain_scale
                                          : others.swing_gain_scale) = 1.0;
    Controller full_ctl(HyqModel(), cfg), scaled_ctl(HyqModel(), scaled), others_ctl(HyqModel(), others);
    IdOutput full, part, other;
    (void)full_ctl.Compute(*da, a.q, a.v, ref, env, 1e-3, &full);
    (void)scaled_ctl.Compute(*da, a.q, a.v, ref, env, 1e-3, &part);
    (void)others_ctl.Compute(*da, a.q, a.v, ref, env, 1e-3, &other);
    EXPECT_LT((other.tau_Nm - full.tau_Nm).norm(), 1e-9) << ToString(kind) << ": another controller's scale applied";
    const VectorJ pd = 400.0 * (ref.q - a.q.tail<kNumJoints>()) + 20.0 * (ref.qd - a.v.tail<kNumJoints>());
    for (int j = 0; j < kNumJoints; ++j) {
      const bool swing = !kLfRh[static_cast<std::size_t>(j / 3)];
      EXPECT_NEAR(full.tau_Nm(j) - part.tau_Nm(j), swing ? (1.0 - s) * pd(j) : 0.0, 1e-6)
          << ToString(kind) << " joint " << j;
    }
  }
}

// PD + gravity compensation's feed-forward is a static equilibrium: with the joint torques τ_g
// there are stance-foot forces f that balance h exactly in all 18 rows (h = Sᵀτ_g + J_cᵀ f),
// solved here independently by least squares over the whole system
TEST(PdGravity, FeedForwardIsAStaticEquilibriumOnTheStanceFeet) {
  std::mt19937_64 rng(7);
  for (const auto& stance : {kAll, kLfRh, std::array<bool, 4>{true, true, true, false}}) {
    const IdInput in = testing::StandingInput(&rng, stance, 0.05);
    const auto dyn = Dyn(in);
    PdGravityController pdg(PdGains{}, VectorJ::Constant(1e6));
    const VectorJ tau = pdg.Compute(*dyn, in.q.tail<kNumJoints>(), in.v.tail<kNumJoints>(),
                                    in.q.tail<kNumJoints>(), in.v.tail<kNumJoints>(), stance);
    EXPECT_TRUE(tau.isApprox(pdg.gravity_torque()));  // no error: the feed-forward alone
    const int n = 3 * static_cast<int>(std::count(stance.begin(), stance.end(), true));
    Eigen::MatrixXd Jt(dynamics::kNv, n);
    int c = 0;
    for (int f = 0; f < 4; ++f)
      if (stance[static_cast<std::size_t>(f)]) Jt.middleCols<3>(3 * c++) = dyn->feet.J_WF[static_cast<std::size_t>(f)].transpose();
    VectorV rhs = dyn->bias;
    rhs.tail<kNumJoints>() -= tau;
    const Eigen::VectorXd f = Jt.colPivHouseholderQr().solve(rhs);
    const double residual = (Jt * f - rhs).norm();
    // two feet cannot hold a moment about the line between them: the least-norm split leaves
    // that part unbalanced (the damping's share is ~1e-6 of h otherwise)
    const double tol = n == 6 ? 0.05 * rhs.head<6>().norm() : 1e-4 * rhs.norm();
    EXPECT_LT(residual, tol) << "stance feet " << n / 3;
    // the feet carry the robot: the vertical forces add up to the weight's share in h_b
    double fz = 0.0;
    for (int k = 0; k < n / 3; ++k) fz += f(3 * k + 2);
    EXPECT_NEAR(fz, dyn->bias(2), 0.05 * std::abs(dyn->bias(2)));
  }
}

TEST(PdGravity, NoStanceIsTheLegsOwnWeightAndTheOutputIsClamped) {
  std::mt19937_64 rng(8);
  const IdInput in = testing::StandingInput(&rng, kAll, 0.05);
  const auto dyn = Dyn(in);
  PdGains g;
  g.kp.setConstant(100.0);
  g.kd.setConstant(2.0);
  PdGravityController pdg(g, VectorJ::Constant(150.0));
  const VectorJ q = in.q.tail<kNumJoints>(), qd = in.v.tail<kNumJoints>();
  VectorJ tau = pdg.Compute(*dyn, q, qd, q, qd, {false, false, false, false});
  EXPECT_TRUE(pdg.gravity_torque().isApprox(dyn->bias.tail<kNumJoints>()));
  const VectorJ dq = VectorJ::Constant(0.01);
  tau = pdg.Compute(*dyn, q, qd, q + dq, qd, {false, false, false, false});
  EXPECT_TRUE(tau.isApprox(dyn->bias.tail<kNumJoints>() + 100.0 * dq, 1e-12));
  tau = pdg.Compute(*dyn, q, qd, q + VectorJ::Constant(10.0), qd, kAll);
  EXPECT_DOUBLE_EQ(tau.maxCoeff(), 150.0);
  EXPECT_EQ(ParseControllerKind("pd_gravity"), ControllerKind::kPdGravity);
  EXPECT_STREQ(ToString(ControllerKind::kPdGravity), "pd_gravity");
}

}  // namespace
}  // namespace hyq::servo
