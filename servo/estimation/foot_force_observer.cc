#include "servo/estimation/foot_force_observer.h"

#include <cmath>

#include "dynamics/kinematics.h"
#include "servo/estimation/disturbance_observer.h"

namespace hyq::servo {

FootForceObserver::FootForceObserver(const dynamics::Model& model,
                                     const FootForceObserverConfig& config, double dt)
    : model_(model),
      config_(config),
      dt_(dt),
      gain_(MomentumObserverGain(config.bandwidth_hz, dt)) {
  Reset();
}

void FootForceObserver::Reset() noexcept {
  anchored_ = false;
  r_.setZero();
  s_.setZero();
  for (auto& f : force_W_) f.setZero();
  probability_.fill(0.0);
}

// (2)–(3) of disturbance_observer.h on the legs' rows:
//   s_k = s_{k−1} + (½ (w_k + w_{k−1}) + r_{k−1}) dt + (A_k − A_{k−1}) (v_k + v_{k−1}) / 2
//   r_k = K_d (A_k v_k − s_k),  w = τ − h (legs' rows)
void FootForceObserver::Update(const dynamics::CycleDynamics& dyn, const dynamics::VectorV& v,
                               const dynamics::VectorJ& tau_measured_Nm) noexcept {
  constexpr int kJ = dynamics::kNumJoints;
  const auto A = dyn.M.bottomRows<kJ>();
  const dynamics::VectorJ w = tau_measured_Nm - dyn.bias.tail<kJ>();
  if (!v.allFinite() || !w.allFinite() || !A.allFinite()) {
    anchored_ = false;  // held; restarts at the next finite cycle, keeping r
    return;
  }
  const dynamics::VectorJ p = A * v;
  if (!anchored_) {
    s_ = p - r_ / gain_;  // r kept: r = K_d (p − s)
    anchored_ = true;
  } else {
    s_ += (0.5 * (w + w_prev_) + r_) * dt_ + 0.5 * (A - A_prev_) * (v + v_prev_);
    r_ = gain_ * (p - s_);
  }
  A_prev_ = A;
  w_prev_ = w;
  v_prev_ = v;
  for (int leg = 0; leg < dynamics::kNumFeet; ++leg) {
    const auto f = static_cast<std::size_t>(leg);
    const int col = dynamics::kNumBaseDofs + 3 * leg;
    dynamics::FootJacobian J_c;
    Eigen::Vector3d unused;
    dynamics::ContactPointJacobian(model_, dyn.feet, leg, Eigen::Vector3d::UnitZ(), &J_c, &unused);
    const Eigen::Matrix3d J = J_c.middleCols<3>(col);
    const Eigen::PartialPivLU<Eigen::Matrix3d> lu(J.transpose());
    if (!(std::abs(lu.determinant()) > 1e-9)) continue;  // singular leg: the last estimate holds
    force_W_[f] = lu.solve(r_.segment<3>(3 * leg));
    probability_[f] = 1.0 / (1.0 + std::exp(-(force_W_[f].z() - config_.force_N) / config_.width_N));
  }
}

}  // namespace hyq::servo
