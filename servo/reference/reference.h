// Motion references: the base trajectory, the feet (planted or swinging) and, through leg
// inverse kinematics, joint references q_ref, q̇_ref, q̈_ref that are consistent with each other
// (q̇_ref = d/dt q_ref, q̈_ref = d/dt q̇_ref; tests/servo/reference_test.cc checks by finite
// differences), plus the stance flags of the gait schedule.
//
//   stand:        the standing posture, optionally reached from a lower base height
//   trot:         diagonal pairs (lf+rh, rf+lh) in antiphase, Barasuol et al., "A reactive
//                 controller framework for quadrupedal locomotion on challenging terrain",
//                 ICRA 2013: step frequency, step height, stride length, duty factor; steered by
//                 a commanded base velocity (SetVelocity, docs/steering.md): the velocity ramps
//                 to the command within limits, the base pose (x, y, yaw) is its integral, and
//                 each foot lands where the base's hip will be at mid-stance, Raibert's neutral
//                 point (M. Raibert, "Legged Robots That Balance", MIT Press 1986, ch. 2):
//                   p_foothold = p_hip(t_touchdown) + v·T_stance/2                        (1)
//   figure_eight: the body traces a figure eight in the horizontal plane, all feet planted
//
// Contact-aware phases (trot; Sample with FootContacts, TouchdownParams): the gait follows the
// feet's detected contact, not the clock alone. A foot that lands in the second part of its swing
// is a stance foot at once: the swing is dropped and the foot held where the measured joints put
// it (under the reference base). A foot that has not landed when its stance is due keeps reaching
// down, from rest at a bounded speed, and stays out of the stance set until it lands. The next
// swing starts where the foot stood. Each foot reports its takeover, 0 at its touchdown rising to
// 1 over load_ramp_s (JointReference::takeover).
#pragma once

#include <array>
#include <memory>
#include <string>

#include "dynamics/leg_kinematics.h"
#include "hal/config_key.h"
#include "servo/control/controller.h"

namespace hyq::servo {

/// The base's desired motion (world frame; angular quantities in the base frame).
struct BaseReference {
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_W = Eigen::Vector3d::Zero();
  double yaw = 0.0;  // heading; roll and pitch are zero in these references
  double yaw_rate = 0.0;
  double yaw_acc = 0.0;
};

/// Where a foot is in the contact-aware gait.
enum class FootPhase : std::uint8_t {
  kStance,    // in stance (scheduled and down, or standing)
  kSwing,     // swinging as scheduled
  kLanded,    // down before its stance was due: held where it landed
  kReaching,  // its stance is due but it has not landed: reaching down
};
/// "stance", "swing", "landed", "reaching".
const char* ToString(FootPhase p) noexcept;

struct FootReference {
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();  // foot sphere centre
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_W = Eigen::Vector3d::Zero();
  bool stance = true;
  FootPhase phase = FootPhase::kStance;
  double takeover = 1.0;           // JointReference::takeover
  double friction_takeover = 1.0;  // JointReference::friction_takeover
};

/// What the contact-aware gait is told each cycle (the state estimator's): which feet are down,
/// and where a foot that lands is held: horizontally where the measured joints put it under the
/// reference base, at the height the measured base pose and joints put it (so that an error of
/// the trunk's height is not latched into the footholds).
struct FootContacts {
  std::array<double, kNumFeet> probability{};  // P(contact) from each foot's ground force
  std::array<double, kNumFeet> vertical_speed_m_s{};  // each foot's contact point's |v_z|
  dynamics::VectorJ q = dynamics::VectorJ::Zero();        // measured joint angles
  double base_height_m = 0.0;                             // estimated base position z, world
  Eigen::Matrix3d R_WB = Eigen::Matrix3d::Identity();     // estimated base orientation
};

struct ReferenceSample {
  BaseReference base;
  std::array<FootReference, kNumFeet> feet;
  JointReference joints;  // q, q̇, q̈ (12) and the stance flags
  dynamics::IkStatus ik = dynamics::IkStatus::kOk;
};

/// The contact-aware phases of the trot (see the file comment).
struct TouchdownParams {
  bool follow_contact = true;      // false: the clock alone (the stance the schedule says)
  double earliest_landing = 0.5;   // a contact counts as a landing after this fraction of the swing
  // The schedule is the prior of the load's evidence (Bledt et al., "Contact Model Fusion for
  // Event-Based Locomotion in Unstructured Terrains", ICRA 2018): a swing foot is down only on
  // firm evidence, a foot whose stance is due on weaker evidence ...
  double landing_probability = 0.9;
  double due_probability = 0.5;
  // ... and a foot whose stance is due is taken as down for this long before it counts as late
  // (in the stance set in the air: the ID would push it down as if it carried its share)
  double grace_s = 0.0;
  // and a foot is down only if its contact point is not moving up or down (it may slide: on ice
  // a loaded foot does): an impact's force fades through the observer while the foot rebounds
  double still_speed_m_s = 0.3;
  double reach_speed_m_s = 0.2;    // a late foot reaches down at this speed ...
  double reach_ramp_s = 0.05;      // ... reached from rest over this time ...
  double reach_depth_m = 0.06;     // ... down to this far below its foothold at most
  double load_ramp_s = 0.03;       // a landed foot's gains rise from the swing's over this time ...
  // ... and its μ from 0 over this one. Off (0) as shipped: each cycle of the ramp is a Stage I
  // QP with a nearly flat cone, which ran out of its time budget (the 20 s trot: 6 fallbacks
  // with 2 ms, 12 with 5 ms, 221 with 30 ms, none without)
  double mu_ramp_s = 0.0;

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("follow_contact", &follow_contact)
                 .Doc("the gait's phases follow the detected contact (false: the clock alone)"));
    a->Visit(hal::Key("earliest_landing", &earliest_landing).In(0.1, 1.0)
                 .Doc("a contact is a landing after this fraction of the swing"));
    a->Visit(hal::Key("landing_probability", &landing_probability).In(0.01, 0.99)
                 .Doc("a swing foot is down at this contact probability ..."));
    a->Visit(hal::Key("due_probability", &due_probability).In(0.01, 0.99)
                 .Doc("... a foot whose stance is due at this one"));
    a->Visit(hal::Key("grace_s", &grace_s).In(0.0, 0.2).Unit("s")
                 .Doc("a foot whose stance is due counts as down this long before it is late"));
    a->Visit(hal::Key("still_speed_m_s", &still_speed_m_s).In(0.01, 5.0).Unit("m/s")
                 .Doc("a foot is down only when its contact point's |v_z| is below this"));
    a->Visit(hal::Key("reach_speed_m_s", &reach_speed_m_s).In(0.01, 1.0).Unit("m/s")
                 .Doc("a foot not down when its stance is due reaches down at this speed ..."));
    a->Visit(hal::Key("reach_ramp_s", &reach_ramp_s).In(0.001, 1.0).Unit("s")
                 .Doc("... from rest over this time ..."));
    a->Visit(hal::Key("reach_depth_m", &reach_depth_m).In(0.0, 0.2).Unit("m")
                 .Doc("... to at most this far below its foothold"));
    a->Visit(hal::Key("load_ramp_s", &load_ramp_s).In(0.0, 0.5).Unit("s")
                 .Doc("a landed foot's leg takes the stance gains over this time ..."));
    a->Visit(hal::Key("mu_ramp_s", &mu_ramp_s).In(0.0, 0.5).Unit("s")
                 .Doc("... and its μ in Stage I rises from 0 over this one"));
  }
};

struct TrotParams {
  double step_frequency_Hz = 1.4;  // gait cycles per second
  double step_height_m = 0.08;
  double stride_m = 0.14;          // forward distance per gait cycle (speed = stride × frequency)
  double duty_factor = 0.6;        // fraction of the cycle a foot is in stance (0.5 .. 0.95)
  double start_delay_s = 0.5;      // stand still first
  double ramp_s = 1.0;             // speed ramps up smoothly over this time
  // steering (SetVelocity): vx forward, vy left (heading frame), wz yaw rate
  std::array<double, 3> max_velocity{0.4, 0.2, 0.5};      // m/s, m/s, rad/s: commands clamped
  std::array<double, 3> max_acceleration{0.5, 0.3, 0.8};  // m/s², m/s², rad/s²: ramp bound
  TouchdownParams touchdown;

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("step_frequency_Hz", &step_frequency_Hz).In(0.2, 4.0).Unit("Hz")
                 .Doc("gait cycles per second"));
    a->Visit(hal::Key("step_height_m", &step_height_m).In(0.0, 0.2).Unit("m").Doc("swing foot lift"));
    a->Visit(hal::Key("stride_m", &stride_m).In(-0.4, 0.4).Unit("m")
                 .Doc("forward distance per gait cycle (speed = stride × frequency)"));
    a->Visit(hal::Key("duty_factor", &duty_factor).In(0.5, 0.95)
                 .Doc("fraction of the cycle a foot is in stance"));
    a->Visit(hal::Key("start_delay_s", &start_delay_s).In(0.0, 60.0).Unit("s").Doc("stand still first"));
    a->Visit(hal::Key("ramp_s", &ramp_s).In(0.0, 60.0).Unit("s")
                 .Doc("the speed ramps up smoothly over this time"));
    a->Visit(hal::Key("max_velocity", &max_velocity).In(0.0, 1.0).MaxEach({1.0, 0.5, 1.5})
                 .Elements("[vx, vy, wz]").Unit("m/s, m/s, rad/s")
                 .Doc("steering commands are clamped to these"));
    a->Visit(hal::Key("max_acceleration", &max_acceleration).In(0.0, 5.0).MaxEach({5.0, 5.0, 10.0})
                 .Elements("[vx, vy, wz]").Unit("m/s², m/s², rad/s²")
                 .Check([](const std::array<double, 3>& v) -> std::optional<hal::Violation> {
                   for (int i = 0; i < 3; ++i)
                     if (!(v[static_cast<std::size_t>(i)] > 0.0)) return hal::Violation{"a number > 0", i};
                   return std::nullopt;
                 })
                 .Doc("the steering ramps' bound (each > 0)"));
    a->Visit("touchdown", &touchdown);
  }
};

/// A set-velocity command applied at a reference time (a scripted steering for experiments and
/// tests: Reference::SetVelocity at t_s of the reference's clock).
struct TimedVelocity {
  double t_s = 0.0;
  double vx_m_s = 0.0, vy_m_s = 0.0, wz_rad_s = 0.0;
};
inline constexpr std::size_t kMaxTimedVelocities = 8;

/// One axis of the commanded base velocity: a cubic Hermite ramp from (v0, a0) at t0 to v1
/// (zero acceleration) at t0 + T, then v1. Velocity and acceleration are continuous, so q̈_ref is.
struct VelocityRamp {
  double t0 = 0.0, T = 0.0, v0 = 0.0, a0 = 0.0, v1 = 0.0;
  struct Value {
    double v, a, integral;  // velocity, acceleration and ∫ v from t0 to t
  };
  Value At(double t) const noexcept;
  /// From (v0, a0) at t0 to v1 with |a| <= a_max throughout (given |a0| <= a_max):
  ///   T = max(1.5 |v1 − v0| / (a_max − 0.75 |a0|), 0.1 s)
  static VelocityRamp Plan(double t0, double v0, double a0, double v1, double a_max) noexcept;
};

struct FigureEightParams {
  double period_s = 4.0;           // one figure eight
  double amplitude_x_m = 0.06;     // forward-backward
  double amplitude_y_m = 0.04;     // sideways
  double start_delay_s = 0.5;
  double ramp_s = 0.5;             // amplitude envelope

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("period_s", &period_s).In(0.5, 60.0).Unit("s").Doc("one figure eight"));
    a->Visit(hal::Key("amplitude_x_m", &amplitude_x_m).In(0.0, 0.15).Unit("m").Doc("forward-backward"));
    a->Visit(hal::Key("amplitude_y_m", &amplitude_y_m).In(0.0, 0.15).Unit("m").Doc("sideways"));
    a->Visit(hal::Key("start_delay_s", &start_delay_s).In(0.0, 60.0).Unit("s").Doc("stand still first"));
    a->Visit(hal::Key("ramp_s", &ramp_s).In(0.0, 60.0).Unit("s").Doc("amplitude envelope"));
  }
};

class Reference {
 public:
  enum class Kind { kStand, kTrot, kFigureEight };

  /// Stand at the model's standing posture, base height `height_m` (0: the model's).
  static Reference Stand(const dynamics::Model& model, double height_m = 0.0);
  static Reference Trot(const dynamics::Model& model, const TrotParams& p, double height_m = 0.0);
  static Reference FigureEight(const dynamics::Model& model, const FigureEightParams& p,
                               double height_m = 0.0);

  /// The reference at time t (s). The leg IK starts from the previous sample's angles, so call
  /// it with increasing t as a loop does (any t works; the first call starts from standing; a
  /// steered trot sampled before its last command's time restarts, see SetVelocity).
  /// Never allocates.
  void Sample(double t, ReferenceSample* out) noexcept;
  /// As above, the trot's phases following the feet's contact (TouchdownParams; the other
  /// references and follow_contact false: the same as Sample(t, out)). Never allocates.
  void Sample(double t, const FootContacts& contacts, ReferenceSample* out) noexcept;

  /// Trot only (false otherwise): steer the base to (vx, vy) m/s in the heading frame and yaw
  /// rate wz rad/s, each clamped to TrotParams::max_velocity, from the last sampled time on (not
  /// before the trot starts) along acceleration-bounded ramps. A foot already swinging keeps the
  /// foothold chosen at its lift-off. When the reference restarts (Sample at an earlier time, as
  /// on enable) the base starts from rest and ramps to the last command. Never allocates.
  bool SetVelocity(double vx_m_s, double vy_m_s, double wz_rad_s) noexcept;
  /// The commanded velocity after clamping (vx, vy, wz); the default profile's cruise speed until
  /// the first SetVelocity.
  const std::array<double, 3>& commanded_velocity() const noexcept { return target_; }

  Kind kind() const noexcept { return kind_; }
  /// Feet positions of the standing posture relative to the base, base frame.
  const std::array<Eigen::Vector3d, kNumFeet>& nominal_feet_B() const noexcept { return nominal_; }

 private:
  // the base pose (x, y, yaw) of the steered plan, integrated on a fixed grid from its start
  struct PoseCursor {
    long cell = 0;  // whole cells of grid_s integrated from plan_t0_
    Eigen::Vector3d pose = Eigen::Vector3d::Zero();
    double grid_s = 1e-3;
  };
  // a foothold already chosen: leg's stance of gait cycle `cycle`
  struct Foothold {
    double cycle = -1e9;
    Eigen::Vector3d p_W = Eigen::Vector3d::Zero();
  };

  // a leg's stance as it happened (contact-aware phases), for gait cycle `cycle`
  struct LegContact {
    double cycle = -1e9;
    FootPhase phase = FootPhase::kStance;  // kLanded (held at p_W) or kReaching (from p_W)
    Eigen::Vector3d p_W = Eigen::Vector3d::Zero();
    double t0 = 0.0;  // the landing (kLanded) or when the reach began (kReaching)
  };

  Reference(const dynamics::Model& model, Kind kind, double height_m);
  void SampleAt(double t, const FootContacts* contacts, ReferenceSample* out) noexcept;
  void SampleBase(double t, BaseReference* b) noexcept;
  void SampleFeet(double t, const FootContacts* contacts, ReferenceSample* s) noexcept;
  // the contact-aware gait of one leg in stance (frac < D) or swing of cycle n
  void FollowContact(int leg, double t, double n, double frac, const FootContacts& c,
                     const BaseReference& base, FootReference* f) noexcept;
  Eigen::Vector3d MeasuredFoot(int leg, const FootContacts& c, const BaseReference& base) const noexcept;
  Eigen::Vector3d StanceStart(int leg, double cycle) noexcept;  // where a swing from it starts
  void SolveJoints(ReferenceSample* out) noexcept;
  double StanceMid(int leg, double cycle) const noexcept;
  Eigen::Vector3d FootHold(int leg, double cycle) noexcept;  // where a stance foot sits
  Eigen::Vector3d PlanPose(double t, PoseCursor* c) const noexcept;  // x, y, yaw
  void StartPlan(double t0, const std::array<double, 3>& v0, const std::array<double, 3>& a0,
                 const Eigen::Vector3d& pose0) noexcept;

  // quadrature cells of the turning base's position: the base's own, and the coarser one of the
  // footholds' prediction (36 cells to the next mid-stance instead of 360, at a lift-off)
  static constexpr double kGridS = 1e-3, kFootGridS = 1e-2;

  const dynamics::Model* model_;
  dynamics::LegKinematics legs_;
  Kind kind_;
  double height_m_;
  TrotParams trot_;
  FigureEightParams eight_;
  std::array<Eigen::Vector3d, kNumFeet> nominal_;  // base frame, standing posture
  dynamics::VectorJ last_q_;
  // steering: until the first SetVelocity the fixed forward profile (steered_ false)
  bool steered_ = false;
  std::array<double, 3> target_{};                // clamped command vx, vy, wz
  double plan_t0_ = 0.0;                          // when the current ramps began
  Eigen::Vector3d plan_pose0_ = Eigen::Vector3d::Zero();  // x, y, yaw at plan_t0_
  std::array<VelocityRamp, 3> ramps_{};
  PoseCursor base_cursor_, foot_cursor_;
  // footholds fixed before the current plan began (a stance or a swing under way then)
  std::array<double, kNumFeet> frozen_cycle_{};
  std::array<Eigen::Vector3d, kNumFeet> frozen_stance_{}, frozen_next_{};
  std::array<bool, kNumFeet> frozen_has_next_{};
  std::array<std::array<Foothold, 2>, kNumFeet> footholds_{};  // cache: the last two per leg
  std::array<LegContact, kNumFeet> contact_{};  // contact-aware phases: the last stance per leg
  double last_t_ = 0.0;
};

}  // namespace hyq::servo
