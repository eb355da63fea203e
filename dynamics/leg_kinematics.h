// Leg kinematics relative to the base (trunk) frame: where each foot is for given joint angles,
// and the inverse: the joint angles, rates and accelerations that put the foot where a
// reference wants it. Built on the project's own model (dynamics/), evaluated with the base at
// the origin, so "world" below is the base frame B.
#pragma once

#include <array>

#include "dynamics/model.h"

namespace hyq::dynamics {

/// A foot point's motion relative to the base, in the base frame.
struct FootMotion {
  Eigen::Vector3d p_BF_B = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_BF_B = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_BF_B = Eigen::Vector3d::Zero();
};

struct LegJointMotion {
  Eigen::Vector3d q = Eigen::Vector3d::Zero();
  Eigen::Vector3d qd = Eigen::Vector3d::Zero();
  Eigen::Vector3d qdd = Eigen::Vector3d::Zero();
};

enum class [[nodiscard]] IkStatus : std::uint8_t { kOk, kNotConverged, kSingular, kOutOfLimits };
const char* ToString(IkStatus s) noexcept;

class LegKinematics {
 public:
  explicit LegKinematics(const Model& model);

  /// Foot sphere centre of `leg` for its three joint angles, in the base frame; J (3 × 3) =
  /// ∂p/∂q, J̇ q̇ when qd is given, and Jw (3 × 3, the joint axes): the lower leg's angular
  /// velocity relative to the base is Jw q̇.
  Eigen::Vector3d Foot(int leg, const Eigen::Vector3d& q, Eigen::Matrix3d* J = nullptr,
                       const Eigen::Vector3d* qd = nullptr, Eigen::Vector3d* Jdot_qd = nullptr,
                       Eigen::Matrix3d* Jw = nullptr) const noexcept;

  /// Inverse kinematics (Newton on the 3 × 3 leg Jacobian, starting from `guess`), then
  /// q̇ = J⁻¹ v and q̈ = J⁻¹ (a − J̇ q̇). kOutOfLimits when the solution leaves the joint limits
  /// (the solution is still returned). Never allocates.
  IkStatus Solve(int leg, const FootMotion& foot, const Eigen::Vector3d& guess,
                 LegJointMotion* out) const noexcept;

 private:
  const Model& model_;
};

}  // namespace hyq::dynamics
