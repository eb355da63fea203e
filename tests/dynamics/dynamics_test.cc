// Internal consistency of the dynamics: M symmetric positive definite, CRBA vs RNEA, Jacobians
// and J̇v vs finite differences on the manifold, kinetic energy vs the sum over bodies from
// finite-differenced poses, the factorisation vs a dense inverse, and no heap in the cycle.
#include <memory>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "dynamics/configuration.h"
#include "dynamics/cycle_dynamics.h"
#include "tests/dynamics/hyq_fixture.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::dynamics {
namespace {

using testing::HyqModel;
using testing::NearRel;

constexpr int kStates = 100;

class Dynamics : public ::testing::Test {
 protected:
  std::unique_ptr<CycleDynamics> Compute(const VectorQ& q, const VectorV& v) {
    auto d = std::make_unique<CycleDynamics>();
    EXPECT_EQ(ComputeCycleDynamics(HyqModel(), q, v, d.get()), DynamicsStatus::kOk);
    return d;
  }
  std::mt19937_64 rng_{7};
};

TEST_F(Dynamics, ModelFacts) {
  const Model& m = HyqModel();
  EXPECT_NEAR(m.TotalMass(), 86.774, 1e-9);
  for (int f = 0; f < kNumFeet; ++f) EXPECT_DOUBLE_EQ(m.feet[f].radius_m, 0.02175);
  EXPECT_EQ(m.joint_names[JointIndex(static_cast<int>(Leg::kRH), 2)], "rh_kfe_joint");
  EXPECT_EQ(m.imu.name, "trunk_imu");
}

TEST_F(Dynamics, StandingPostureHasFeetOnTheGround) {
  const Model& m = HyqModel();
  const auto d = Compute(m.StandingQ(), VectorV::Zero());
  for (int f = 0; f < kNumFeet; ++f) {
    // the sphere touches z = 0 (SOURCE.md: 0.5993 m base height, rounded to 0.1 mm)
    EXPECT_NEAR(d->feet.p_WF_W[f].z(), m.feet[f].radius_m, 1e-4) << m.feet[f].name;
  }
  // feet under the hips, front feet ahead of the hind ones
  EXPECT_GT(d->feet.p_WF_W[0].x(), 0.2);
  EXPECT_LT(d->feet.p_WF_W[2].x(), -0.2);
  EXPECT_GT(d->feet.p_WF_W[0].y(), 0.0);
  EXPECT_LT(d->feet.p_WF_W[1].y(), 0.0);
}

TEST_F(Dynamics, MassMatrixSymmetricPositiveDefiniteAndLegsDecoupled) {
  for (int s = 0; s < kStates; ++s) {
    const auto st = testing::MakeRandomState(HyqModel(), &rng_);
    const auto d = Compute(st.q, st.v);
    EXPECT_TRUE(NearRel(d->M, MatrixV(d->M.transpose()), 1e-14));
    const Eigen::SelfAdjointEigenSolver<MatrixV> eig(d->M);
    EXPECT_GT(eig.eigenvalues().minCoeff(), 1e-4);
    for (int a = 0; a < kNumLegs; ++a) {
      for (int b = 0; b < kNumLegs; ++b) {
        if (a != b) {
          EXPECT_EQ((d->M.block<3, 3>(6 + 3 * a, 6 + 3 * b).cwiseAbs().maxCoeff()), 0.0);
        }
      }
    }
  }
}

TEST_F(Dynamics, CrbaMatchesRneaColumns) {
  // M e_i = ID(q, v, e_i) − ID(q, v, 0)
  RneaWorkspace ws;
  for (int s = 0; s < 20; ++s) {
    const auto st = testing::MakeRandomState(HyqModel(), &rng_);
    const auto d = Compute(st.q, st.v);
    for (int i = 0; i < kNv; ++i) {
      VectorV tau;
      InverseDynamics(HyqModel(), d->kin, VectorV::Unit(i), &ws, &tau);
      EXPECT_TRUE(NearRel(VectorV(tau - d->bias), VectorV(d->M.col(i)), 1e-12)) << "col " << i;
    }
  }
}

TEST_F(Dynamics, BiasIsGravityPlusVelocityTerms) {
  // h(q, 0) is gravity alone: the base force is the total weight
  const auto st = testing::MakeRandomState(HyqModel(), &rng_);
  const auto d = Compute(st.q, VectorV::Zero());
  EXPECT_NEAR(d->bias(2), HyqModel().TotalMass() * 9.81, 1e-9);
  EXPECT_NEAR(d->bias(0), 0.0, 1e-9);
}

TEST_F(Dynamics, JacobiansMatchFiniteDifferences) {
  constexpr double eps = 1e-6;
  for (int s = 0; s < 20; ++s) {
    const auto st = testing::MakeRandomState(HyqModel(), &rng_);
    const auto d = Compute(st.q, st.v);
    for (int i = 0; i < kNv; ++i) {
      const auto plus = Compute(Integrate(st.q, VectorV::Unit(i), eps), st.v);
      const auto minus = Compute(Integrate(st.q, VectorV::Unit(i), -eps), st.v);
      for (int f = 0; f < kNumFeet; ++f) {
        const Eigen::Vector3d fd = (plus->feet.p_WF_W[f] - minus->feet.p_WF_W[f]) / (2 * eps);
        EXPECT_TRUE(NearRel(Eigen::Vector3d(d->feet.J_WF[f].col(i)), fd, 1e-8))
            << "foot " << f << " dof " << i;
      }
    }
  }
}

TEST_F(Dynamics, JdotVMatchesFiniteDifferences) {
  // J̇v = d/dt (J(q(t)) v) along q(t) = q ⊕ v t
  constexpr double eps = 1e-6;
  for (int s = 0; s < 50; ++s) {
    const auto st = testing::MakeRandomState(HyqModel(), &rng_);
    const auto d = Compute(st.q, st.v);
    const auto plus = Compute(Integrate(st.q, st.v, eps), st.v);
    const auto minus = Compute(Integrate(st.q, st.v, -eps), st.v);
    for (int f = 0; f < kNumFeet; ++f) {
      const Eigen::Vector3d fd =
          (plus->feet.J_WF[f] * st.v - minus->feet.J_WF[f] * st.v) / (2 * eps);
      EXPECT_TRUE(NearRel(d->feet.Jdot_v_W[f], fd, 1e-6)) << "foot " << f;
    }
  }
}

TEST_F(Dynamics, ContactPointJacobianMatchesFiniteDifferences) {
  // the material point of the sphere that touches a surface of normal n: c = p − r n
  constexpr double eps = 1e-6;
  const Eigen::Vector3d n = Eigen::Vector3d(0.2, -0.1, 1.0).normalized();
  for (int s = 0; s < 20; ++s) {
    const auto st = testing::MakeRandomState(HyqModel(), &rng_);
    const auto d = Compute(st.q, st.v);
    for (int f = 0; f < kNumFeet; ++f) {
      FootJacobian Jc;
      Eigen::Vector3d Jcdot_v;
      ContactPointJacobian(HyqModel(), d->feet, f, n, &Jc, &Jcdot_v);
      const int b = HyqModel().feet[f].body;
      // the body-fixed point that coincides with c now, followed along the motion
      const Eigen::Vector3d c = d->feet.p_WF_W[f] - HyqModel().feet[f].radius_m * n;
      const Eigen::Vector3d c_B = d->kin.R_WB[b].transpose() * (c - d->kin.p_WB_W[b]);
      auto point = [&](const CycleDynamics& x) {
        return Eigen::Vector3d(x.kin.p_WB_W[b] + x.kin.R_WB[b] * c_B);
      };
      for (int i = 0; i < kNv; ++i) {
        const auto plus = Compute(Integrate(st.q, VectorV::Unit(i), eps), st.v);
        const auto minus = Compute(Integrate(st.q, VectorV::Unit(i), -eps), st.v);
        EXPECT_TRUE(NearRel(Eigen::Vector3d(Jc.col(i)),
                            Eigen::Vector3d((point(*plus) - point(*minus)) / (2 * eps)), 1e-8));
      }
      const auto plus = Compute(Integrate(st.q, st.v, eps), st.v);
      const auto minus = Compute(Integrate(st.q, st.v, -eps), st.v);
      FootJacobian Jp, Jm;
      Eigen::Vector3d unused;
      ContactPointJacobian(HyqModel(), plus->feet, f, n, &Jp, &unused);
      ContactPointJacobian(HyqModel(), minus->feet, f, n, &Jm, &unused);
      // J̇_c v for the contact point of the rolling sphere (n fixed): d/dt (J_c(q(t)) v)
      EXPECT_TRUE(NearRel(Jcdot_v, Eigen::Vector3d((Jp - Jm) * st.v / (2 * eps)), 1e-6));
    }
  }
}

TEST_F(Dynamics, KineticEnergyEqualsSumOverBodies) {
  // ½ vᵀ M v against Σ ½ m |ċ|² + ½ ωᵀ I_c ω with ċ and ω from finite-differenced poses
  constexpr double eps = 1e-6;
  for (int s = 0; s < kStates; ++s) {
    const auto st = testing::MakeRandomState(HyqModel(), &rng_);
    const auto d = Compute(st.q, st.v);
    const auto plus = Compute(Integrate(st.q, st.v, eps), st.v);
    const auto minus = Compute(Integrate(st.q, st.v, -eps), st.v);
    double T = 0.0;
    for (int b = 0; b < kNumBodies; ++b) {
      const RigidBodyInertia& in = HyqModel().bodies[b].inertia;
      auto com = [&](const CycleDynamics& x) {
        return Eigen::Vector3d(x.kin.p_WB_W[b] + x.kin.R_WB[b] * in.p_BoBcm_B);
      };
      const Eigen::Vector3d cdot = (com(*plus) - com(*minus)) / (2 * eps);
      const Eigen::Matrix3d Rdot = (plus->kin.R_WB[b] - minus->kin.R_WB[b]) / (2 * eps);
      const Eigen::Matrix3d W = Rdot * d->kin.R_WB[b].transpose();  // [ω]×
      const Eigen::Vector3d w(W(2, 1), W(0, 2), W(1, 0));
      const Eigen::Matrix3d I_W = d->kin.R_WB[b] * in.I_Bcm_B * d->kin.R_WB[b].transpose();
      T += 0.5 * in.mass * cdot.squaredNorm() + 0.5 * w.dot(I_W * w);
    }
    const double T_M = 0.5 * st.v.dot(d->M * st.v);
    EXPECT_NEAR(T_M, T, 1e-7 * std::max(1.0, T));
  }
}

TEST_F(Dynamics, FactorisationAndInverseBlocksMatchDenseInverse) {
  for (int s = 0; s < kStates; ++s) {
    const auto st = testing::MakeRandomState(HyqModel(), &rng_);
    const auto d = Compute(st.q, st.v);
    const MatrixV Minv = d->M.inverse();
    const double tol = 1e-9;
    MinvBlocks blocks;
    ComputeMinvBlocks(d->factor, &blocks);
    EXPECT_TRUE(NearRel(blocks.D, Matrix6d(Minv.topLeftCorner<6, 6>()), tol));
    EXPECT_TRUE(NearRel(blocks.E, BaseJointMatrix(Minv.topRightCorner<6, 12>()), tol));
    EXPECT_TRUE(NearRel(blocks.F, JointMatrix(Minv.bottomRightCorner<12, 12>()), tol));
    EXPECT_TRUE(NearRel(d->inv.A_inv, Matrix6d(d->M.topLeftCorner<6, 6>().inverse()), tol));
    const JointMatrix F_inv_dense = Minv.bottomRightCorner<12, 12>().inverse();
    EXPECT_TRUE(NearRel(d->inv.F_inv, F_inv_dense, tol));
    // E F⁻¹ = −A⁻¹ B, the identity Stage I relies on (Zapolsky et al. eqs 21–22)
    EXPECT_TRUE(NearRel(BaseJointMatrix(blocks.E * d->inv.F_inv),
                        BaseJointMatrix(-d->inv.A_inv_B), tol));
    // [D E] − E F⁻¹ [Eᵀ F] = [A⁻¹ 0]  (the Z of eq 21 is A⁻¹ R_b)
    EXPECT_TRUE(NearRel(Matrix6d(blocks.D - blocks.E * d->inv.F_inv * blocks.E.transpose()),
                        d->inv.A_inv, tol));
    VectorV b = VectorV::LinSpaced(-1.0, 2.0);
    const VectorV x_dense = d->M.llt().solve(b);
    SolveInPlace(d->factor, &b);
    EXPECT_TRUE(NearRel(b, x_dense, tol));
  }
}

TEST_F(Dynamics, FactorisationRejectsEveryIndefiniteBlock) {
  const auto st = testing::MakeRandomState(HyqModel(), &rng_);
  const MatrixV M = Compute(st.q, st.v)->M;
  MassMatrixFactor f;
  ASSERT_EQ(FactorMassMatrix(M, &f), FactorStatus::kOk);
  // a leg's joint block, the base block A and the Schur complement Ā = A − B C⁻¹ Bᵀ (A stays
  // positive definite, but the base couples more strongly to the leg than its inertia allows),
  // and a NaN, which no pivot test may pass
  MatrixV leg = M;
  leg(12, 12) = -1.0;
  EXPECT_EQ(FactorMassMatrix(leg, &f), FactorStatus::kNotPositiveDefinite);
  MatrixV base = M;
  base(2, 2) = -1.0;
  EXPECT_EQ(FactorMassMatrix(base, &f), FactorStatus::kNotPositiveDefinite);
  MatrixV schur = M;
  const double coupling = 2.0 * std::sqrt(M(0, 0) * M(6, 6));
  schur(0, 6) = schur(6, 0) = coupling;
  EXPECT_EQ(FactorMassMatrix(schur, &f), FactorStatus::kNotPositiveDefinite);
  MatrixV nan = M;
  nan(7, 7) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(FactorMassMatrix(nan, &f), FactorStatus::kNotPositiveDefinite);
}

TEST_F(Dynamics, IntegrateAndDifferenceAreInverse) {
  for (int s = 0; s < 20; ++s) {
    const auto st = testing::MakeRandomState(HyqModel(), &rng_);
    const VectorQ q1 = Integrate(st.q, st.v, 0.01);
    EXPECT_TRUE(NearRel(Difference(st.q, q1, 0.01), st.v, 1e-9));
  }
}

TEST_F(Dynamics, BadStateIsReportedNotComputed) {
  CycleDynamics d;
  VectorQ q = HyqModel().StandingQ();
  VectorV v = VectorV::Zero();
  v(7) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(ComputeCycleDynamics(HyqModel(), q, v, &d), DynamicsStatus::kBadInput);
  v(7) = 0.0;
  q.segment<4>(3).setZero();
  EXPECT_EQ(ComputeCycleDynamics(HyqModel(), q, v, &d), DynamicsStatus::kBadInput);
  q(3) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(ComputeCycleDynamics(HyqModel(), q, v, &d), DynamicsStatus::kBadInput);
}

TEST_F(Dynamics, NoHeapAfterWarmup) {
  HYQ_REQUIRE_HEAP_HOOKS();
  auto d = std::make_unique<CycleDynamics>();
  const auto st = testing::MakeRandomState(HyqModel(), &rng_);
  ASSERT_EQ(ComputeCycleDynamics(HyqModel(), st.q, st.v, d.get()), DynamicsStatus::kOk);
  RneaWorkspace ws;
  VectorV tau;
  {
    testing::NoHeapGuard guard;
    for (int i = 0; i < 10; ++i) {
      const auto s = ComputeCycleDynamics(HyqModel(), st.q, st.v, d.get());
      (void)s;
      InverseDynamics(HyqModel(), d->kin, st.v, &ws, &tau);
      VectorQ q = Integrate(st.q, st.v, 1e-3);
      (void)q;
    }
    EXPECT_EQ(guard.allocations(), 0u);
  }
}

}  // namespace
}  // namespace hyq::dynamics
