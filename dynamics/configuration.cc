#include "dynamics/configuration.h"

#include <Eigen/Geometry>

namespace hyq::dynamics {

VectorQ Integrate(const VectorQ& q, const VectorV& v, double dt) {
  VectorQ out = q;
  out.head<3>() += v.head<3>() * dt;
  const Eigen::Vector3d rot = v.segment<3>(3) * dt;
  const double angle = rot.norm();
  Eigen::Quaterniond dq = Eigen::Quaterniond::Identity();
  if (angle > 0.0) dq = Eigen::Quaterniond(Eigen::AngleAxisd(angle, rot / angle));
  const Eigen::Quaterniond q0(q(3), q(4), q(5), q(6));
  const Eigen::Quaterniond q1 = (q0 * dq).normalized();
  out.segment<4>(3) << q1.w(), q1.x(), q1.y(), q1.z();
  out.tail<kNumJoints>() += v.tail<kNumJoints>() * dt;
  return out;
}

VectorV Difference(const VectorQ& q0, const VectorQ& q1, double dt) {
  VectorV v;
  v.head<3>() = (q1.head<3>() - q0.head<3>()) / dt;
  const Eigen::Quaterniond a(q0(3), q0(4), q0(5), q0(6));
  const Eigen::Quaterniond b(q1(3), q1(4), q1(5), q1(6));
  Eigen::Quaterniond d = a.normalized().conjugate() * b.normalized();
  if (d.w() < 0.0) d.coeffs() = -d.coeffs();  // shortest rotation
  const Eigen::AngleAxisd aa(d);
  v.segment<3>(3) = aa.axis() * aa.angle() / dt;
  v.tail<kNumJoints>() = (q1.tail<kNumJoints>() - q0.tail<kNumJoints>()) / dt;
  return v;
}

}  // namespace hyq::dynamics
