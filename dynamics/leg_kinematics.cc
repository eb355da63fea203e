#include "dynamics/leg_kinematics.h"

#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/LU>

namespace hyq::dynamics {

const char* ToString(IkStatus s) noexcept {
  switch (s) {
    case IkStatus::kOk: return "ok";
    case IkStatus::kNotConverged: return "not_converged";
    case IkStatus::kSingular: return "singular";
    case IkStatus::kOutOfLimits: return "out_of_limits";
  }
  return "unknown";
}

LegKinematics::LegKinematics(const Model& model) : model_(model) {}

Eigen::Vector3d LegKinematics::Foot(int leg, const Eigen::Vector3d& q, Eigen::Matrix3d* J,
                                    const Eigen::Vector3d* qd,
                                    Eigen::Vector3d* Jdot_qd, Eigen::Matrix3d* Jw) const noexcept {
  // the chain trunk → hip → upper → lower with the base at the origin (world = B)
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  std::array<Eigen::Vector3d, 3> axis, origin;
  for (int k = 0; k < kJointsPerLeg; ++k) {
    const Body& b = model_.bodies[BodyOfJoint(JointIndex(leg, k))];
    p += R * b.p_PJ_P;
    R = R * b.R_PJ;
    axis[k] = R * b.axis_B;
    origin[k] = p;
    R = R * Eigen::AngleAxisd(q(k), b.axis_B).toRotationMatrix();
  }
  const FootFrame& foot = model_.feet[leg];
  const Eigen::Vector3d p_F = p + R * foot.p_BF_B;
  if (J != nullptr)
    for (int k = 0; k < 3; ++k) J->col(k) = axis[k].cross(p_F - origin[k]);
  if (Jw != nullptr)
    for (int k = 0; k < 3; ++k) Jw->col(k) = axis[k];
  if (qd != nullptr && Jdot_qd != nullptr) {
    // d/dt (a_k × (p − o_k)) with ȧ_k = ω_{k−1} × a_k (ω_{k−1}: the body carrying axis k) and
    // ȯ_k = Σ_{j<k} a_j × (o_k − o_j) q̇_j
    Eigen::Vector3d w = Eigen::Vector3d::Zero();  // angular velocity of the body before joint k
    std::array<Eigen::Vector3d, 3> w_before;
    for (int k = 0; k < 3; ++k) {
      w_before[k] = w;
      w += axis[k] * (*qd)(k);
    }
    Eigen::Vector3d v_F = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) v_F += axis[k].cross(p_F - origin[k]) * (*qd)(k);
    Jdot_qd->setZero();
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d adot = w_before[k].cross(axis[k]);
      Eigen::Vector3d odot = Eigen::Vector3d::Zero();
      for (int j = 0; j < k; ++j) odot += axis[j].cross(origin[k] - origin[j]) * (*qd)(j);
      *Jdot_qd += (adot.cross(p_F - origin[k]) + axis[k].cross(v_F - odot)) * (*qd)(k);
    }
  }
  return p_F;
}

IkStatus LegKinematics::Solve(int leg, const FootMotion& foot, const Eigen::Vector3d& guess,
                              LegJointMotion* out) const noexcept {
  Eigen::Vector3d q = guess;
  Eigen::Matrix3d J;
  bool converged = false;
  for (int it = 0; it < 50; ++it) {
    const Eigen::Vector3d err = foot.p_BF_B - Foot(leg, q, &J);
    if (err.norm() < 1e-12) {
      converged = true;
      break;
    }
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(J);
    if (lu.rank() < 3) return IkStatus::kSingular;
    Eigen::Vector3d step = lu.solve(err);
    const double n = step.norm();
    if (n > 0.3) step *= 0.3 / n;  // keep Newton inside its basin
    q += step;
  }
  if (!converged) return IkStatus::kNotConverged;
  (void)Foot(leg, q, &J);
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(J);
  if (lu.rank() < 3) return IkStatus::kSingular;
  out->q = q;
  out->qd = lu.solve(foot.v_BF_B);
  Eigen::Vector3d Jdot_qd;
  (void)Foot(leg, q, nullptr, &out->qd, &Jdot_qd);
  out->qdd = lu.solve(foot.a_BF_B - Jdot_qd);
  for (int k = 0; k < 3; ++k) {
    const auto& lim = model_.limits[JointIndex(leg, k)];
    if (q(k) < lim.lower_rad || q(k) > lim.upper_rad) return IkStatus::kOutOfLimits;
  }
  return IkStatus::kOk;
}

}  // namespace hyq::dynamics
