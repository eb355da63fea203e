#include "servo/reference/motion_sequencer.h"

#include <algorithm>
#include <cmath>

namespace hyq::servo {
// The phases' handlers and their table (motion_sequencer.h): each returns the next phase.
struct MotionPhaseTable {
  using M = MotionSequencer;
  using EnterFn = void (*)(M&, const MotionInputs&) noexcept;
  using SampleFn = MotionPhase (*)(M&, const MotionInputs&) noexcept;
  using AdvanceFn = MotionPhase (*)(M&, MotionRequests*) noexcept;
  using SitFn = MotionPhase (*)(const M&) noexcept;
  struct Handlers {
    const char* name;
    EnterFn on_enter;    // entering the phase (its clock at 0)
    SampleFn sample;     // the reference stage, every cycle
    AdvanceFn advance;   // the end of an ACTIVE cycle
    SitFn sit;           // a sit-down is pending: where to go now (null: none is taken)
  };
  static const Handlers kTable[kNumMotionPhases];
  static const Handlers& Of(MotionPhase p) noexcept { return kTable[static_cast<std::size_t>(p)]; }

  static void NoEnter(M&, const MotionInputs&) noexcept {}

  // STAND-UP: from the resting posture, every foot on the ground, up to the reference's height
  static void EnterStandUp(M& m, const MotionInputs&) noexcept {
    m.posture_.Start(m.q0_, {true, true, true, true}, m.sample_->base.p_W.z(),
                     m.config_.stand_up_s);
  }

  // REFERENCE: its clock starts; the enable ramp blends from q0 (set by whoever entered)
  static void EnterReference(M& m, const MotionInputs&) noexcept { m.t_ref_ = 0.0; }

  // SIT-DOWN: from the measured posture down to the crouch, the feet of the reference's stance on
  // the ground and the others lowered onto it; the reference's base velocity (a trot's), in the
  // base frame, braked to rest (after a stand-up: none)
  static void EnterSitDown(M& m, const MotionInputs& in) noexcept {
    Eigen::Vector2d v0_B = Eigen::Vector2d::Zero();
    if (m.left_ == MotionPhase::kReference) {
      const BaseReference& b = m.sample_->base;
      const double c = std::cos(b.yaw), s = std::sin(b.yaw);
      v0_B = Eigen::Vector2d(c * b.v_W.x() + s * b.v_W.y(), -s * b.v_W.x() + c * b.v_W.y());
    }
    m.posture_.Start(in.q_rad, m.joints_->stance, m.config_.crouch_height_m,
                     m.config_.sit_down_s, v0_B, 0.4);
  }

  // outside ACTIVE nothing moves: the joint reference keeps its last value
  static MotionPhase SampleRest(M& m, const MotionInputs&) noexcept { return m.phase_; }

  static MotionPhase SamplePosture(M& m, const MotionInputs& in) noexcept {
    if (!in.active) return MotionPhase::kRest;
    m.sample_ok_ = m.posture_.Sample(m.phase_t_, m.joints_);
    // sitting down, a foot being lowered is a stance foot once it is on the ground, not when
    // its lowering's clock ends: short of the ground the IDs would push it down through the air
    // as if it carried its share (the feet that stood when the sit-down began stay in the
    // stance set, as the stand-up's do: their load follows the push). And a foot that carries
    // nothing has its leg's gains where a landed trot foot starts them (JointReference::takeover):
    // the stance gains ring a light leg behind the lag
    if (m.phase_ == MotionPhase::kSitDown && in.contacts != nullptr)
      for (std::size_t f = 0; f < kNumFeet; ++f) {
        if (!m.posture_.starts_on_ground(f) && in.contacts->probability[f] < 0.5)
          m.joints_->stance[f] = false;
        m.joints_->takeover[f] = std::min(m.joints_->takeover[f], in.contacts->probability[f]);
      }
    return m.phase_;
  }

  static MotionPhase SampleReference(M& m, const MotionInputs& in) noexcept {
    if (!in.active) return MotionPhase::kRest;
    if (in.contacts != nullptr)
      m.reference_->Sample(m.t_ref_, *in.contacts, m.sample_);
    else
      m.reference_->Sample(m.t_ref_, m.sample_);
    JointReference& out = *m.joints_;
    const JointReference& r = m.sample_->joints;
    out = r;
    // the enable ramp (1)
    const double T = m.config_.enable_ramp_s;
    if (T > 0.0 && m.t_ref_ < T) {
      const double x = m.t_ref_ / T;
      const double s = x * x * (3.0 - 2.0 * x), sd = 6.0 * x * (1.0 - x) / T;
      const dynamics::VectorJ gap = r.q - m.q0_;
      out.q = m.q0_ + s * gap;
      out.qd = s * r.qd + sd * gap;
      out.qdd = s * r.qdd;
    }
    return m.phase_;
  }

  // after a sit-down the legs fold onto their stops under the sit-down's damping, held until the
  // robot rests: torque off before that would drop it (a fault's damping stays as configured)
  static MotionPhase SampleSettle(M& m, const MotionInputs& in) noexcept {
    if (!in.damping) return m.phase_;
    m.settling_ = !in.damping_cut;
    if (in.cycles_in_mode <= 1) m.settled_s_ = 0.0;
    m.settled_s_ =
        in.fastest_joint_rad_s < m.config_.settle_speed_rad_s ? m.settled_s_ + m.dt_ : 0.0;
    const double in_mode_s = static_cast<double>(in.cycles_in_mode) * m.dt_;
    m.hold_damping_ =
        m.settling_ && m.settled_s_ < M::kSettledS && in_mode_s < m.config_.settle_max_s;
    return m.phase_;
  }

  static MotionPhase Stay(M& m, MotionRequests*) noexcept { return m.phase_; }

  // the end of the stand-up: the enable ramp blends from where it ended to the reference
  static MotionPhase AdvanceStandUp(M& m, MotionRequests*) noexcept {
    m.phase_t_ += m.dt_;
    if (m.phase_t_ < m.posture_.duration_s()) return m.phase_;
    m.q0_ = m.joints_->q;
    return MotionPhase::kReference;
  }

  // the run's duration is reference time: the stand-up and the sit-down come on top
  static MotionPhase AdvanceReference(M& m, MotionRequests* r) noexcept {
    m.t_ref_ += m.dt_;
    const MotionConfig& c = m.config_;
    while (m.steer_next_ < c.steer_count && c.steer[m.steer_next_].t_s <= m.t_ref_ + 1e-9) {
      const TimedVelocity& s = c.steer[m.steer_next_++];
      m.reference_->SetVelocity(s.vx_m_s, s.vy_m_s, s.wz_rad_s);
    }
    if (m.config_.duration_s > 0.0 && m.t_ref_ >= m.config_.duration_s) r->duration_over = true;
    return m.phase_;
  }

  static MotionPhase AdvanceSitDown(M& m, MotionRequests* r) noexcept {
    m.phase_t_ += m.dt_;
    if (m.phase_t_ < m.posture_.duration_s()) return m.phase_;
    r->sit_down_ended = true;
    r->cause = m.sit_cause_;
    return MotionPhase::kSettle;
  }

  static MotionPhase SitAtOnce(const M&) noexcept { return MotionPhase::kSitDown; }

  // a gait's swing foot comes down within half a gait cycle (a foot reaching down late counts:
  // its stance is due, and the sit-down lowers it onto the ground); a reference that never has
  // every foot down still sits after kMaxSitWaitS
  static MotionPhase SitOnceFeetDown(const M& m) noexcept {
    bool all_down = true;
    for (std::size_t f = 0; f < kNumFeet; ++f)
      all_down = all_down && (m.joints_->stance[f] || m.sample_->feet[f].phase == FootPhase::kReaching);
    return all_down || m.sit_wait_s_ >= M::kMaxSitWaitS ? MotionPhase::kSitDown : m.phase_;
  }
};

const MotionPhaseTable::Handlers MotionPhaseTable::kTable[kNumMotionPhases] = {
    // name       on_enter        sample           advance           sit
    {"rest",      NoEnter,        SampleRest,      Stay,             nullptr},
    {"stand-up",  EnterStandUp,   SamplePosture,   AdvanceStandUp,   SitAtOnce},
    {"reference", EnterReference, SampleReference, AdvanceReference, SitOnceFeetDown},
    {"sit-down",  EnterSitDown,   SamplePosture,   AdvanceSitDown,   nullptr},
    {"settle",    NoEnter,        SampleSettle,    Stay,             nullptr},
};

const char* ToString(MotionPhase p) noexcept {
  const auto i = static_cast<std::size_t>(p);
  return i < kNumMotionPhases ? MotionPhaseTable::kTable[i].name : "unknown";
}

MotionSequencer::MotionSequencer(const dynamics::Model& model, Reference* reference,
                                 const MotionConfig& config, double dt, ReferenceSample* sample,
                                 JointReference* joints)
    : reference_(reference),
      posture_(model),
      config_(config),
      dt_(dt),
      sample_(sample),
      joints_(joints) {
  reference_->Sample(0.0, sample_);
  *joints_ = sample_->joints;
}

void MotionSequencer::Enter(MotionPhase next, const MotionInputs& in) noexcept {
  left_ = phase_;
  phase_ = next;
  phase_t_ = 0.0;
  MotionPhaseTable::Of(next).on_enter(*this, in);
}

void MotionSequencer::Enable(const MotionInputs& in) noexcept {
  q0_ = in.q_rad;
  t_ref_ = 0.0;
  steer_next_ = 0;
  sit_pending_ = false;
  sit_wait_s_ = 0.0;
  reference_->Sample(0.0, sample_);
  phase_ = MotionPhase::kRest;
  Enter(config_.stand_up_s > 0.0 ? MotionPhase::kStandUp : MotionPhase::kReference, in);
}

MotionRequests MotionSequencer::RequestSitDown(SitDownCause cause,
                                               const MotionInputs& in) noexcept {
  MotionRequests r;
  if (cause == SitDownCause::kFault) {
    // at once, wherever the feet are (the swing foot is lowered where it is); a fault's sit-down
    // under way goes on (a lost joint's board is off, its joint locked: its leg still carries)
    const bool sitting = phase_ == MotionPhase::kSitDown;
    if (!sitting && MotionPhaseTable::Of(phase_).sit == nullptr) return r;
    const bool news = !sitting || sit_cause_ != SitDownCause::kFault;
    sit_cause_ = SitDownCause::kFault;
    if (!news) return r;
    sit_pending_ = false;
    sit_wait_s_ = 0.0;
    Enter(MotionPhase::kSitDown, in);
    r.sit_down_began = true;
    r.cause = sit_cause_;
    return r;
  }
  if (MotionPhaseTable::Of(phase_).sit == nullptr) return r;
  if (!sit_pending_ || cause == SitDownCause::kStop) sit_cause_ = cause;  // a stop overrides
  sit_pending_ = true;
  TrySitDown(in, &r);
  return r;
}

void MotionSequencer::TrySitDown(const MotionInputs& in, MotionRequests* r) noexcept {
  const MotionPhaseTable::SitFn sit = MotionPhaseTable::Of(phase_).sit;
  if (sit == nullptr || sit(*this) == phase_) return;
  sit_pending_ = false;
  sit_wait_s_ = 0.0;
  Enter(MotionPhase::kSitDown, in);
  r->sit_down_began = true;
  r->cause = sit_cause_;
}

bool MotionSequencer::Sample(const MotionInputs& in) noexcept {
  settling_ = hold_damping_ = false;
  sample_ok_ = true;
  const MotionPhase next = MotionPhaseTable::Of(phase_).sample(*this, in);
  if (next != phase_) Enter(next, in);
  return sample_ok_;
}

MotionRequests MotionSequencer::Advance(const MotionInputs& in) noexcept {
  MotionRequests r;
  if (sit_pending_) {
    sit_wait_s_ += dt_;
    TrySitDown(in, &r);  // the feet of this cycle's reference; the clock below ticks for it too
  }
  const MotionPhase next = MotionPhaseTable::Of(phase_).advance(*this, &r);
  if (next != phase_) Enter(next, in);
  return r;
}

}  // namespace hyq::servo
