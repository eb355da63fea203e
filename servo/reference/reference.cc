#include "servo/reference/reference.h"

#include <algorithm>
#include <cmath>

#include "servo/reference/min_jerk.h"

namespace hyq::servo {
namespace {

// 64 s³(1 − s)³: 0 at both ends with zero slope and curvature, 1 at s = ½
Smooth Bump(double x) {
  if (x <= 0.0 || x >= 1.0) return {0.0, 0.0, 0.0};
  const double u = x * (1 - x), du = 1 - 2 * x, ddu = -2;
  return {64 * u * u * u, 192 * u * u * du, 192 * (2 * u * du * du + u * u * ddu)};
}

constexpr std::array<double, kNumFeet> kTrotOffset{0.0, 0.5, 0.5, 0.0};  // lf, rf, lh, rh

// R_z(yaw) applied to (x, y)
Eigen::Vector2d Rotate(double yaw, double x, double y) {
  const double c = std::cos(yaw), s = std::sin(yaw);
  return {c * x - s * y, s * x + c * y};
}

}  // namespace

// cubic Hermite basis h00, h10, h01, their derivatives and integrals from 0 to s
VelocityRamp::Value VelocityRamp::At(double t) const noexcept {
  if (t >= t0 + T) return {v1, 0.0, T * (0.5 * v0 + T * a0 / 12.0 + 0.5 * v1) + v1 * (t - t0 - T)};
  if (t < t0) return {v0, a0, v0 * (t - t0)};
  const double s = (t - t0) / T, s2 = s * s, s3 = s2 * s, s4 = s3 * s;
  const double ta0 = T * a0;
  const double v = (2 * s3 - 3 * s2 + 1) * v0 + (s3 - 2 * s2 + s) * ta0 + (-2 * s3 + 3 * s2) * v1;
  const double a = ((6 * s2 - 6 * s) * v0 + (3 * s2 - 4 * s + 1) * ta0 + (-6 * s2 + 6 * s) * v1) / T;
  const double integral =
      T * ((0.5 * s4 - s3 + s) * v0 + (0.25 * s4 - 2.0 / 3.0 * s3 + 0.5 * s2) * ta0 +
           (-0.5 * s4 + s3) * v1);
  return {v, a, integral};
}

// a(s) = (Δv/T)·6s(1 − s) + a0·(1 − s)(1 − 3s): with T from (2) |a| <= a_max on [0, 1]
VelocityRamp VelocityRamp::Plan(double t0, double v0, double a0, double v1, double a_max) noexcept {
  a0 = std::clamp(a0, -a_max, a_max);
  const double T = std::max(1.5 * std::abs(v1 - v0) / (a_max - 0.75 * std::abs(a0)), 0.1);
  return {t0, T, v0, a0, v1};
}

Reference::Reference(const dynamics::Model& model, Kind kind, double height_m)
    : model_(&model),
      legs_(model),
      kind_(kind),
      height_m_(height_m > 0 ? height_m : model.standing_base_height_m),
      last_q_(model.q_standing) {
  for (int leg = 0; leg < kNumFeet; ++leg)
    nominal_[leg] = legs_.Foot(leg, model.q_standing.segment<3>(3 * leg));
  // feet on the ground at the requested height: keep their horizontal placement
  for (auto& p : nominal_) p.z() = -height_m_ + model.feet[0].radius_m;
  frozen_cycle_.fill(-1e9);
}

Reference Reference::Stand(const dynamics::Model& model, double height_m) {
  return Reference(model, Kind::kStand, height_m);
}

Reference Reference::Trot(const dynamics::Model& model, const TrotParams& p, double height_m) {
  Reference r(model, Kind::kTrot, height_m);
  r.trot_ = p;
  r.trot_.duty_factor = std::clamp(p.duty_factor, 0.5, 0.95);
  r.target_ = {p.stride_m * p.step_frequency_Hz, 0.0, 0.0};
  return r;
}

Reference Reference::FigureEight(const dynamics::Model& model, const FigureEightParams& p,
                                 double height_m) {
  Reference r(model, Kind::kFigureEight, height_m);
  r.eight_ = p;
  return r;
}

namespace {

// the fixed forward profile: speed v·s((t − t0)/T); position its integral (closed form of the
// quintic's integral)
void DefaultTrotBase(const TrotParams& p, double t, BaseReference* b) {
  const double v = p.stride_m * p.step_frequency_Hz, T = p.ramp_s;
  const double tau = (t - p.start_delay_s) / T;
  if (tau <= 0.0) return;
  if (tau < 1.0) {
    const Smooth s = MinJerk(tau);
    const double t2 = tau * tau, t4 = t2 * t2;
    b->p_W.x() = v * T * (2.5 * t4 - 3 * t4 * tau + t4 * t2);
    b->v_W.x() = v * s.s;
    b->a_W.x() = v * s.ds / T;
  } else {
    b->p_W.x() = v * T * 0.5 + v * (t - p.start_delay_s - T);
    b->v_W.x() = v;
  }
}

}  // namespace

// The steered base: yaw(t) = yaw0 + ∫ wz in closed form; (x, y) = ∫ R_z(yaw) (vx, vy) by Simpson's
// rule on the cursor's cells from the plan's start (the same cells whatever the calls' times), the
// cursor moving a cell at a time either way.
Eigen::Vector3d Reference::PlanPose(double t, PoseCursor* c) const noexcept {
  const auto yaw_at = [&](double tau) { return plan_pose0_.z() + ramps_[2].At(tau).integral; };
  if (ramps_[2].v0 == 0.0 && ramps_[2].a0 == 0.0 && ramps_[2].v1 == 0.0) {  // heading fixed
    const Eigen::Vector2d d =
        Rotate(plan_pose0_.z(), ramps_[0].At(t).integral, ramps_[1].At(t).integral);
    return {plan_pose0_.x() + d.x(), plan_pose0_.y() + d.y(), plan_pose0_.z()};
  }
  if (t <= plan_t0_) return plan_pose0_;
  const auto f = [&](double tau) {
    return Rotate(yaw_at(tau), ramps_[0].At(tau).v, ramps_[1].At(tau).v);
  };
  const auto simpson = [&](double a, double b) -> Eigen::Vector2d {
    return (b - a) / 6.0 * (f(a) + 4.0 * f(0.5 * (a + b)) + f(b));
  };
  const double h = c->grid_s;
  const long cell = static_cast<long>(std::floor((t - plan_t0_) / h));
  while (c->cell < cell) {
    const double a = plan_t0_ + static_cast<double>(c->cell) * h;
    c->pose.head<2>() += simpson(a, a + h);
    ++c->cell;
  }
  while (c->cell > cell) {
    --c->cell;
    const double a = plan_t0_ + static_cast<double>(c->cell) * h;
    c->pose.head<2>() -= simpson(a, a + h);
  }
  const double a = plan_t0_ + static_cast<double>(cell) * h;
  const Eigen::Vector2d xy = c->pose.head<2>() + simpson(a, t);
  return {xy.x(), xy.y(), yaw_at(t)};
}

void Reference::StartPlan(double t0, const std::array<double, 3>& v0,
                          const std::array<double, 3>& a0, const Eigen::Vector3d& pose0) noexcept {
  steered_ = true;
  plan_t0_ = t0;
  plan_pose0_ = pose0;
  for (std::size_t i = 0; i < 3; ++i)
    ramps_[i] = VelocityRamp::Plan(t0, v0[i], a0[i], target_[i], trot_.max_acceleration[i]);
  base_cursor_ = PoseCursor{0, pose0, kGridS};
  foot_cursor_ = PoseCursor{0, pose0, kFootGridS};
  for (auto& cache : footholds_) cache = {};
}

bool Reference::SetVelocity(double vx_m_s, double vy_m_s, double wz_rad_s) noexcept {
  if (kind_ != Kind::kTrot) return false;
  const std::array<double, 3> command{vx_m_s, vy_m_s, wz_rad_s};
  for (std::size_t i = 0; i < 3; ++i) {
    const double lim = trot_.max_velocity[i];
    target_[i] = std::isfinite(command[i]) ? std::clamp(command[i], -lim, lim) : 0.0;
  }
  // the motion now (not before the trot starts), in the heading frame
  const double t0 = std::max(last_t_, trot_.start_delay_s);
  std::array<double, 3> v{}, a{};
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();
  if (steered_) {
    for (std::size_t i = 0; i < 3; ++i) {
      const VelocityRamp::Value r = ramps_[i].At(t0);
      v[i] = r.v;
      a[i] = r.a;
    }
    pose = PlanPose(t0, &base_cursor_);
  } else {
    BaseReference b;
    DefaultTrotBase(trot_, t0, &b);
    v[0] = b.v_W.x();
    a[0] = b.a_W.x();
    pose.x() = b.p_W.x();
  }
  // footholds chosen under the old plan: the stance under way, and the landing of a swing
  std::array<double, kNumFeet> cycle{};
  std::array<Eigen::Vector3d, kNumFeet> stance{}, landing{};
  std::array<bool, kNumFeet> swinging{};
  for (int leg = 0; leg < kNumFeet; ++leg) {
    const auto l = static_cast<std::size_t>(leg);
    const double phase = trot_.step_frequency_Hz * (t0 - trot_.start_delay_s) + kTrotOffset[l];
    cycle[l] = std::floor(phase);
    stance[l] = FootHold(leg, cycle[l]);
    swinging[l] = phase - cycle[l] >= trot_.duty_factor;
    if (swinging[l]) landing[l] = FootHold(leg, cycle[l] + 1);
  }
  frozen_cycle_ = cycle;
  frozen_stance_ = stance;
  frozen_next_ = landing;
  frozen_has_next_ = swinging;
  StartPlan(t0, v, a, pose);
  return true;
}

void Reference::SampleBase(double t, BaseReference* b) noexcept {
  *b = BaseReference{};
  b->p_W.z() = height_m_;
  if (kind_ == Kind::kTrot && !steered_) {
    DefaultTrotBase(trot_, t, b);
  } else if (kind_ == Kind::kTrot) {
    // v_W = R (vx, vy), a_W = R (ax − wz vy, ay + wz vx): the heading frame turns at wz
    const VelocityRamp::Value vx = ramps_[0].At(t), vy = ramps_[1].At(t), wz = ramps_[2].At(t);
    const Eigen::Vector3d pose = PlanPose(t, &base_cursor_);
    b->p_W.head<2>() = pose.head<2>();
    b->yaw = pose.z();
    b->yaw_rate = wz.v;
    b->yaw_acc = wz.a;
    b->v_W.head<2>() = Rotate(b->yaw, vx.v, vy.v);
    b->a_W.head<2>() = Rotate(b->yaw, vx.a - wz.v * vy.v, vy.a + wz.v * vx.v);
  } else if (kind_ == Kind::kFigureEight) {
    // envelope e(t) times the lemniscate (A sin ωt, B sin 2ωt), t from the start delay
    const double t0 = t - eight_.start_delay_s;
    if (t0 <= 0.0) return;
    const Smooth e = MinJerk(t0 / eight_.ramp_s);
    const double de = e.ds / eight_.ramp_s, dde = e.dds / (eight_.ramp_s * eight_.ramp_s);
    const double w = 2 * M_PI / eight_.period_s;
    const double A = eight_.amplitude_x_m, B = eight_.amplitude_y_m;
    const double fx = A * std::sin(w * t0), dfx = A * w * std::cos(w * t0),
                 ddfx = -A * w * w * std::sin(w * t0);
    const double fy = B * std::sin(2 * w * t0), dfy = 2 * B * w * std::cos(2 * w * t0),
                 ddfy = -4 * B * w * w * std::sin(2 * w * t0);
    b->p_W.x() = e.s * fx;
    b->v_W.x() = de * fx + e.s * dfx;
    b->a_W.x() = dde * fx + 2 * de * dfx + e.s * ddfx;
    b->p_W.y() = e.s * fy;
    b->v_W.y() = de * fy + e.s * dfy;
    b->a_W.y() = dde * fy + 2 * de * dfy + e.s * ddfy;
  }
}

// Trot: the n-th stance of a leg starts at (n − offset)/f and lasts D/f. A stance that began by
// the start keeps the foot where it stood (mid-stance time 0).
double Reference::StanceMid(int leg, double cycle) const noexcept {
  const double freq = trot_.step_frequency_Hz;
  const double touchdown =
      trot_.start_delay_s + (cycle - kTrotOffset[static_cast<std::size_t>(leg)]) / freq;
  return touchdown <= trot_.start_delay_s ? 0.0 : touchdown + 0.5 * trot_.duty_factor / freq;
}

// The foothold of a stance is the nominal foot under the base pose at mid-stance (1), the pose
// predicted from the plan at lift-off: the plan only changes through SetVelocity, which keeps the
// footholds already chosen (frozen_*). Cached: the last two per leg.
Eigen::Vector3d Reference::FootHold(int leg, double cycle) noexcept {
  const auto l = static_cast<std::size_t>(leg);
  if (steered_ && cycle <= frozen_cycle_[l]) return frozen_stance_[l];
  if (steered_ && frozen_has_next_[l] && cycle == frozen_cycle_[l] + 1) return frozen_next_[l];
  auto& cache = footholds_[l];
  for (const Foothold& h : cache)
    if (h.cycle == cycle) return h.p_W;
  const double t_mid = StanceMid(leg, cycle);
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();
  if (steered_) {
    pose = PlanPose(t_mid, &foot_cursor_);
  } else {
    BaseReference b;
    DefaultTrotBase(trot_, t_mid, &b);
    pose.x() = b.p_W.x();
  }
  Eigen::Vector3d p;
  p.head<2>() = pose.head<2>() + Rotate(pose.z(), nominal_[l].x(), nominal_[l].y());
  p.z() = model_->feet[l].radius_m;
  Foothold& slot = cache[0].cycle < cache[1].cycle ? cache[0] : cache[1];
  slot = {cycle, p};
  return p;
}

namespace {

// the swing from `from` to `to` at x ∈ [0, 1] of a swing of Ts seconds: a minimum-jerk path
// with the step height's bump on top; it lands with zero velocity and acceleration
void Swing(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double x, double Ts,
           double height, FootReference* f) {
  f->stance = false;
  f->phase = FootPhase::kSwing;
  const Smooth h = MinJerk(x), z = Bump(x);
  f->p_W = from + h.s * (to - from);
  f->v_W = h.ds / Ts * (to - from);
  f->a_W = h.dds / (Ts * Ts) * (to - from);
  f->p_W.z() += height * z.s;
  f->v_W.z() += height * z.ds / Ts;
  f->a_W.z() += height * z.dds / (Ts * Ts);
}

// a late foot's way down τ s after its stance was due: the speed rises from 0 to V over T
// (smoothstep), then stays, until the depth reaches its bound
struct Reach {
  double depth, speed, acc;
};
Reach ReachDown(const TouchdownParams& p, double tau) {
  if (tau <= 0.0) return {0.0, 0.0, 0.0};
  const double V = p.reach_speed_m_s, T = p.reach_ramp_s, x = tau / T;
  Reach r = x < 1.0 ? Reach{V * T * (x * x * x - 0.5 * x * x * x * x), V * x * x * (3.0 - 2.0 * x),
                            V * 6.0 * x * (1.0 - x) / T}
                    : Reach{V * T * 0.5 + V * (tau - T), V, 0.0};
  if (r.depth >= p.reach_depth_m) r = {p.reach_depth_m, 0.0, 0.0};
  return r;
}

// a landed foot's takeover: smoothstep from 0 at the landing to 1 after the ramp
double Takeover(double since_landing_s, double ramp_s) {
  if (ramp_s <= 0.0 || since_landing_s >= ramp_s) return 1.0;
  const double x = std::max(since_landing_s, 0.0) / ramp_s;
  return x * x * (3.0 - 2.0 * x);
}

}  // namespace

const char* ToString(FootPhase p) noexcept {
  switch (p) {
    case FootPhase::kStance: return "stance";
    case FootPhase::kSwing: return "swing";
    case FootPhase::kLanded: return "landed";
    case FootPhase::kReaching: return "reaching";
  }
  return "unknown";
}

void Reference::SampleFeet(double t, const FootContacts* contacts, ReferenceSample* s) noexcept {
  const bool follow = contacts != nullptr && trot_.touchdown.follow_contact;
  for (int leg = 0; leg < kNumFeet; ++leg) {
    FootReference& f = s->feet[leg];
    f = FootReference{};
    if (kind_ != Kind::kTrot || t < trot_.start_delay_s) {
      f.p_W = nominal_[leg];
      f.p_W.z() = model_->feet[leg].radius_m;
      continue;
    }
    const double freq = trot_.step_frequency_Hz, D = trot_.duty_factor;
    const double tt = t - trot_.start_delay_s;           // gait time
    const double phase = freq * tt + kTrotOffset[leg];   // cycles, this leg
    const double n = std::floor(phase);                  // cycle index
    const double frac = phase - n;
    if (follow) {
      FollowContact(leg, t, n, frac, *contacts, s->base, &f);
    } else if (frac < D) {  // stance of cycle n
      f.p_W = FootHold(leg, n);
    } else {                // swing from cycle n's foothold to cycle n+1's
      Swing(FootHold(leg, n), FootHold(leg, n + 1), (frac - D) / (1.0 - D), (1.0 - D) / freq,
            trot_.step_height_m, &f);
    }
  }
}

// where the measured joints put the foot: horizontally under the reference base (the gait's
// frame), vertically under the estimated base (the ground's height, whatever the trunk's error)
Eigen::Vector3d Reference::MeasuredFoot(int leg, const FootContacts& c,
                                        const BaseReference& base) const noexcept {
  const Eigen::Vector3d p_B = legs_.Foot(leg, c.q.segment<3>(3 * leg));
  Eigen::Vector3d p;
  p.head<2>() = base.p_W.head<2>() + Rotate(base.yaw, p_B.x(), p_B.y());
  p.z() = c.base_height_m + c.R_WB.row(2).dot(p_B);
  return p;
}

// a swing of cycle n starts where the foot stood in that stance: its foothold, where it landed,
// or as far as it had reached down when the stance ended without a landing
Eigen::Vector3d Reference::StanceStart(int leg, double cycle) noexcept {
  const LegContact& lc = contact_[static_cast<std::size_t>(leg)];
  if (lc.cycle != cycle) return FootHold(leg, cycle);
  if (lc.phase != FootPhase::kReaching) return lc.p_W;
  const double freq = trot_.step_frequency_Hz;
  const double lift_off = trot_.start_delay_s +
                          (cycle - kTrotOffset[static_cast<std::size_t>(leg)] + trot_.duty_factor) / freq;
  Eigen::Vector3d p = lc.p_W;
  p.z() -= ReachDown(trot_.touchdown, lift_off - lc.t0).depth;
  return p;
}

void Reference::FollowContact(int leg, double t, double n, double frac, const FootContacts& c,
                              const BaseReference& base, FootReference* f) noexcept {
  const TouchdownParams& td = trot_.touchdown;
  const auto l = static_cast<std::size_t>(leg);
  const double freq = trot_.step_frequency_Hz, D = trot_.duty_factor;
  LegContact& lc = contact_[l];
  const double prob = c.vertical_speed_m_s[l] <= td.still_speed_m_s ? c.probability[l] : 0.0;
  const auto hold = [&](FootPhase phase) {
    f->stance = true;
    f->phase = phase;
    f->p_W = lc.p_W;
    f->takeover = Takeover(t - lc.t0, td.load_ramp_s);
    f->friction_takeover = Takeover(t - lc.t0, td.mu_ramp_s);
  };
  if (frac < D) {  // the stance of cycle n is due
    const double due = trot_.start_delay_s + (n - kTrotOffset[l]) / freq;
    const bool down = prob >= td.due_probability;
    if (lc.cycle != n) {  // due now: at its foothold, and down unless the grace runs out first
      lc = {n, FootPhase::kStance, FootHold(leg, n), due <= trot_.start_delay_s ? -1e9 : due};
    }
    if (lc.phase == FootPhase::kStance) {
      if (down || lc.t0 < trot_.start_delay_s) lc.phase = FootPhase::kLanded;
      else if (t - lc.t0 >= td.grace_s) lc = {n, FootPhase::kReaching, lc.p_W, t};
    } else if (lc.phase == FootPhase::kReaching && down) {
      lc = {n, FootPhase::kLanded, MeasuredFoot(leg, c, base), t};
    }
    if (lc.phase != FootPhase::kReaching) return hold(FootPhase::kStance);
    const Reach r = ReachDown(td, t - lc.t0);
    f->stance = false;
    f->phase = FootPhase::kReaching;
    f->p_W = lc.p_W - r.depth * Eigen::Vector3d::UnitZ();
    f->v_W = -r.speed * Eigen::Vector3d::UnitZ();
    f->a_W = -r.acc * Eigen::Vector3d::UnitZ();
    return;
  }
  // the swing of cycle n towards the stance of n + 1
  const double x = (frac - D) / (1.0 - D);
  if (lc.cycle == n + 1 && lc.phase == FootPhase::kLanded) return hold(FootPhase::kLanded);
  if (prob >= td.landing_probability && x >= td.earliest_landing) {
    lc = {n + 1, FootPhase::kLanded, MeasuredFoot(leg, c, base), t};
    return hold(FootPhase::kLanded);
  }
  Swing(StanceStart(leg, n), FootHold(leg, n + 1), x, (1.0 - D) / freq, trot_.step_height_m, f);
}

void Reference::Sample(double t, ReferenceSample* out) noexcept { SampleAt(t, nullptr, out); }

void Reference::Sample(double t, const FootContacts& contacts, ReferenceSample* out) noexcept {
  SampleAt(t, &contacts, out);
}

void Reference::SampleAt(double t, const FootContacts* contacts, ReferenceSample* out) noexcept {
  // a restart (time going back, as on enable): the contact-aware phases forget their stances;
  // a steered plan restarts from rest to the last command
  if (t < last_t_) contact_.fill(LegContact{});
  if (steered_ && t < last_t_ && t < plan_t0_) {
    frozen_cycle_.fill(-1e9);
    frozen_has_next_.fill(false);
    StartPlan(trot_.start_delay_s, {}, {}, Eigen::Vector3d::Zero());
  }
  last_t_ = t;
  SampleBase(t, &out->base);
  SampleFeet(t, contacts, out);
  SolveJoints(out);
}

void Reference::SolveJoints(ReferenceSample* out) noexcept {
  out->ik = dynamics::IkStatus::kOk;
  // foot relative to the base, base frame (the base turns about z at ω = yaw_rate ẑ):
  //   p_rel = R_yawᵀ (p_F − p_B)
  //   v_rel = R_yawᵀ (v_F − v_B) − ω × p_rel
  //   a_rel = R_yawᵀ (a_F − a_B) − 2 ω × v_rel − ω × (ω × p_rel) − ω̇ × p_rel
  const double c = std::cos(out->base.yaw), s = std::sin(out->base.yaw);
  Eigen::Matrix3d Rt;
  Rt << c, s, 0, -s, c, 0, 0, 0, 1;
  const Eigen::Vector3d w(0, 0, out->base.yaw_rate), dw(0, 0, out->base.yaw_acc);
  for (int leg = 0; leg < kNumFeet; ++leg) {
    const FootReference& f = out->feet[leg];
    dynamics::FootMotion m;
    m.p_BF_B = Rt * (f.p_W - out->base.p_W);
    m.v_BF_B = Rt * (f.v_W - out->base.v_W) - w.cross(m.p_BF_B);
    m.a_BF_B = Rt * (f.a_W - out->base.a_W) - 2.0 * w.cross(m.v_BF_B) -
               w.cross(w.cross(m.p_BF_B)) - dw.cross(m.p_BF_B);
    dynamics::LegJointMotion j;
    const dynamics::IkStatus st = legs_.Solve(leg, m, last_q_.segment<3>(3 * leg), &j);
    if (st != dynamics::IkStatus::kOk && out->ik == dynamics::IkStatus::kOk) out->ik = st;
    out->joints.q.segment<3>(3 * leg) = j.q;
    out->joints.qd.segment<3>(3 * leg) = j.qd;
    out->joints.qdd.segment<3>(3 * leg) = j.qdd;
    out->joints.stance[leg] = f.stance;
    out->joints.takeover[leg] = f.takeover;
    out->joints.friction_takeover[leg] = f.friction_takeover;
  }
  last_q_ = out->joints.q;
}

}  // namespace hyq::servo
