#include "servo/estimation/disturbance_observer.h"

#include <algorithm>
#include <cmath>

#include "dynamics/kinematics.h"

namespace hyq::servo {

DisturbanceObserver::DisturbanceObserver(const dynamics::Model& model,
                                         const DisturbanceObserverConfig& config, double dt)
    : model_(model),
      config_(config), dt_(dt), alpha_(1.0 - std::exp(-2.0 * M_PI * config.bandwidth_hz * dt)) {}

void DisturbanceObserver::Reset() noexcept {
  started_ = false;
  held_ = true;
  e_.setZero();
  d_b_.setZero();
}

const DisturbanceObserver::Vector6d& DisturbanceObserver::Update(
    const dynamics::CycleDynamics& dyn, const dynamics::VectorV& v,
    const dynamics::VectorJ& tau_measured_Nm) noexcept {
  constexpr int nb = dynamics::kNumBaseDofs;
  if (!started_) {  // no v̇ yet: the filter starts at the first residual
    v_prev_ = v;
    started_ = true;
    return d_b_;
  }
  // e = M v̇ + h − Sᵀ τ_m, v̇ by the difference over the cycle
  dynamics::VectorV raw = dyn.M * ((v - v_prev_) / dt_) + dyn.bias;
  raw.tail<dynamics::kNumJoints>() -= tau_measured_Nm;
  v_prev_ = v;
  if (!raw.allFinite()) {
    held_ = true;
    return d_b_;
  }
  e_ += alpha_ * (raw - e_);
  // every foot's force from its leg's rows, the rest on the trunk
  Vector6d d = e_.head<nb>();
  for (int f = 0; f < dynamics::kNumFeet; ++f) {
    dynamics::FootJacobian J;
    Eigen::Vector3d unused;
    dynamics::ContactPointJacobian(model_, dyn.feet, f, Eigen::Vector3d::UnitZ(), &J, &unused);
    const int col = nb + dynamics::kJointsPerLeg * f;
    const Eigen::Matrix3d J_leg = J.middleCols<3>(col);
    const Eigen::PartialPivLU<Eigen::Matrix3d> lu(J_leg.transpose());
    if (!(std::abs(lu.determinant()) > 1e-9)) {  // a stretched leg: no force estimate
      held_ = true;
      return d_b_;
    }
    const Eigen::Vector3d force = lu.solve(e_.segment<3>(col));
    d.noalias() -= J.leftCols<nb>().transpose() * force;
  }
  for (int k = 0; k < 3; ++k) {
    d_b_(k) = std::clamp(d(k), -config_.max_force_N, config_.max_force_N);
    d_b_(k + 3) = std::clamp(d(k + 3), -config_.max_torque_Nm, config_.max_torque_Nm);
  }
  held_ = false;
  return d_b_;
}

}  // namespace hyq::servo
