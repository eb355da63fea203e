// The motion phases around ACTIVE: a const table of phases {on_enter, sample, advance, sit}, each
// handler returning the next phase, in the manner of hal/device_state_machine.cc (lely
// src/co/nmt.c). The loop (servo/runtime/servo_loop.h) samples it in its reference stage, ticks
// its clock at the end of each ACTIVE cycle and relays what it asks (MotionRequests) to the safety
// state machine, which alone decides the mode.
//
//   phase      on_enter           sample (every cycle)       advance (end of an     sit (a sit-down
//                                                           ACTIVE cycle)          is pending)
//   REST       -                  holds still                -                      ignored
//   STAND-UP   posture move up    the move; not ACTIVE: REST stand_up_s: REFERENCE  SIT-DOWN
//   REFERENCE  reference clock 0  reference and ramp (1);    the clock; duration_s: SIT-DOWN once
//                                 not ACTIVE: REST           asks for a stop        every foot down
//   SIT-DOWN   posture move down  the move; not ACTIVE: REST sit_down_s: SETTLE,    ignored
//                                                           asks for stop or damp
//   SETTLE     -                  DAMPING: the sit-down's    -                      ignored
//                                 damping and its hold
//   Enable (the mode became ACTIVE), from any phase: STAND-UP when stand_up_s > 0, else REFERENCE.
//
//   REST       outside ACTIVE: the reference holds still (the joint reference keeps its last value)
//   STAND-UP   PostureMove (posture.h) from the posture measured at enable, every foot on the
//              ground, up to the reference's base height in stand_up_s
//   REFERENCE  the reference at its own clock (reference time, 0 at the phase's start), blended
//              from the posture the phase began in (q0) by the enable ramp over enable_ramp_s:
//                q_ref = q0 + s(x) (q_r − q0),  s(x) = 3x² − 2x³,  x = t / enable_ramp_s   (1)
//              (q̇_ref by the product rule; q̈_ref = s q̈_r)
//   SIT-DOWN   PostureMove from the measured posture down to crouch_height_m in sit_down_s, the
//              reference's stance feet on the ground, its base velocity braked to rest; after a
//              fault at once, every leg in it (a lost joint's board is off: its joint locked)
//   SETTLE     after a sit-down, until the next enable: while the safety state machine damps (not
//              a fault's cut) the damping is the sit-down's, held until every joint has been slower
//              than settle_speed_rad_s for kSettledS, at most settle_max_s
//
// A sit-down asked for in STAND-UP starts at once; in REFERENCE it waits until the reference has
// every foot on the ground (a trot: within half a gait cycle), at the latest kMaxSitWaitS. A stop
// overrides a pending disable. Nothing here allocates after construction.
#pragma once

#include <cstdint>

#include "servo/control/controller.h"
#include "servo/reference/posture.h"
#include "servo/reference/reference.h"

namespace hyq::servo {

enum class MotionPhase : std::uint8_t { kRest, kStandUp, kReference, kSitDown, kSettle };
inline constexpr int kNumMotionPhases = 5;
/// "rest", "stand-up", "reference", "sit-down", "settle".
const char* ToString(MotionPhase p) noexcept;

/// Why the robot sits down, and so what follows the sit-down.
enum class SitDownCause : std::uint8_t {
  kStop,     // a controlled stop: damping, then STOPPED
  kDisable,  // a disable: damping, then STANDBY at 0 N·m
  kFault,    // a fault's controlled or degraded stop (servo/runtime/stop_class.h): at once;
             // damping, then FAULT
};

/// The durations and limits of the phases (0 s turns a posture move off).
struct MotionConfig {
  double stand_up_s = 0.0;
  double sit_down_s = 0.0;
  double crouch_height_m = 0.36;       // the base height a sit-down ends at
  double enable_ramp_s = 0.5;          // (1)
  double duration_s = 0.0;             // reference time after which a stop is asked for; 0: never
  double settle_speed_rad_s = 0.05;    // SETTLE: a joint slower than this rests
  double settle_max_s = 5.0;           // SETTLE: the longest hold of the damping
  std::array<TimedVelocity, kMaxTimedVelocities> steer{};  // in increasing t_s ...
  std::size_t steer_count = 0;         // ... this many
};

/// What the sequencer is told on each call: the mode of the safety state machine and the
/// measured joints.
struct MotionInputs {
  bool active = false;                 // the mode is ACTIVE
  bool damping = false;                // the mode is DAMPING ...
  bool damping_cut = false;            // ... a fault's, at once, without a sit-down
  std::uint64_t cycles_in_mode = 0;    // cycles in the current mode (this one counted)
  dynamics::VectorJ q_rad = dynamics::VectorJ::Zero();  // measured joint positions
  double fastest_joint_rad_s = 0.0;    // the fastest joint's speed; infinite when one is unknown
  /// The feet's detected contact for the reference's contact-aware phases (Reference::Sample);
  /// null: the gait's clock alone.
  const FootContacts* contacts = nullptr;
};

/// What the sequencer asks of the safety state machine (the loop relays it, in this order).
struct MotionRequests {
  bool sit_down_began = false;         // record it: "sitting down to the crouch first"
  bool sit_down_ended = false;         // stop (kStop) or damp (kDisable) now
  SitDownCause cause = SitDownCause::kStop;  // of the sit-down that began or ended
  bool duration_over = false;          // a controlled stop: duration_s of reference time passed
};

class MotionSequencer {
 public:
  static constexpr double kMaxSitWaitS = 1.0;  // longest wait for every foot to be down
  static constexpr double kSettledS = 0.2;     // SETTLE: how long every joint must rest

  /// `reference` (steered by commands) is not owned. The sequencer writes the reference stage's
  /// output into `*sample` (the reference's, REFERENCE only) and `*joints` (the joint reference
  /// the controller tracks; not owned, kept by the caller) and samples the reference at t = 0
  /// into both now. `dt`: the period.
  MotionSequencer(const dynamics::Model& model, Reference* reference, const MotionConfig& config,
                  double dt, ReferenceSample* sample, JointReference* joints);

  /// The mode became ACTIVE: the reference restarts at t = 0; STAND-UP from the measured posture
  /// when stand_up_s > 0, else REFERENCE ramping from it.
  void Enable(const MotionInputs& in) noexcept;
  /// A controlled stop or a disable while ACTIVE (the caller checks sits_down()): SIT-DOWN now or
  /// once every foot is down. Ignored while sitting down already. A fault (kFault) sits down at
  /// once from the feet where they are (a later fault lets it go on); it overrides a stop's or a
  /// disable's cause.
  MotionRequests RequestSitDown(SitDownCause cause, const MotionInputs& in) noexcept;
  /// The reference stage, every cycle: writes the joint reference of the phase (nothing outside
  /// ACTIVE), and in SETTLE decides the damping's hold. False when a posture move's inverse
  /// kinematics failed (the previous joint reference stands).
  bool Sample(const MotionInputs& in) noexcept;
  /// The end of an ACTIVE cycle (after the write): the phase clock ticks by dt, a pending
  /// sit-down looks at the feet again, a phase may end.
  MotionRequests Advance(const MotionInputs& in) noexcept;

  MotionPhase phase() const noexcept { return phase_; }
  /// Whether a stop or disable in ACTIVE sits down first.
  bool sits_down() const noexcept { return config_.sit_down_s > 0.0; }
  /// The reference's clock (REFERENCE time since the phase began; kept outside it).
  double reference_time_s() const noexcept { return t_ref_; }
  /// This cycle's damping is the sit-down's (SETTLE, damping not for a fault), per Sample.
  bool settling() const noexcept { return settling_; }
  /// DAMPING must not end on its timer yet (SETTLE: the joints not at rest), per Sample.
  bool holds_damping() const noexcept { return hold_damping_; }
  /// A sit-down waits for the feet.
  bool sit_down_pending() const noexcept { return sit_pending_; }

 private:
  friend struct MotionPhaseTable;  // the phases' handlers (motion_sequencer.cc)

  void Enter(MotionPhase next, const MotionInputs& in) noexcept;
  void TrySitDown(const MotionInputs& in, MotionRequests* r) noexcept;

  Reference* reference_;
  PostureMove posture_;
  MotionConfig config_;
  double dt_;
  ReferenceSample* sample_;
  JointReference* joints_;
  MotionPhase phase_ = MotionPhase::kRest;
  MotionPhase left_ = MotionPhase::kRest;  // the phase before the current one
  double phase_t_ = 0.0;                   // time in the current phase (STAND-UP, SIT-DOWN)
  double t_ref_ = 0.0;                     // the reference's clock
  dynamics::VectorJ q0_ = dynamics::VectorJ::Zero();  // where the enable ramp (1) starts
  bool sit_pending_ = false;
  SitDownCause sit_cause_ = SitDownCause::kStop;
  double sit_wait_s_ = 0.0;
  double settled_s_ = 0.0;                 // SETTLE: how long every joint has been at rest
  bool settling_ = false, hold_damping_ = false;
  bool sample_ok_ = true;
  std::size_t steer_next_ = 0;  // the first scripted command not yet applied
};

}  // namespace hyq::servo
