// Stand-up and sit-down (servo/reference/posture.h): q̇_ref and q̈_ref are the derivatives of
// q_ref (central differences), the feet on the ground stay put in the world (the legs' forward
// kinematics with the move's base position), a lifted foot comes down, the base ends at rest at
// the height asked, and the cycle allocates nothing.
#include "servo/reference/posture.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "servo/reference/reference.h"
#include "tests/dynamics/hyq_fixture.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::servo {
namespace {

using testing::HyqModel;

// the joint angles of the standing reference at base height h
VectorJ PostureAt(double h) {
  Reference r = Reference::Stand(HyqModel(), h);
  ReferenceSample s;
  r.Sample(0.0, &s);
  return s.joints.q;
}

struct Move {
  VectorJ q0;
  std::array<bool, kNumFeet> on_ground;
  double h1, T;
  Eigen::Vector2d v0;
  const char* name;
};

std::vector<Move> Moves() {
  // a trot's stop: rf and lh 4 cm up in the air (their knee and hip bent a little more)
  VectorJ lifted = PostureAt(0.5993);
  for (int leg : {1, 2}) lifted(3 * leg + 2) += (leg == 1 ? -0.15 : 0.15);
  return {{PostureAt(0.40), {true, true, true, true}, 0.5993, 2.0, {0.0, 0.0}, "stand-up"},
          {PostureAt(0.5993), {true, true, true, true}, 0.40, 1.5, {0.0, 0.0}, "sit-down"},
          {lifted, {true, false, false, true}, 0.40, 1.5, {0.2, 0.03}, "sit-down from a trot"}};
}

TEST(PostureMove, JointDerivativesAreConsistent) {
  constexpr double h = 1e-5;
  for (const Move& m : Moves()) {
    PostureMove a(HyqModel()), b(HyqModel()), c(HyqModel());
    for (PostureMove* p : {&a, &b, &c}) p->Start(m.q0, m.on_ground, m.h1, m.T, m.v0);
    JointReference ja, jb, jc;
    double worst_qd = 0, worst_qdd = 0;
    for (double t = 0.003; t < m.T + 0.2; t += 0.0071) {
      ASSERT_TRUE(a.Sample(t - h, &ja) && b.Sample(t, &jb) && c.Sample(t + h, &jc)) << m.name << " " << t;
      worst_qd = std::max(worst_qd, ((jc.q - ja.q) / (2 * h) - jb.qd).cwiseAbs().maxCoeff());
      worst_qdd = std::max(worst_qdd, ((jc.qd - ja.qd) / (2 * h) - jb.qdd).cwiseAbs().maxCoeff());
    }
    std::printf("%s: max |q̇ − FD| %.2e rad/s, max |q̈ − FD| %.2e rad/s²\n", m.name, worst_qd, worst_qdd);
    EXPECT_LT(worst_qd, 1e-5) << m.name;
    EXPECT_LT(worst_qdd, 1e-3) << m.name;
  }
}

TEST(PostureMove, FeetStayOnTheGroundAndTheBaseEndsWhereAsked) {
  const dynamics::LegKinematics legs(HyqModel());
  for (const Move& m : Moves()) {
    PostureMove p(HyqModel());
    p.Start(m.q0, m.on_ground, m.h1, m.T, m.v0);
    JointReference j;
    std::array<Eigen::Vector3d, kNumFeet> start{};
    double worst_slide = 0, worst_ground = 0;
    for (int k = 0; k <= static_cast<int>(m.T * 1000) + 100; ++k) {
      const double t = 1e-3 * k;
      ASSERT_TRUE(p.Sample(t, &j)) << m.name << " " << t;
      for (int f = 0; f < kNumFeet; ++f) {
        const auto i = static_cast<std::size_t>(f);
        const Eigen::Vector3d p_W = p.base_position_m() + legs.Foot(f, j.q.segment<3>(3 * f));
        if (k == 0) start[i] = p_W;
        // a foot on the ground at the start stays where it is; every foot is on the ground once
        // the lowering (40 % of the move) is over, and in stance
        if (m.on_ground[i]) worst_slide = std::max(worst_slide, (p_W - start[i]).norm());
        if (t >= 0.4 * m.T) {
          worst_ground = std::max(worst_ground, std::abs(p_W.z() - HyqModel().feet[i].radius_m));
          EXPECT_TRUE(j.stance[i]);
        }
        EXPECT_NEAR((p_W - start[i]).head<2>().norm(), 0.0, 1e-9) << m.name << " foot " << f;
      }
    }
    std::printf("%s: from %.3f m to %.3f m, feet slid at most %.1e m, off the ground %.1e m\n",
                m.name, p.start_height_m(), p.base_position_m().z(), worst_slide, worst_ground);
    EXPECT_LT(worst_slide, 1e-9) << m.name;
    EXPECT_LT(worst_ground, 1e-9) << m.name;
    EXPECT_NEAR(p.base_position_m().z(), m.h1, 1e-12) << m.name;
    EXPECT_EQ(j.qd, VectorJ::Zero()) << m.name << ": at rest at the end";
    // braking: the base came to rest v0 T / 2 further on (T = 0.3 s)
    EXPECT_NEAR(p.base_position_m().x(), 0.15 * m.v0.x(), 1e-12) << m.name;
    EXPECT_NEAR(p.base_position_m().y(), 0.15 * m.v0.y(), 1e-12) << m.name;
  }
}

TEST(PostureMove, NoHeapInTheCycle) {
  if (!hyq::testing::NoHeapGuard::Available()) GTEST_SKIP() << "allocator hooks compiled out (sanitizer build)";
  PostureMove p(HyqModel());
  const Move m = Moves()[2];
  JointReference j;
  hyq::testing::NoHeapGuard guard;
  p.Start(m.q0, m.on_ground, m.h1, m.T, m.v0);
  for (int k = 0; k < 2000; ++k) (void)p.Sample(1e-3 * k, &j);
  EXPECT_EQ(guard.allocations(), 0u);
}

}  // namespace
}  // namespace hyq::servo
