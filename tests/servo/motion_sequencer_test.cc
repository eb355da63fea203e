// The motion phases alone (servo/reference/motion_sequencer.h), driven as the loop drives them:
// Sample in the reference stage, Advance at the end of an ACTIVE cycle. Each phase's transitions,
// the enable ramp's ends, a sit-down deferred until every foot is down (and its 1 s bound), a stop
// overriding a pending disable, the settling's damping hold, the duration stop, and no heap.
#include "servo/reference/motion_sequencer.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "tests/dynamics/hyq_fixture.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::servo {
namespace {

using testing::HyqModel;

constexpr double kDt = 1e-3;

// A sequencer with its outputs, as the loop owns them, and the inputs the loop would give.
struct Rig {
  explicit Rig(const MotionConfig& c, Reference r = Reference::Stand(HyqModel()))
      : reference(std::move(r)), seq(HyqModel(), &reference, c, kDt, &sample, &joints) {
    in.active = true;
    in.q_rad = joints.q;
  }
  // an enable with the joints measured at the standing posture of base height h
  void EnableStandingAt(double h);
  // one ACTIVE cycle: the reference stage, then the end of the cycle
  MotionRequests Cycle() {
    EXPECT_TRUE(seq.Sample(in));
    return seq.Advance(in);
  }
  // cycles until a request or `max` cycles; the number run
  int CyclesUntilRequest(int max, MotionRequests* r) {
    for (int k = 1; k <= max; ++k) {
      *r = Cycle();
      if (r->sit_down_began || r->sit_down_ended || r->duration_over) return k;
    }
    return max;
  }

  Reference reference;
  ReferenceSample sample;
  JointReference joints;
  MotionSequencer seq;
  MotionInputs in;
};

MotionConfig NoMoves() {
  MotionConfig c;
  c.stand_up_s = 0.0;
  c.sit_down_s = 0.0;
  c.enable_ramp_s = 0.5;
  return c;
}

// the standing reference's joint angles at base height h
dynamics::VectorJ StandingAt(double h) {
  Reference r = Reference::Stand(HyqModel(), h);
  ReferenceSample s;
  r.Sample(0.0, &s);
  return s.joints.q;
}

void Rig::EnableStandingAt(double h) {
  in.q_rad = StandingAt(h);
  seq.Enable(in);
}

TEST(MotionSequencer, RestsAndHoldsStillOutsideActive) {
  Rig rig(NoMoves());
  EXPECT_EQ(rig.seq.phase(), MotionPhase::kRest);
  EXPECT_STREQ(ToString(rig.seq.phase()), "rest");
  const dynamics::VectorJ q = rig.joints.q;
  EXPECT_EQ(q, rig.sample.joints.q) << "constructed with the reference at t = 0";
  rig.in.active = false;
  rig.in.q_rad = StandingAt(0.45);
  for (int k = 0; k < 10; ++k) EXPECT_TRUE(rig.seq.Sample(rig.in));
  EXPECT_EQ(rig.seq.phase(), MotionPhase::kRest);
  EXPECT_EQ(rig.joints.q, q) << "outside ACTIVE the joint reference keeps its value";
  // a sit-down is taken only while standing up or following the reference
  const MotionRequests r = rig.seq.RequestSitDown(SitDownCause::kStop, rig.in);
  EXPECT_FALSE(r.sit_down_began);
  EXPECT_FALSE(rig.seq.sit_down_pending());
}

// the ramp (1) starts exactly at the posture measured at enable, at rest, and ends exactly on the
// reference once enable_ramp_s of reference time has passed
TEST(MotionSequencer, EnableRampRunsFromTheMeasuredPostureToTheReference) {
  Rig rig(NoMoves());
  const dynamics::VectorJ q_ref = rig.joints.q;
  rig.EnableStandingAt(0.45);
  EXPECT_EQ(rig.seq.phase(), MotionPhase::kReference);
  EXPECT_EQ(rig.seq.reference_time_s(), 0.0);
  ASSERT_TRUE(rig.seq.Sample(rig.in));
  EXPECT_EQ(rig.joints.q, rig.in.q_rad) << "x = 0: the measured posture";
  EXPECT_EQ(rig.joints.qd, dynamics::VectorJ::Zero()) << "s'(0) = 0: at rest";
  (void)rig.seq.Advance(rig.in);
  // halfway (x = 0.5, s = 0.5): the mean of the two postures
  for (int k = 1; k < 250; ++k) (void)rig.Cycle();
  ASSERT_TRUE(rig.seq.Sample(rig.in));
  EXPECT_NEAR(rig.seq.reference_time_s(), 0.25, 1e-9);
  const dynamics::VectorJ mean = 0.5 * (rig.in.q_rad + rig.sample.joints.q);
  EXPECT_LT((rig.joints.q - mean).cwiseAbs().maxCoeff(), 1e-9);
  (void)rig.seq.Advance(rig.in);
  // past the ramp: the reference itself, bit for bit
  for (int k = 251; k <= 501; ++k) (void)rig.Cycle();
  ASSERT_TRUE(rig.seq.Sample(rig.in));
  EXPECT_GT(rig.seq.reference_time_s(), 0.5);
  EXPECT_EQ(rig.joints.q, rig.sample.joints.q);
  EXPECT_EQ(rig.joints.qd, rig.sample.joints.qd);
  EXPECT_LT((rig.joints.q - q_ref).cwiseAbs().maxCoeff(), 1e-9) << "the standing posture";
  // the ACTIVE mode left (a fault, a disable without a sit-down): REST, the reference stops
  const double t = rig.seq.reference_time_s();
  rig.in.active = false;
  ASSERT_TRUE(rig.seq.Sample(rig.in));
  EXPECT_EQ(rig.seq.phase(), MotionPhase::kRest);
  EXPECT_EQ(rig.seq.reference_time_s(), t) << "the clock is kept outside ACTIVE";
}

TEST(MotionSequencer, StandUpThenTheReferenceRampsFromWhereItEnded) {
  MotionConfig c = NoMoves();
  c.stand_up_s = 0.3;
  Rig rig(c);
  const double standing_m = rig.sample.base.p_W.z();
  rig.EnableStandingAt(0.40);
  EXPECT_EQ(rig.seq.phase(), MotionPhase::kStandUp);
  EXPECT_STREQ(ToString(rig.seq.phase()), "stand-up");
  int cycles = 0;
  while (rig.seq.phase() == MotionPhase::kStandUp && cycles < 1000) {
    const MotionRequests r = rig.Cycle();
    EXPECT_FALSE(r.sit_down_began || r.sit_down_ended || r.duration_over);
    ++cycles;
  }
  EXPECT_EQ(rig.seq.phase(), MotionPhase::kReference);
  EXPECT_NEAR(cycles, 300, 1) << "stand_up_s at 1 kHz";
  EXPECT_EQ(rig.seq.reference_time_s(), 0.0) << "the reference's clock starts after the stand-up";
  EXPECT_LT((rig.joints.q - StandingAt(standing_m)).cwiseAbs().maxCoeff(), 1e-3)
      << "the stand-up ends at the reference's height";
  const dynamics::VectorJ end = rig.joints.q;
  ASSERT_TRUE(rig.seq.Sample(rig.in));
  EXPECT_EQ(rig.joints.q, end) << "the ramp starts where the stand-up ended";
}

// a sit-down asked for during the stand-up starts at once, without the reference's base velocity
TEST(MotionSequencer, SitDownDuringTheStandUpStartsAtOnce) {
  MotionConfig c = NoMoves();
  c.stand_up_s = 0.3;
  c.sit_down_s = 0.2;
  Rig rig(c);
  rig.EnableStandingAt(0.40);
  for (int k = 0; k < 100; ++k) (void)rig.Cycle();
  rig.in.q_rad = rig.joints.q;
  const MotionRequests r = rig.seq.RequestSitDown(SitDownCause::kDisable, rig.in);
  EXPECT_TRUE(r.sit_down_began);
  EXPECT_EQ(r.cause, SitDownCause::kDisable);
  EXPECT_EQ(rig.seq.phase(), MotionPhase::kSitDown);
  EXPECT_FALSE(rig.seq.sit_down_pending());
  // a second request while sitting down changes nothing
  EXPECT_FALSE(rig.seq.RequestSitDown(SitDownCause::kStop, rig.in).sit_down_began);
  MotionRequests end;
  const int n = rig.CyclesUntilRequest(1000, &end);
  EXPECT_TRUE(end.sit_down_ended);
  EXPECT_EQ(end.cause, SitDownCause::kDisable) << "a disable: damping, then STANDBY";
  EXPECT_NEAR(n, 200, 1) << "sit_down_s at 1 kHz";
  EXPECT_EQ(rig.seq.phase(), MotionPhase::kSettle);
}

// a trot: a stop that comes with a foot in the air waits until every foot is down (at most half
// a gait cycle), then sits down; the sit-down ends with the stop's request
TEST(MotionSequencer, SitDownWaitsUntilEveryFootIsDown) {
  MotionConfig c = NoMoves();
  c.sit_down_s = 0.2;
  TrotParams trot;
  Rig rig(c, Reference::Trot(HyqModel(), trot));
  rig.seq.Enable(rig.in);
  // into the gait until a foot swings
  int k = 0;
  auto all_down = [&] {
    const auto& st = rig.joints.stance;
    return st[0] && st[1] && st[2] && st[3];
  };
  for (; k < 5000; ++k) {
    ASSERT_TRUE(rig.seq.Sample(rig.in));
    if (!all_down()) break;
    (void)rig.seq.Advance(rig.in);
  }
  ASSERT_FALSE(all_down()) << "the trot lifts a foot";
  // asked for in the reference stage's cycle with a foot up: deferred
  MotionRequests r = rig.seq.RequestSitDown(SitDownCause::kDisable, rig.in);
  EXPECT_FALSE(r.sit_down_began);
  EXPECT_TRUE(rig.seq.sit_down_pending());
  // a stop overrides the pending disable; a later disable does not override the stop
  EXPECT_FALSE(rig.seq.RequestSitDown(SitDownCause::kStop, rig.in).sit_down_began);
  EXPECT_FALSE(rig.seq.RequestSitDown(SitDownCause::kDisable, rig.in).sit_down_began);
  r = rig.seq.Advance(rig.in);
  int waited = 1;
  while (!r.sit_down_began && waited < 2000) {
    EXPECT_EQ(rig.seq.phase(), MotionPhase::kReference);
    EXPECT_FALSE(r.duration_over);
    ASSERT_TRUE(rig.seq.Sample(rig.in));
    r = rig.seq.Advance(rig.in);
    ++waited;
  }
  ASSERT_TRUE(r.sit_down_began);
  EXPECT_TRUE(all_down()) << "it began on a cycle whose reference had every foot down";
  EXPECT_EQ(r.cause, SitDownCause::kStop);
  EXPECT_LE(waited * kDt, 0.5 / trot.step_frequency_Hz + kDt) << "within half a gait cycle";
  EXPECT_EQ(rig.seq.phase(), MotionPhase::kSitDown);
  EXPECT_FALSE(rig.seq.sit_down_pending());
  MotionRequests end;
  (void)rig.CyclesUntilRequest(1000, &end);
  EXPECT_TRUE(end.sit_down_ended);
  EXPECT_EQ(end.cause, SitDownCause::kStop) << "a stop: damping, then STOPPED";
}

// A fault's sit-down starts at once, from the footholds of the moment, with every leg in the
// stance set (a lost joint's board is off, its valve closed: the joint is locked and its leg
// carries); a second fault during it lets it go on, a stop's sit-down under way becomes the
// fault's and starts again from where the robot is
TEST(MotionSequencer, AFaultSitsDownAtOnceOnEveryLeg) {
  MotionConfig c = NoMoves();
  c.sit_down_s = 0.3;
  Rig rig(c);
  rig.seq.Enable(rig.in);
  for (int k = 0; k < 600; ++k) (void)rig.Cycle();
  ASSERT_TRUE(rig.seq.Sample(rig.in));
  EXPECT_TRUE(rig.seq.RequestSitDown(SitDownCause::kStop, rig.in).sit_down_began);
  for (int k = 0; k < 50; ++k) (void)rig.Cycle();
  MotionRequests r = rig.seq.RequestSitDown(SitDownCause::kFault, rig.in);
  EXPECT_TRUE(r.sit_down_began) << "a stop's sit-down becomes the fault's";
  EXPECT_EQ(r.cause, SitDownCause::kFault);
  int cycles = 0;
  for (MotionRequests m; cycles < 1000 && !m.sit_down_ended; ++cycles) {
    ASSERT_TRUE(rig.seq.Sample(rig.in));
    for (int f = 0; f < 4; ++f) EXPECT_TRUE(rig.joints.stance[static_cast<std::size_t>(f)]) << f;
    if (cycles == 100) {
      EXPECT_FALSE(rig.seq.RequestSitDown(SitDownCause::kFault, rig.in).sit_down_began);
    }
    m = rig.seq.Advance(rig.in);
    if (m.sit_down_ended) {
      EXPECT_EQ(m.cause, SitDownCause::kFault) << "damping, then FAULT";
    }
  }
  EXPECT_EQ(cycles, 300) << "one sit-down of sit_down_s from the fault on";
}

// a reference that keeps a foot in the air (a trot with a duty factor of 0.5 never has all four
// down between its pairs' switches) still sits down after kMaxSitWaitS
TEST(MotionSequencer, SitDownWaitsAtMostOneSecond) {
  MotionConfig c = NoMoves();
  c.sit_down_s = 0.2;
  TrotParams trot;
  trot.duty_factor = 0.5;
  trot.start_delay_s = 0.0;
  trot.ramp_s = 0.1;
  Rig rig(c, Reference::Trot(HyqModel(), trot));
  rig.seq.Enable(rig.in);
  for (int k = 0; k < 100; ++k) (void)rig.Cycle();
  ASSERT_TRUE(rig.seq.Sample(rig.in));
  MotionRequests r = rig.seq.RequestSitDown(SitDownCause::kStop, rig.in);
  ASSERT_FALSE(r.sit_down_began) << "a foot in the air";
  int waited = 0;
  bool ever_all_down = false;
  do {
    r = rig.seq.Advance(rig.in);
    ++waited;
    if (r.sit_down_began) break;
    ASSERT_TRUE(rig.seq.Sample(rig.in));
    const auto& st = rig.joints.stance;
    ever_all_down = ever_all_down || (st[0] && st[1] && st[2] && st[3]);
  } while (waited < 2000);
  ASSERT_FALSE(ever_all_down) << "the test needs a reference that never has every foot down";
  ASSERT_TRUE(r.sit_down_began);
  EXPECT_NEAR(waited * kDt, MotionSequencer::kMaxSitWaitS, 1.5 * kDt);
}

// after a sit-down, while damping (not for a fault): the sit-down's damping, held until every
// joint has rested kSettledS, at most settle_max_s; then REST again at the next enable
TEST(MotionSequencer, SettleHoldsTheDampingUntilTheJointsRest) {
  MotionConfig c = NoMoves();
  c.sit_down_s = 0.05;
  c.settle_speed_rad_s = 0.05;
  c.settle_max_s = 1.0;
  Rig rig(c);
  rig.seq.Enable(rig.in);
  (void)rig.Cycle();
  ASSERT_TRUE(rig.seq.RequestSitDown(SitDownCause::kStop, rig.in).sit_down_began);
  MotionRequests end;
  (void)rig.CyclesUntilRequest(1000, &end);
  ASSERT_TRUE(end.sit_down_ended);
  ASSERT_EQ(rig.seq.phase(), MotionPhase::kSettle);
  EXPECT_STREQ(ToString(rig.seq.phase()), "settle");

  // the safety state machine damps: the joints still move, then rest
  rig.in.active = false;
  rig.in.damping = true;
  auto step = [&](std::uint64_t cycle, double speed) {
    rig.in.cycles_in_mode = cycle;
    rig.in.fastest_joint_rad_s = speed;
    EXPECT_TRUE(rig.seq.Sample(rig.in));
  };
  std::uint64_t cycle = 1;
  for (; cycle <= 100; ++cycle) {
    step(cycle, 0.3);
    EXPECT_TRUE(rig.seq.settling());
    EXPECT_TRUE(rig.seq.holds_damping()) << cycle;
  }
  int rested = 0;
  for (; rig.seq.holds_damping() && cycle < 1000; ++cycle, ++rested) step(cycle, 0.01);
  EXPECT_NEAR(rested * kDt, MotionSequencer::kSettledS, 1.5 * kDt) << "released once at rest";
  EXPECT_TRUE(rig.seq.settling());

  // a new DAMPING (cycle count restarts): an unknown joint speed keeps it held up to settle_max_s
  for (cycle = 1; cycle < 2000; ++cycle) {
    step(cycle, std::numeric_limits<double>::infinity());
    if (!rig.seq.holds_damping()) break;
  }
  EXPECT_NEAR(static_cast<double>(cycle) * kDt, c.settle_max_s, 1.5 * kDt);

  // a fault's damping: the configured one, not held
  rig.in.damping_cut = true;
  step(1, 0.3);
  EXPECT_FALSE(rig.seq.settling());
  EXPECT_FALSE(rig.seq.holds_damping());
  // not damping (STOPPED): neither
  rig.in.damping = rig.in.damping_cut = false;
  step(5, 0.3);
  EXPECT_FALSE(rig.seq.settling());
  EXPECT_FALSE(rig.seq.holds_damping());
  EXPECT_EQ(rig.seq.phase(), MotionPhase::kSettle) << "until the next enable";

  rig.in.active = true;
  rig.seq.Enable(rig.in);
  EXPECT_EQ(rig.seq.phase(), MotionPhase::kReference);
}

// the run's duration counts reference time only: not the stand-up
TEST(MotionSequencer, DurationStopCountsReferenceTime) {
  MotionConfig c = NoMoves();
  c.stand_up_s = 0.1;
  c.duration_s = 0.2;
  Rig rig(c);
  rig.EnableStandingAt(0.45);
  MotionRequests r;
  const int n = rig.CyclesUntilRequest(2000, &r);
  ASSERT_TRUE(r.duration_over);
  EXPECT_FALSE(r.sit_down_began || r.sit_down_ended);
  EXPECT_NEAR(n, 300, 1) << "0.1 s of stand-up, then 0.2 s of reference";
  EXPECT_GE(rig.seq.reference_time_s(), c.duration_s);
  EXPECT_TRUE(rig.Cycle().duration_over) << "asked again each cycle until the stop is taken";
  // never without a duration
  Rig forever(NoMoves());
  forever.seq.Enable(forever.in);
  EXPECT_EQ(forever.CyclesUntilRequest(3000, &r), 3000);
  EXPECT_FALSE(r.duration_over);
}

TEST(MotionSequencer, NoHeapInTheCycle) {
  if (!hyq::testing::NoHeapGuard::Available())
    GTEST_SKIP() << "allocator hooks compiled out (sanitizer build)";
  MotionConfig c = NoMoves();
  c.stand_up_s = 0.2;
  c.sit_down_s = 0.2;
  Rig rig(c, Reference::Trot(HyqModel(), TrotParams{}));
  (void)rig.Cycle();
  hyq::testing::NoHeapGuard guard;
  rig.seq.Enable(rig.in);
  for (int k = 0; k < 1500; ++k) (void)rig.Cycle();
  (void)rig.seq.RequestSitDown(SitDownCause::kStop, rig.in);
  for (int k = 0; k < 800; ++k) (void)rig.Cycle();
  EXPECT_EQ(guard.allocations(), 0u);
}

}  // namespace
}  // namespace hyq::servo
