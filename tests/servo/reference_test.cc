// References: q̇_ref and q̈_ref are the derivatives of q_ref (central differences), stance feet
// do not move in the world (forward kinematics of the full model with the reference base pose),
// the trot's schedule, and the IK itself against the model; the same for the steered trot
// (forward, sideways, turning, a command changed mid-ramp and mid-stride), its velocity ramps and
// Raibert footholds.
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "dynamics/cycle_dynamics.h"
#include "servo/reference/reference.h"
#include "tests/dynamics/hyq_fixture.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::servo {
namespace {

using testing::HyqModel;

constexpr double kFdStep = 1e-5;

// the worst gap between q̇, q̈ and the central differences of q, q̇ over samples at t ∓ h
struct FdWorst {
  double qd = 0, qdd = 0;
  void Add(const ReferenceSample& a, const ReferenceSample& b, const ReferenceSample& c) {
    qd = std::max(qd, ((c.joints.q - a.joints.q) / (2 * kFdStep) - b.joints.qd).cwiseAbs().maxCoeff());
    qdd = std::max(qdd, ((c.joints.qd - a.joints.qd) / (2 * kFdStep) - b.joints.qdd).cwiseAbs().maxCoeff());
  }
  void Expect(const char* name) const {
    std::printf("%s: max |q̇ − FD| %.2e rad/s, max |q̈ − FD| %.2e rad/s²\n", name, qd, qdd);
    EXPECT_LT(qd, 1e-5) << name;
    EXPECT_LT(qdd, 1e-3) << name;
  }
};

void CheckDerivatives(Reference ref, double t_end, const char* name) {
  constexpr double h = kFdStep;
  FdWorst worst;
  ReferenceSample a, b, c;
  Reference r0 = ref, r1 = ref, r2 = ref;
  for (double t = 0.01; t < t_end; t += 0.0137) {
    r0.Sample(t - h, &a);
    r1.Sample(t, &b);
    r2.Sample(t + h, &c);
    ASSERT_EQ(b.ik, dynamics::IkStatus::kOk) << name << " at t = " << t;
    worst.Add(a, b, c);
  }
  worst.Expect(name);
}

// forward kinematics of the full model at the sample's base pose (p_W, yaw about z) against the
// sample's feet, and how far a stance foot moves from where it was planted; the worst of each
struct StanceWorst {
  std::array<Eigen::Vector3d, 4> planted{};
  std::array<bool, 4> was_stance{};
  std::unique_ptr<dynamics::CycleDynamics> dyn = std::make_unique<dynamics::CycleDynamics>();
  double fk = 0, slide = 0;
  void Add(const ReferenceSample& s) {
    VectorQ q = VectorQ::Zero();
    q.head<3>() = s.base.p_W;
    q(3) = std::cos(0.5 * s.base.yaw);  // w x y z: a turn about z
    q(6) = std::sin(0.5 * s.base.yaw);
    q.tail<12>() = s.joints.q;
    ASSERT_EQ(dynamics::ComputeCycleDynamics(HyqModel(), q, VectorV::Zero(), dyn.get()),
              dynamics::DynamicsStatus::kOk);
    for (int f = 0; f < 4; ++f) {
      fk = std::max(fk, (dyn->feet.p_WF_W[f] - s.feet[f].p_W).norm());
      if (s.joints.stance[f]) {
        if (!was_stance[f]) planted[f] = s.feet[f].p_W;
        slide = std::max(slide, (s.feet[f].p_W - planted[f]).norm());
      }
      was_stance[f] = s.joints.stance[f];
    }
  }
};

TEST(Reference, JointDerivativesAreConsistent) {
  CheckDerivatives(Reference::Stand(HyqModel()), 1.0, "stand");
  CheckDerivatives(Reference::Trot(HyqModel(), TrotParams{}), 4.0, "trot");
  CheckDerivatives(Reference::FigureEight(HyqModel(), FigureEightParams{}), 4.5, "figure_eight");
}

TEST(Reference, StanceFeetStayPutAndMatchTheModel) {
  for (auto ref : {Reference::Trot(HyqModel(), TrotParams{}),
                   Reference::FigureEight(HyqModel(), FigureEightParams{})}) {
    ReferenceSample s;
    StanceWorst worst;
    for (int k = 0; k < 4000; ++k) {
      ref.Sample(k * 1e-3, &s);
      ASSERT_EQ(s.ik, dynamics::IkStatus::kOk) << k;
      ASSERT_NO_FATAL_FAILURE(worst.Add(s)) << k;
      for (int f = 0; f < 4; ++f) {
        if (s.joints.stance[f]) {
          EXPECT_NEAR(s.feet[f].p_W.z(), HyqModel().feet[f].radius_m, 1e-12);
        }
      }
    }
    EXPECT_LT(worst.fk, 1e-9);     // the IK reproduces the feet through the full model
    EXPECT_LT(worst.slide, 1e-12); // planted feet do not move
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

// A velocity command at reference time t (applied after sampling t, as the loop does).
struct SteerCommand {
  double t, vx, vy, wz;
};

// Steps `ref` forward to time t, applying the commands due on the way.
void AdvanceTo(Reference* ref, double t, const std::vector<SteerCommand>& plan, std::size_t* next) {
  ReferenceSample s;
  while (*next < plan.size() && plan[*next].t <= t) {
    const SteerCommand& c = plan[(*next)++];
    ref->Sample(c.t, &s);
    ASSERT_TRUE(ref->SetVelocity(c.vx, c.vy, c.wz));
  }
  ref->Sample(t, &s);
}

// q̇, q̈ against central differences of copies of a reference that steps forward with the loop
void CheckSteeredDerivatives(const std::vector<SteerCommand>& plan, double t_end, const char* name) {
  constexpr double h = kFdStep;
  Reference ref = Reference::Trot(HyqModel(), TrotParams{});
  std::size_t next = 0;
  FdWorst worst;
  ReferenceSample a, b, c;
  for (double t = 0.01; t < t_end; t += 0.0137) {
    AdvanceTo(&ref, t - 2 * h, plan, &next);
    Reference r0 = ref, r1 = ref, r2 = ref;
    r0.Sample(t - h, &a);
    r1.Sample(t, &b);
    r2.Sample(t + h, &c);
    ASSERT_EQ(b.ik, dynamics::IkStatus::kOk) << name << " at t = " << t;
    worst.Add(a, b, c);
  }
  ASSERT_EQ(next, plan.size()) << name;
  worst.Expect(name);
}

// t = 2.23 s is in the swing of rf and lh (phase 2.92, duty factor 0.6), in the ramp of the
// command at 1 s; t = 2.71 s in the swing of lf and rh (phase 3.09 + 0.5), in the second ramp
const std::vector<SteerCommand> kForward{{0.2, 0.3, 0.0, 0.0}};
const std::vector<SteerCommand> kSideways{{1.0, 0.0, 0.15, 0.0}};
const std::vector<SteerCommand> kTurning{{1.0, 0.2, 0.0, 0.4}};
const std::vector<SteerCommand> kChangeMidStride{{1.0, 0.3, 0.0, 0.0}, {2.23, 0.1, -0.1, -0.4},
                                                 {2.71, -0.1, 0.05, 0.3}};

TEST(Reference, SteeredJointDerivativesAreConsistent) {
  CheckSteeredDerivatives(kForward, 4.0, "steered forward");
  CheckSteeredDerivatives(kSideways, 4.0, "steered sideways");
  CheckSteeredDerivatives(kTurning, 4.0, "steered turning");
  CheckSteeredDerivatives(kChangeMidStride, 4.5, "steered, changed mid-ramp and mid-stride");
}

TEST(Reference, SteeredStanceFeetStayPutAndMatchTheModel) {
  for (const auto* plan : {&kForward, &kSideways, &kTurning, &kChangeMidStride}) {
    Reference ref = Reference::Trot(HyqModel(), TrotParams{});
    std::size_t next = 0;
    ReferenceSample s;
    StanceWorst worst;
    for (int k = 0; k < 5000; ++k) {
      AdvanceTo(&ref, k * 1e-3, *plan, &next);
      ref.Sample(k * 1e-3, &s);
      ASSERT_EQ(s.ik, dynamics::IkStatus::kOk) << k;
      ASSERT_NO_FATAL_FAILURE(worst.Add(s)) << k;
    }
    EXPECT_LT(worst.fk, 1e-9);
    EXPECT_EQ(worst.slide, 0.0);  // a chosen foothold is never moved, even by a new command
  }
}

TEST(Reference, SteeredVelocityRampsWithinLimitsAndIntegratesThePose) {
  const TrotParams p;
  Reference ref = Reference::Trot(HyqModel(), p);
  const std::vector<SteerCommand> plan{{1.0, 9.0, -9.0, 0.3}, {1.8, 0.1, -9.0, -9.0}};
  std::size_t next = 0;
  ReferenceSample s, prev;
  double worst_ax = 0, worst_ay = 0, worst_aw = 0, worst_jump = 0;
  for (int k = 0; k <= 8000; ++k) {
    const double t = k * 1e-3;
    AdvanceTo(&ref, t, plan, &next);
    ref.Sample(t, &s);
    // heading-frame acceleration: R_yawᵀ a_W + the turning term
    const Eigen::Vector2d a_B = Eigen::Rotation2Dd(-s.base.yaw) * s.base.a_W.head<2>();
    const Eigen::Vector2d v_B = Eigen::Rotation2Dd(-s.base.yaw) * s.base.v_W.head<2>();
    worst_ax = std::max(worst_ax, std::abs(a_B.x() + s.base.yaw_rate * v_B.y()));
    worst_ay = std::max(worst_ay, std::abs(a_B.y() - s.base.yaw_rate * v_B.x()));
    worst_aw = std::max(worst_aw, std::abs(s.base.yaw_acc));
    if (k > 0) {
      worst_jump = std::max(worst_jump, (s.base.a_W - prev.base.a_W).norm());
      // the pose is the velocity's integral (trapezoid over 1 ms)
      EXPECT_NEAR(s.base.p_W.x(), prev.base.p_W.x() + 5e-4 * (s.base.v_W.x() + prev.base.v_W.x()), 1e-9);
      EXPECT_NEAR(s.base.p_W.y(), prev.base.p_W.y() + 5e-4 * (s.base.v_W.y() + prev.base.v_W.y()), 1e-9);
      EXPECT_NEAR(s.base.yaw, prev.base.yaw + 5e-4 * (s.base.yaw_rate + prev.base.yaw_rate), 1e-9);
    }
    prev = s;
  }
  // clamped to the limits, reached with the ramps
  EXPECT_EQ(ref.commanded_velocity()[0], 0.1);
  EXPECT_EQ(ref.commanded_velocity()[1], -p.max_velocity[1]);
  EXPECT_EQ(ref.commanded_velocity()[2], -p.max_velocity[2]);
  const Eigen::Vector2d v_B = Eigen::Rotation2Dd(-s.base.yaw) * s.base.v_W.head<2>();
  EXPECT_NEAR(v_B.x(), 0.1, 1e-12);
  EXPECT_NEAR(v_B.y(), -p.max_velocity[1], 1e-12);
  EXPECT_NEAR(s.base.yaw_rate, -p.max_velocity[2], 1e-12);
  EXPECT_LE(worst_ax, p.max_acceleration[0] + 1e-9);
  EXPECT_LE(worst_ay, p.max_acceleration[1] + 1e-9);
  EXPECT_LE(worst_aw, p.max_acceleration[2] + 1e-9);
  EXPECT_LT(worst_jump, 0.05);  // continuous acceleration, also across the second command
  EXPECT_GT(worst_ax, 0.5 * p.max_acceleration[0]);  // the bound is used, not just met
}

TEST(Reference, SteeredFootholdsAreRaibertsNeutralPoint) {
  // at cruise, a foot touches down v·T_stance/2 ahead of (or beside) its nominal place under the
  // hip, in the heading frame
  for (const Eigen::Vector2d& v : {Eigen::Vector2d(0.3, 0.0), Eigen::Vector2d(0.0, -0.15)}) {
    const TrotParams p;
    Reference ref = Reference::Trot(HyqModel(), p);
    const std::vector<SteerCommand> plan{{0.6, v.x(), v.y(), 0.0}};
    std::size_t next = 0;
    ReferenceSample s;
    bool was_stance = true;
    int touchdowns = 0;
    const Eigen::Vector3d nominal = ref.nominal_feet_B()[0];
    const double half_stance = 0.5 * p.duty_factor / p.step_frequency_Hz;
    for (int k = 0; k < 6000; ++k) {
      const double t = k * 1e-3;
      AdvanceTo(&ref, t, plan, &next);
      ref.Sample(t, &s);
      if (t > 3.0 && s.joints.stance[0] && !was_stance) {  // lf touches down
        ++touchdowns;
        const Eigen::Vector3d p_rel = s.feet[0].p_W - s.base.p_W;
        // sampled up to 1 ms after the touchdown
        EXPECT_NEAR(p_rel.x(), nominal.x() + v.x() * half_stance, 1e-3 * std::abs(v.x()) + 1e-9);
        EXPECT_NEAR(p_rel.y(), nominal.y() + v.y() * half_stance, 1e-3 * std::abs(v.y()) + 1e-9);
      }
      was_stance = s.joints.stance[0];
    }
    EXPECT_GE(touchdowns, 3);
  }
}

TEST(Reference, SteeringDoesNotTouchTheHeap) {
  HYQ_REQUIRE_HEAP_HOOKS();
  Reference ref = Reference::Trot(HyqModel(), TrotParams{});
  ReferenceSample s;
  ref.Sample(0.0, &s);
  testing::NoHeapGuard guard;
  double worst_us = 0.0;  // printed, not judged (a shared machine)
  for (int k = 1; k < 3000; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    ref.Sample(k * 1e-3, &s);
    worst_us = std::max(
        worst_us, std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
    if (k == 1000) {
      ASSERT_TRUE(ref.SetVelocity(0.2, 0.1, 0.3));
    } else if (k == 2200) {
      ASSERT_TRUE(ref.SetVelocity(-0.1, 0.0, -0.3));
    }
  }
  ref.Sample(0.0, &s);  // restart
  EXPECT_EQ(guard.allocations(), 0u);
  std::printf("steered, turning trot: slowest Sample %.1f us (a lift-off predicts a foothold)\n",
              worst_us);
}

TEST(Reference, SteeringRestartsFromRestAndOnlyTrotSteers) {
  Reference ref = Reference::Trot(HyqModel(), TrotParams{});
  ReferenceSample s;
  for (double t = 0; t < 3.0; t += 1e-3) ref.Sample(t, &s);
  ASSERT_TRUE(ref.SetVelocity(0.0, 0.1, 0.2));
  ref.Sample(0.0, &s);  // enable again
  EXPECT_EQ(s.base.v_W.norm(), 0.0);
  EXPECT_EQ(s.base.p_W.head<2>().norm(), 0.0);
  for (double t = 0; t < 4.0; t += 1e-3) ref.Sample(t, &s);
  EXPECT_NEAR(s.base.yaw_rate, 0.2, 1e-12);
  Reference stand = Reference::Stand(HyqModel());
  EXPECT_FALSE(stand.SetVelocity(0.1, 0.0, 0.0));
}

// The contact-aware trot on a toy ground: the joints track the reference exactly, except that a
// foot cannot go below its ground (ground_z[f] + radius); a foot at its ground is loaded
// (P(contact) 1), else not (0). One sample per millisecond, the contacts of the last one.
struct ToyGround {
  std::array<double, 4> ground_z{};
  Reference ref = Reference::Trot(HyqModel(), TrotParams{});
  ReferenceSample s;
  FootContacts c;
  std::array<bool, 4> touching{};

  void Step(double t) {
    ref.Sample(t, c, &s);
    for (int f = 0; f < 4; ++f) {
      const double floor_z = ground_z[f] + HyqModel().feet[f].radius_m;
      touching[f] = s.feet[f].p_W.z() <= floor_z + 1e-9;
      c.probability[f] = touching[f] ? 1.0 : 0.0;
    }
    c.q = s.joints.q;  // perfect tracking: where the measured joints put the foot is the reference
    c.base_height_m = s.base.p_W.z();
    c.R_WB = Eigen::AngleAxisd(s.base.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  }
};

// the schedule's stance of foot f at time t (duty factor 0.6, 1.4 Hz, offsets 0, .5, .5, 0)
bool ScheduledStance(int f, double t) {
  const TrotParams p;
  if (t < p.start_delay_s) return true;
  const double phase = p.step_frequency_Hz * (t - p.start_delay_s) + (f == 1 || f == 2 ? 0.5 : 0.0);
  return phase - std::floor(phase) < p.duty_factor;
}

// whether the contact-aware stance of a foot on the toy's flat ground must be the schedule's: not
// in the first cycle after a scheduled touchdown (the toy's contact is the last sample's: a foot
// that lands at its due time exactly may be seen down a cycle later)
bool PastTouchdown(int f, double t) { return ScheduledStance(f, t) == ScheduledStance(f, t - 1.5e-3); }

TEST(ContactAwareTrot, OnFlatGroundItIsTheSchedule) {
  ToyGround g;
  Reference clock_only = Reference::Trot(HyqModel(), TrotParams{});
  ReferenceSample s0;
  double worst = 0.0;
  for (int k = 0; k <= 4000; ++k) {
    const double t = k * 1e-3;
    g.Step(t);
    clock_only.Sample(t, &s0);
    worst = std::max(worst, (g.s.joints.q - s0.joints.q).cwiseAbs().maxCoeff());
    for (int f = 0; f < 4; ++f) {
      if (!PastTouchdown(f, t)) continue;
      ASSERT_EQ(g.s.joints.stance[f], s0.joints.stance[f]) << "foot " << f << " at " << t;
    }
  }
  // the toy reports the last sample's joints: a foot is held where they put it under this
  // sample's base, a cycle of the base's motion (0.2 mm) from its foothold
  EXPECT_LT(worst, 1e-3);
}

TEST(ContactAwareTrot, AFootOnAStepUpLandsEarlyAndStaysWhereItLanded) {
  ToyGround g;  // lf steps up 3 cm at its first step (its first lift-off is at 0.93 s)
  const double r = HyqModel().feet[0].radius_m;
  int early_landings = 0;
  double worst_jump = 0.0, worst_hold = 0.0;
  Eigen::Vector3d last_p = Eigen::Vector3d::Zero(), held = Eigen::Vector3d::Zero();
  bool was_stance = true;
  for (int k = 0; k <= 4000; ++k) {
    const double t = k * 1e-3;
    if (t > 1.0) g.ground_z[0] = 0.03;
    g.Step(t);
    const FootReference& lf = g.s.feet[0];
    if (k > 0) worst_jump = std::max(worst_jump, (lf.p_W - last_p).norm());
    if (k == 0) held = lf.p_W;
    last_p = lf.p_W;
    if (early_landings > 0) {
      EXPECT_GE(lf.p_W.z(), 0.03 + r - 1e-3) << "at " << t << ": below the step";
    }
    if (lf.stance && !was_stance) {
      held = lf.p_W;
      // on the step the foot lands before its stance is due, and is in the stance set at once
      if (!ScheduledStance(0, t)) {
        ++early_landings;
        EXPECT_EQ(lf.phase, FootPhase::kLanded);
        EXPECT_LT(lf.takeover, 0.1);
      }
    }
    if (lf.stance) worst_hold = std::max(worst_hold, (lf.p_W - held).norm());
    was_stance = lf.stance;
    // the other feet are on the schedule
    for (int f = 1; f < 4; ++f) {
      if (!PastTouchdown(f, t)) continue;
      ASSERT_EQ(g.s.joints.stance[f], ScheduledStance(f, t)) << f << " at " << t;
    }
  }
  EXPECT_GE(early_landings, 4);
  EXPECT_LT(worst_hold, 1e-12) << "a landed foot stays where it landed";
  EXPECT_LT(worst_jump, 0.003) << "the foot's reference moves at most 3 mm per ms";
  EXPECT_NEAR(held.z(), 0.03 + r, 2e-3);
}

TEST(ContactAwareTrot, AFootOverAStepDownReachesAndLandsLate) {
  ToyGround g;
  g.ground_z[0] = -0.03;  // lf: 3 cm lower than the others' ground
  const TouchdownParams td;
  const double r = HyqModel().feet[0].radius_m;
  int late_landings = 0;
  double worst_speed = 0.0, worst_jump = 0.0;
  Eigen::Vector3d last_p = Eigen::Vector3d::Zero();
  bool was_stance = true;
  double reach_began = -1.0;
  for (int k = 0; k <= 4000; ++k) {
    const double t = k * 1e-3;
    g.Step(t);
    const FootReference& lf = g.s.feet[0];
    if (k > 0) worst_jump = std::max(worst_jump, (lf.p_W - last_p).norm());
    last_p = lf.p_W;
    if (lf.phase == FootPhase::kReaching) {
      if (reach_began < 0) reach_began = t;
      EXPECT_FALSE(lf.stance) << "a reaching foot is not in the stance set, at " << t;
      worst_speed = std::max(worst_speed, lf.v_W.norm());
    }
    if (lf.stance && !was_stance && reach_began >= 0) {
      ++late_landings;
      // it lands when it reaches the ground: 3 cm at the reach speed after the grace
      EXPECT_NEAR(lf.p_W.z(), -0.03 + r, 2e-3);
      EXPECT_GT(t - reach_began, 0.03 / td.reach_speed_m_s) << "landed before reaching the ground";
      EXPECT_LT(t - reach_began, 0.03 / td.reach_speed_m_s + td.reach_ramp_s + 0.005);
      reach_began = -1.0;
    }
    was_stance = lf.stance;
  }
  EXPECT_GE(late_landings, 4);
  EXPECT_LE(worst_speed, td.reach_speed_m_s + 1e-9);
  EXPECT_LT(worst_jump, 0.003);
}

TEST(ContactAwareTrot, FollowContactOffIsTheClockAndNoHeap) {
  HYQ_REQUIRE_HEAP_HOOKS();
  TrotParams p;
  p.touchdown.follow_contact = false;
  Reference a = Reference::Trot(HyqModel(), p), b = Reference::Trot(HyqModel(), p);
  ReferenceSample sa, sb;
  FootContacts none;  // no foot down: with the contacts followed, every landing would be late
  {
    testing::NoHeapGuard guard;
    for (int k = 0; k <= 3000; ++k) {
      a.Sample(k * 1e-3, none, &sa);
      b.Sample(k * 1e-3, &sb);
      ASSERT_EQ(sa.joints.q, sb.joints.q);
      ASSERT_EQ(sa.joints.stance, sb.joints.stance);
    }
    EXPECT_EQ(guard.allocations(), 0u);
  }
  ToyGround g;
  g.ground_z[0] = -0.03;
  testing::NoHeapGuard guard;
  for (int k = 0; k <= 3000; ++k) g.Step(k * 1e-3);
  g.Step(0.0);  // a restart forgets the stances
  EXPECT_EQ(guard.allocations(), 0u);
  EXPECT_EQ(g.s.feet[0].phase, FootPhase::kStance);
}

}  // namespace
}  // namespace hyq::servo
