// Spatial algebra in one common frame (world coordinates, about the world origin), following
// Featherstone, "Rigid Body Dynamics Algorithms" (2008), ch. 2, with [angular; linear] ordering.
// Motion vectors V = [w; v_O], force vectors F = [n_O; f].
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynamics/model.h"

namespace hyq::dynamics {

/// Skew-symmetric matrix: Skew(a) b = a × b.
inline Eigen::Matrix3d Skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d s;
  s << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return s;
}

/// Motion cross product V ×m U  (Featherstone eq 2.31).
inline Vector6d CrossMotion(const Vector6d& V, const Vector6d& U) {
  Vector6d out;
  out.head<3>() = V.head<3>().cross(U.head<3>());
  out.tail<3>() = V.tail<3>().cross(U.head<3>()) + V.head<3>().cross(U.tail<3>());
  return out;
}

/// Force cross product V ×* F  (Featherstone eq 2.32).
inline Vector6d CrossForce(const Vector6d& V, const Vector6d& F) {
  Vector6d out;
  out.head<3>() = V.head<3>().cross(F.head<3>()) + V.tail<3>().cross(F.tail<3>());
  out.tail<3>() = V.head<3>().cross(F.tail<3>());
  return out;
}

/// Spatial inertia about the world origin in compact form: mass m, first moment h = m c, and
/// rotational inertia about the origin I_O = I_cm + m [c]×[c]×ᵀ  (Featherstone eq 2.63).
struct SpatialInertia {
  double m = 0.0;
  Eigen::Vector3d h = Eigen::Vector3d::Zero();
  Eigen::Matrix3d I_O = Eigen::Matrix3d::Zero();

  /// Momentum of a body moving with V: [I_O w + h × v; m v − h × w].
  Vector6d operator*(const Vector6d& V) const {
    const auto w = V.head<3>();
    const auto v = V.tail<3>();
    Vector6d out;
    out.head<3>() = I_O * w + h.cross(v);
    out.tail<3>() = m * v - h.cross(w);
    return out;
  }
  SpatialInertia& operator+=(const SpatialInertia& o) {
    m += o.m;
    h += o.h;
    I_O += o.I_O;
    return *this;
  }
};

/// A body's inertia placed in the world by its pose (R_WB, p_WB).
inline SpatialInertia ToWorld(const RigidBodyInertia& b, const Eigen::Matrix3d& R_WB,
                              const Eigen::Vector3d& p_WB) {
  const Eigen::Vector3d c = p_WB + R_WB * b.p_BoBcm_B;
  SpatialInertia out;
  out.m = b.mass;
  out.h = b.mass * c;
  // I_O = R I_cm Rᵀ + m ([c]×[c]×ᵀ) = R I_cm Rᵀ + m (|c|² 1 − c cᵀ)
  out.I_O.noalias() = R_WB * b.I_Bcm_B * R_WB.transpose();
  out.I_O += b.mass * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
  return out;
}

}  // namespace hyq::dynamics
