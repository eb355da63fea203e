#include "servo/control/pd_gravity.h"

#include <algorithm>

#include <Eigen/Cholesky>

namespace hyq::servo {
namespace {

// Tikhonov weight on the 6 × 6 normal matrix (units m²): small against its entries (~1 for the
// force rows, ~0.1 for the moment rows) so that four feet solve it exactly in effect, and large
// enough that the rank-5 two-foot case stays well conditioned.
constexpr double kDamping = 1e-6;

}  // namespace

PdGravityController::PdGravityController(const PdGains& gains,
                                         const dynamics::VectorJ& effort_limit_Nm)
    : gains_(gains), effort_limit_(effort_limit_Nm) {}

dynamics::VectorJ PdGravityController::Compute(
    const dynamics::CycleDynamics& dyn, const dynamics::VectorV& h, const dynamics::VectorJ& q,
    const dynamics::VectorJ& qd, const dynamics::VectorJ& q_ref, const dynamics::VectorJ& qd_ref,
    const std::array<bool, dynamics::kNumFeet>& stance,
    const dynamics::VectorJ* gain_scale) noexcept {
  constexpr int nb = dynamics::kNumBaseDofs;
  Eigen::Matrix<double, nb, nb> N = kDamping * Eigen::Matrix<double, nb, nb>::Identity();
  bool any = false;
  for (int f = 0; f < dynamics::kNumFeet; ++f) {
    if (!stance[static_cast<std::size_t>(f)]) continue;
    const auto Jb = dyn.feet.J_WF[static_cast<std::size_t>(f)].leftCols<nb>();
    N.noalias() += Jb.transpose() * Jb;
    any = true;
  }
  tau_g_ = h.tail<dynamics::kNumJoints>();
  if (any) {
    const Eigen::Matrix<double, nb, 1> y = N.ldlt().solve(h.head<nb>());
    for (int f = 0; f < dynamics::kNumFeet; ++f) {
      if (!stance[static_cast<std::size_t>(f)]) continue;
      const auto& J = dyn.feet.J_WF[static_cast<std::size_t>(f)];
      const Eigen::Vector3d force = J.leftCols<nb>() * y;
      tau_g_.noalias() -= J.rightCols<dynamics::kNumJoints>().transpose() * force;
    }
  }
  dynamics::VectorJ tau;
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const double s = gain_scale != nullptr ? (*gain_scale)(j) : 1.0;
    const double u = tau_g_(j) + s * (gains_.kp(j) * (q_ref(j) - q(j)) + gains_.kd(j) * (qd_ref(j) - qd(j)));
    tau(j) = std::clamp(u, -effort_limit_(j), effort_limit_(j));
  }
  return tau;
}

}  // namespace hyq::servo
