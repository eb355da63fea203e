// References: q̇_ref and q̈_ref are the derivatives of q_ref (central differences), stance feet
// do not move in the world (forward kinematics of the full model with the reference base pose),
// the trot's schedule, and the IK itself against the model.
#include <cmath>

#include <gtest/gtest.h>

#include "dynamics/cycle_dynamics.h"
#include "servo/reference/reference.h"
#include "tests/dynamics/hyq_fixture.h"

namespace hyq::servo {
namespace {

using testing::HyqModel;

void CheckDerivatives(Reference ref, double t_end, const char* name) {
  constexpr double h = 1e-5;
  double worst_qd = 0, worst_qdd = 0;
  ReferenceSample a, b, c;
  Reference r0 = ref, r1 = ref, r2 = ref;
  for (double t = 0.01; t < t_end; t += 0.0137) {
    r0.Sample(t - h, &a);
    r1.Sample(t, &b);
    r2.Sample(t + h, &c);
    ASSERT_EQ(b.ik, dynamics::IkStatus::kOk) << name << " at t = " << t;
    const VectorJ qd_fd = (c.joints.q - a.joints.q) / (2 * h);
    const VectorJ qdd_fd = (c.joints.qd - a.joints.qd) / (2 * h);
    worst_qd = std::max(worst_qd, (qd_fd - b.joints.qd).cwiseAbs().maxCoeff());
    worst_qdd = std::max(worst_qdd, (qdd_fd - b.joints.qdd).cwiseAbs().maxCoeff());
  }
  std::printf("%s: max |q̇ − FD| %.2e rad/s, max |q̈ − FD| %.2e rad/s²\n", name, worst_qd, worst_qdd);
  EXPECT_LT(worst_qd, 1e-5);
  EXPECT_LT(worst_qdd, 1e-3);
}

TEST(Reference, JointDerivativesAreConsistent) {
  CheckDerivatives(Reference::Stand(HyqModel()), 1.0, "stand");
  CheckDerivatives(Reference::Trot(HyqModel(), TrotParams{}), 4.0, "trot");
  CheckDerivatives(Reference::FigureEight(HyqModel(), FigureEightParams{}), 4.5, "figure_eight");
}

TEST(Reference, StanceFeetStayPutAndMatchTheModel) {
  for (auto ref : {Reference::Trot(HyqModel(), TrotParams{}),
                   Reference::FigureEight(HyqModel(), FigureEightParams{})}) {
    std::array<Eigen::Vector3d, 4> planted;
    std::array<bool, 4> was_stance{};
    ReferenceSample s;
    auto dyn = std::make_unique<dynamics::CycleDynamics>();
    double worst_fk = 0, worst_slide = 0;
    for (int k = 0; k < 4000; ++k) {
      ref.Sample(k * 1e-3, &s);
      ASSERT_EQ(s.ik, dynamics::IkStatus::kOk) << k;
      VectorQ q = VectorQ::Zero();
      q.head<3>() = s.base.p_W;
      q(3) = 1.0;
      q.tail<12>() = s.joints.q;
      ASSERT_EQ(dynamics::ComputeCycleDynamics(HyqModel(), q, VectorV::Zero(), dyn.get()),
                dynamics::DynamicsStatus::kOk);
      for (int f = 0; f < 4; ++f) {
        worst_fk = std::max(worst_fk, (dyn->feet.p_WF_W[f] - s.feet[f].p_W).norm());
        if (s.joints.stance[f]) {
          if (!was_stance[f]) planted[f] = s.feet[f].p_W;
          worst_slide = std::max(worst_slide, (s.feet[f].p_W - planted[f]).norm());
          EXPECT_NEAR(s.feet[f].p_W.z(), HyqModel().feet[f].radius_m, 1e-12);
        }
        was_stance[f] = s.joints.stance[f];
      }
    }
    EXPECT_LT(worst_fk, 1e-9);     // the IK reproduces the feet through the full model
    EXPECT_LT(worst_slide, 1e-12); // planted feet do not move
  }
}

TEST(Reference, TrotScheduleUsesDiagonalPairsAndTheDutyFactor) {
  TrotParams p;
  p.duty_factor = 0.6;
  Reference ref = Reference::Trot(HyqModel(), p);
  ReferenceSample s;
  int stance_steps = 0, steps = 0, four = 0;
  for (double t = p.start_delay_s + 2.0; t < p.start_delay_s + 2.0 + 10 / p.step_frequency_Hz;
       t += 1e-3) {
    ref.Sample(t, &s);
    const auto& st = s.joints.stance;
    EXPECT_EQ(st[0], st[3]);  // lf with rh
    EXPECT_EQ(st[1], st[2]);  // rf with lh
    stance_steps += st[0];
    four += st[0] && st[1];
    ++steps;
  }
  EXPECT_NEAR(static_cast<double>(stance_steps) / steps, p.duty_factor, 0.01);
  EXPECT_NEAR(static_cast<double>(four) / steps, 2 * p.duty_factor - 1, 0.01);  // double support
  // cruising speed = stride × frequency
  ref.Sample(p.start_delay_s + 5.0, &s);
  EXPECT_NEAR(s.base.v_W.x(), p.stride_m * p.step_frequency_Hz, 1e-12);
}

TEST(Reference, FigureEightKeepsAllFeetDown) {
  Reference ref = Reference::FigureEight(HyqModel(), FigureEightParams{});
  ReferenceSample s;
  double max_x = 0, max_y = 0;
  for (double t = 0; t < 5.0; t += 1e-3) {
    ref.Sample(t, &s);
    for (bool st : s.joints.stance) EXPECT_TRUE(st);
    max_x = std::max(max_x, std::abs(s.base.p_W.x()));
    max_y = std::max(max_y, std::abs(s.base.p_W.y()));
  }
  EXPECT_NEAR(max_x, 0.06, 0.005);
  EXPECT_NEAR(max_y, 0.04, 0.005);
}

}  // namespace
}  // namespace hyq::servo
