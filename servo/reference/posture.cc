#include "servo/reference/posture.h"

#include <algorithm>
#include <cmath>

#include "servo/reference/min_jerk.h"

namespace hyq::servo {
namespace {

constexpr double kOnGroundTolerance_m = 0.01;
constexpr double kTakeoverS = 0.03;  // a lowered foot's takeover (JointReference::takeover)

}  // namespace

PostureMove::PostureMove(const dynamics::Model& model) : model_(model), legs_(model) {}

void PostureMove::Start(const dynamics::VectorJ& q, const std::array<bool, kNumFeet>& on_ground,
                        double h1_m, double duration_s, const Eigen::Vector2d& v0_B,
                        double lower_fraction) noexcept {
  std::array<Eigen::Vector3d, kNumFeet> p_BF;
  double h0 = 0.0;
  int n = 0;
  for (int leg = 0; leg < kNumFeet; ++leg) {
    const auto l = static_cast<std::size_t>(leg);
    p_BF[l] = legs_.Foot(leg, q.segment<3>(3 * leg));
    if (on_ground[l]) {
      h0 += model_.feet[l].radius_m - p_BF[l].z();  // base height that puts this foot on z = r
      ++n;
    }
  }
  if (n == 0) {  // no foot down: the lowest one is
    double lowest = p_BF[0].z();
    for (const auto& p : p_BF) lowest = std::min(lowest, p.z());
    h0 = model_.feet[0].radius_m - lowest;
    n = 1;
  } else {
    h0 /= n;
  }
  h0_m_ = h0;
  h1_m_ = h1_m;
  duration_s_ = std::max(duration_s, 1e-3);
  lower_s_ = std::clamp(lower_fraction, 0.05, 1.0) * duration_s_;
  brake_s_ = std::min(duration_s_, 0.3);
  v0_B_ = v0_B.allFinite() ? v0_B : Eigen::Vector2d::Zero();
  for (int leg = 0; leg < kNumFeet; ++leg) {
    const auto l = static_cast<std::size_t>(leg);
    p_WF0_[l] = Eigen::Vector3d(0.0, 0.0, h0) + p_BF[l];
    on_ground_[l] = p_WF0_[l].z() < model_.feet[l].radius_m + kOnGroundTolerance_m;
  }
  last_q_ = q;
}

bool PostureMove::Sample(double t, JointReference* out) noexcept {
  // base: (0, 0, h(t)), level, minimum jerk from h0 to h1
  const Smooth b = MinJerk(t / duration_s_);
  const double dh = h1_m_ - h0_m_;
  Eigen::Vector3d p_B(0.0, 0.0, h0_m_ + dh * b.s);
  Eigen::Vector3d v_B(0.0, 0.0, dh * b.ds / duration_s_);
  Eigen::Vector3d a_B(0.0, 0.0, dh * b.dds / (duration_s_ * duration_s_));
  // braking: x(s) = v0 T (s − s³ + s⁴/2), s = t / T, T = brake_s_
  const double s = std::min(t / brake_s_, 1.0), T = brake_s_;
  const double xs = s - s * s * s + 0.5 * s * s * s * s, dxs = 1 - 3 * s * s + 2 * s * s * s,
               ddxs = -6 * s + 6 * s * s;
  p_B.head<2>() = v0_B_ * T * xs;
  v_B.head<2>() = v0_B_ * dxs;
  a_B.head<2>() = v0_B_ * ddxs / T;
  // feet: in place; each one onto the ground (z = r) in the first lower_s_ seconds
  const Smooth f = MinJerk(t / lower_s_);
  bool ok = true;
  for (int leg = 0; leg < kNumFeet; ++leg) {
    const auto l = static_cast<std::size_t>(leg);
    const double dz = model_.feet[l].radius_m - p_WF0_[l].z();
    Eigen::Vector3d p_F = p_WF0_[l], v_F = Eigen::Vector3d::Zero(), a_F = Eigen::Vector3d::Zero();
    p_F.z() += dz * f.s;
    v_F.z() = dz * f.ds / lower_s_;
    a_F.z() = dz * f.dds / (lower_s_ * lower_s_);
    dynamics::FootMotion m;
    m.p_BF_B = p_F - p_B;
    m.v_BF_B = v_F - v_B;
    m.a_BF_B = a_F - a_B;
    dynamics::LegJointMotion j;
    const dynamics::IkStatus st = legs_.Solve(leg, m, last_q_.segment<3>(3 * leg), &j);
    if (st == dynamics::IkStatus::kOutOfLimits) {
      // low down a foot that stood wide (a trot's swing foot) can ask for more than a joint's
      // range: the joint stays at its stop, the others follow
      for (int k = 0; k < 3; ++k) {
        const auto& lim = model_.limits[static_cast<std::size_t>(3 * leg + k)];
        if (j.q(k) < lim.lower_rad || j.q(k) > lim.upper_rad) {
          j.q(k) = std::clamp(j.q(k), lim.lower_rad, lim.upper_rad);
          j.qd(k) = 0.0;
          j.qdd(k) = 0.0;
        }
      }
    }
    if (st == dynamics::IkStatus::kOk || st == dynamics::IkStatus::kOutOfLimits) {
      out->q.segment<3>(3 * leg) = j.q;
      out->qd.segment<3>(3 * leg) = j.qd;
      out->qdd.segment<3>(3 * leg) = j.qdd;
    } else {
      ok = false;
      out->q.segment<3>(3 * leg) = last_q_.segment<3>(3 * leg);
      out->qd.segment<3>(3 * leg).setZero();
      out->qdd.segment<3>(3 * leg).setZero();
    }
    // a lowered foot carries weight once it is down, taking over as a landed trot foot does
    out->stance[l] = on_ground_[l] || t >= lower_s_;
    out->takeover[l] = on_ground_[l] ? 1.0 : std::clamp((t - lower_s_) / kTakeoverS, 0.0, 1.0);
    out->friction_takeover[l] = 1.0;
  }
  last_q_ = out->q;
  last_p_B_ = p_B;
  return ok;
}

}  // namespace hyq::servo
