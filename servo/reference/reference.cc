#include "servo/reference/reference.h"

#include <algorithm>
#include <cmath>

namespace hyq::servo {
namespace {

// smoothstep of order 5 and its derivatives: s(0) = 0, s(1) = 1, zero 1st and 2nd derivative at
// both ends (the minimum-jerk profile)
struct Smooth {
  double s, ds, dds;
};
Smooth MinJerk(double x) {
  if (x <= 0.0) return {0.0, 0.0, 0.0};
  if (x >= 1.0) return {1.0, 0.0, 0.0};
  const double x2 = x * x, x3 = x2 * x;
  return {x3 * (10 - 15 * x + 6 * x2), 30 * x2 * (1 - 2 * x + x2), 60 * x * (1 - 3 * x + 2 * x2)};
}

// 64 s³(1 − s)³: 0 at both ends with zero slope and curvature, 1 at s = ½
Smooth Bump(double x) {
  if (x <= 0.0 || x >= 1.0) return {0.0, 0.0, 0.0};
  const double u = x * (1 - x), du = 1 - 2 * x, ddu = -2;
  return {64 * u * u * u, 192 * u * u * du, 192 * (2 * u * du * du + u * u * ddu)};
}

constexpr std::array<double, kNumFeet> kTrotOffset{0.0, 0.5, 0.5, 0.0};  // lf, rf, lh, rh

}  // namespace

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
}

Reference Reference::Stand(const dynamics::Model& model, double height_m) {
  return Reference(model, Kind::kStand, height_m);
}

Reference Reference::Trot(const dynamics::Model& model, const TrotParams& p, double height_m) {
  Reference r(model, Kind::kTrot, height_m);
  r.trot_ = p;
  r.trot_.duty_factor = std::clamp(p.duty_factor, 0.5, 0.95);
  return r;
}

Reference Reference::FigureEight(const dynamics::Model& model, const FigureEightParams& p,
                                 double height_m) {
  Reference r(model, Kind::kFigureEight, height_m);
  r.eight_ = p;
  return r;
}

void Reference::SampleBase(double t, BaseReference* b) const noexcept {
  *b = BaseReference{};
  b->p_W.z() = height_m_;
  if (kind_ == Kind::kTrot) {
    // speed v·s((t − t0)/T); position is its integral (closed form of the quintic's integral)
    const double v = trot_.stride_m * trot_.step_frequency_Hz, T = trot_.ramp_s;
    const double tau = (t - trot_.start_delay_s) / T;
    if (tau <= 0.0) return;
    if (tau < 1.0) {
      const Smooth s = MinJerk(tau);
      const double t2 = tau * tau, t4 = t2 * t2;
      b->p_W.x() = v * T * (2.5 * t4 - 3 * t4 * tau + t4 * t2);
      b->v_W.x() = v * s.s;
      b->a_W.x() = v * s.ds / T;
    } else {
      b->p_W.x() = v * T * 0.5 + v * (t - trot_.start_delay_s - T);
      b->v_W.x() = v;
    }
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

// Trot: the n-th stance of a leg starts at (n − offset)/f and lasts D/f; its foothold is under
// the nominal foot at mid-stance. Before the trot starts every foot stands at its nominal spot.
Eigen::Vector3d Reference::FootHold(int leg, double t_mid) const noexcept {
  BaseReference b;
  SampleBase(t_mid, &b);
  Eigen::Vector3d p = b.p_W + nominal_[leg];
  p.z() = model_->feet[leg].radius_m;
  return p;
}

void Reference::SampleFeet(double t, ReferenceSample* s) const noexcept {
  for (int leg = 0; leg < kNumFeet; ++leg) {
    FootReference& f = s->feet[leg];
    f = FootReference{};
    if (kind_ != Kind::kTrot || t < trot_.start_delay_s) {
      f.p_W = nominal_[leg];
      f.p_W.z() = model_->feet[leg].radius_m;
      if (kind_ == Kind::kTrot) f.p_W = FootHold(leg, 0.0);
      continue;
    }
    const double freq = trot_.step_frequency_Hz, D = trot_.duty_factor;
    const double tt = t - trot_.start_delay_s;           // gait time
    const double phase = freq * tt + kTrotOffset[leg];   // cycles, this leg
    const double n = std::floor(phase);                  // cycle index
    const double frac = phase - n;
    // the foothold of a cycle's stance is taken at mid-stance; a stance that began by the start
    // keeps the foot where it stood
    const auto stance_mid = [&](double cycle) {
      const double touchdown = trot_.start_delay_s + (cycle - kTrotOffset[leg]) / freq;
      return touchdown <= trot_.start_delay_s ? 0.0 : touchdown + 0.5 * D / freq;
    };
    if (frac < D) {  // stance of cycle n
      f.stance = true;
      f.p_W = FootHold(leg, stance_mid(n));
    } else {         // swing from cycle n's foothold to cycle n+1's
      f.stance = false;
      const Eigen::Vector3d from = FootHold(leg, stance_mid(n));
      const Eigen::Vector3d to = FootHold(leg, stance_mid(n + 1));
      const double Ts = (1.0 - D) / freq;  // swing duration
      const double x = (frac - D) / (1.0 - D);
      const Smooth h = MinJerk(x), z = Bump(x);
      f.p_W = from + h.s * (to - from);
      f.v_W = h.ds / Ts * (to - from);
      f.a_W = h.dds / (Ts * Ts) * (to - from);
      f.p_W.z() += trot_.step_height_m * z.s;
      f.v_W.z() += trot_.step_height_m * z.ds / Ts;
      f.a_W.z() += trot_.step_height_m * z.dds / (Ts * Ts);
    }
  }
}

void Reference::Sample(double t, ReferenceSample* out) noexcept {
  SampleBase(t, &out->base);
  SampleFeet(t, out);
  out->ik = dynamics::IkStatus::kOk;
  // foot relative to the base, base frame (the base does not rotate in these references):
  // p_rel = R_yawᵀ (p_F − p_B), and its derivatives
  const double c = std::cos(out->base.yaw), s = std::sin(out->base.yaw);
  Eigen::Matrix3d Rt;
  Rt << c, s, 0, -s, c, 0, 0, 0, 1;
  for (int leg = 0; leg < kNumFeet; ++leg) {
    const FootReference& f = out->feet[leg];
    dynamics::FootMotion m;
    m.p_BF_B = Rt * (f.p_W - out->base.p_W);
    m.v_BF_B = Rt * (f.v_W - out->base.v_W);
    m.a_BF_B = Rt * (f.a_W - out->base.a_W);
    dynamics::LegJointMotion j;
    const dynamics::IkStatus st = legs_.Solve(leg, m, last_q_.segment<3>(3 * leg), &j);
    if (st != dynamics::IkStatus::kOk && out->ik == dynamics::IkStatus::kOk) out->ik = st;
    out->joints.q.segment<3>(3 * leg) = j.q;
    out->joints.qd.segment<3>(3 * leg) = j.qd;
    out->joints.qdd.segment<3>(3 * leg) = j.qdd;
    out->joints.stance[leg] = f.stance;
  }
  last_q_ = out->joints.q;
}

}  // namespace hyq::servo
