#include "servo/estimation/disturbance_observer.h"

#include <algorithm>
#include <cmath>

#include "dynamics/kinematics.h"

namespace hyq::servo {

DisturbanceObserver::DisturbanceObserver(const dynamics::Model& model,
                                         const DisturbanceObserverConfig& config, double dt)
    : model_(model),
      config_(config),
      dt_(dt),
      gain_(MomentumObserverGain(config.bandwidth_hz, dt)) {}

void DisturbanceObserver::Reset() noexcept {
  held_ = true;
  full_ = {};
  base_ = {};
  d_b_.setZero();
}

template <int N>
bool DisturbanceObserver::MomentumResidual<N>::Step(const Matrix& A, const dynamics::VectorV& v,
                                                    const dynamics::VectorV& v_prev, const Vector& w,
                                                    double gain, double dt) noexcept {
  Vector p;
  p.noalias() = A * v;
  const bool running = anchored;
  if (!running) {
    s = p - r / gain;  // keeps r
  } else {
    // s_k = s_{k−1} + (½ (w_k + w_{k−1}) + r_{k−1}) dt + (A_k − A_{k−1}) (v_k + v_{k−1}) / 2   (2)
    const dynamics::VectorV v_mid = 0.5 * (v + v_prev);
    s.noalias() += (A - A_prev) * v_mid;
    s += (0.5 * (w + w_prev) + r) * dt;
    // r_k = K_d (p_k − s_k)   (3)
    r = gain * (p - s);
  }
  A_prev = A;
  w_prev = w;
  anchored = true;
  return running;
}

// P = [I₆ | −J_f,bᵀ J_f,legᵀ⁻¹ per leg]
bool DisturbanceObserver::Project(const dynamics::CycleDynamics& dyn) noexcept {
  constexpr int nb = dynamics::kNumBaseDofs;
  P_.setZero();
  P_.leftCols<nb>().setIdentity();
  for (int f = 0; f < dynamics::kNumFeet; ++f) {
    dynamics::FootJacobian J;
    Eigen::Vector3d unused;
    dynamics::ContactPointJacobian(model_, dyn.feet, f, Eigen::Vector3d::UnitZ(), &J, &unused);
    const int col = nb + dynamics::kJointsPerLeg * f;
    const Eigen::Matrix3d J_leg = J.middleCols<3>(col);
    const Eigen::PartialPivLU<Eigen::Matrix3d> lu(J_leg.transpose());
    if (!(std::abs(lu.determinant()) > 1e-9)) return false;  // a stretched leg: no force estimate
    P_.middleCols<3>(col).noalias() = -J.leftCols<nb>().transpose() * lu.inverse();
  }
  return true;
}

const DisturbanceObserver::Vector6d& DisturbanceObserver::Update(
    const dynamics::CycleDynamics& dyn, const dynamics::VectorV& v,
    const dynamics::VectorJ& tau_measured_Nm) noexcept {
  // the known generalized force u = Sᵀ τ_m − h
  dynamics::VectorV u = -dyn.bias;
  u.tail<dynamics::kNumJoints>() += tau_measured_Nm;
  if (!v.allFinite() || !u.allFinite() || !dyn.M.allFinite()) {
    held_ = true;
    full_.anchored = base_.anchored = false;
    return d_b_;
  }
  // r: τ_ext, all rows
  (void)full_.Step(dyn.M, v, v_prev_, u, gain_, dt_);
  // r_b: d_b = P τ_ext, from p_b = P M v and P u
  bool running = false;
  if (Project(dyn)) {
    PM_.noalias() = P_ * dyn.M;
    const Vector6d u_b = P_ * u;
    running = base_.Step(PM_, v, v_prev_, u_b, gain_, dt_);
  } else {
    base_.anchored = false;
  }
  v_prev_ = v;
  if (!running) {
    held_ = true;
    return d_b_;
  }
  for (int k = 0; k < 3; ++k) {
    d_b_(k) = std::clamp(base_.r(k), -config_.max_force_N, config_.max_force_N);
    d_b_(k + 3) = std::clamp(base_.r(k + 3), -config_.max_torque_Nm, config_.max_torque_Nm);
  }
  held_ = false;
  return d_b_;
}

}  // namespace hyq::servo
