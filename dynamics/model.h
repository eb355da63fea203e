// The HyQ rigid-body model: fixed-size, built once at configuration time from the URDF
// (dynamics/urdf_loader.h), then shared read-only by every algorithm in this folder.
//
// Generalized coordinates (docs/conventions.md; MuJoCo's free-joint convention):
//   q (19) = [ p_WB_W (3) | quaternion R_WB (w, x, y, z) | 12 joint angles, rad ]
//   v (18) = [ v_WB_W (3, base origin velocity in world) | w_WB_B (3, base angular velocity in
//              the base frame) | 12 joint rates, rad/s ]
//   joint order: lf, rf, lh, rh legs, each haa, hfe, kfe.
// Spatial vectors are [angular; linear], expressed in world coordinates at the world origin.
#pragma once

#include <array>
#include <stdexcept>
#include <string>

#include <Eigen/Core>

namespace hyq::dynamics {

inline constexpr int kNumLegs = 4;
inline constexpr int kNumFeet = 4;
inline constexpr int kJointsPerLeg = 3;
inline constexpr int kNumJoints = 12;
inline constexpr int kNumBaseDofs = 6;
inline constexpr int kNq = 19;
inline constexpr int kNv = 18;
inline constexpr int kNumBodies = 13;  // trunk + 3 links per leg
inline constexpr int kTrunk = 0;

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using VectorQ = Eigen::Matrix<double, kNq, 1>;
using VectorV = Eigen::Matrix<double, kNv, 1>;
using VectorJ = Eigen::Matrix<double, kNumJoints, 1>;
using MatrixV = Eigen::Matrix<double, kNv, kNv>;
using FootJacobian = Eigen::Matrix<double, 3, kNv>;

enum class Leg : int { kLF = 0, kRF = 1, kLH = 2, kRH = 3 };
inline constexpr std::array<const char*, kNumLegs> kLegNames = {"lf", "rf", "lh", "rh"};
inline constexpr std::array<const char*, kJointsPerLeg> kLegJointNames = {"haa", "hfe", "kfe"};

/// Index of joint k (0 haa, 1 hfe, 2 kfe) of a leg among the 12 joints.
constexpr int JointIndex(int leg, int k) { return kJointsPerLeg * leg + k; }
/// Index of that joint's link among the bodies (0 is the trunk).
constexpr int BodyOfJoint(int joint) { return 1 + joint; }
/// Its index in v (and one less than its index in q).
constexpr int VIndexOfJoint(int joint) { return kNumBaseDofs + joint; }
constexpr int QIndexOfJoint(int joint) { return kNumBaseDofs + 1 + joint; }

/// Thrown at configuration time when a model file is missing, malformed or not HyQ-shaped. The
/// message names the file, the element, what was expected and what was found.
class ModelError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Mass properties of one body, in its own frame B.
struct RigidBodyInertia {
  double mass = 0.0;
  Eigen::Vector3d p_BoBcm_B = Eigen::Vector3d::Zero();  // centre of mass
  Eigen::Matrix3d I_Bcm_B = Eigen::Matrix3d::Zero();    // rotational inertia about the COM
};

/// A body of the tree. Its frame is its joint's frame (URDF convention); the joint rotates the
/// body about axis_B by q relative to the joint's placement in the parent at q = 0.
struct Body {
  std::string name;
  int parent = -1;                                       // -1 for the trunk (floating base)
  Eigen::Matrix3d R_PJ = Eigen::Matrix3d::Identity();    // joint placement in the parent
  Eigen::Vector3d p_PJ_P = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_B = Eigen::Vector3d::UnitZ();     // unit joint axis
  RigidBodyInertia inertia;                              // fixed children lumped in
};

/// A frame fixed to a body (feet, IMU).
struct FixedFrame {
  std::string name;
  int body = kTrunk;
  Eigen::Matrix3d R_BF = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p_BF_B = Eigen::Vector3d::Zero();
};

struct FootFrame : FixedFrame {
  double radius_m = 0.0;  // contact sphere, centred on the frame origin
};

struct JointLimits {
  double lower_rad = 0.0;
  double upper_rad = 0.0;
  double velocity_rad_s = 0.0;
  double effort_Nm = 0.0;
};

/// Read-only after construction. Strings are for reports only; algorithms use indices.
struct Model {
  std::string source;                                // file the model came from
  std::array<Body, kNumBodies> bodies;
  std::array<std::string, kNumJoints> joint_names;
  std::array<JointLimits, kNumJoints> limits;
  std::array<FootFrame, kNumFeet> feet;               // lf, rf, lh, rh
  FixedFrame imu;
  VectorJ q_standing = VectorJ::Zero();              // joint angles of the standing posture
  double standing_base_height_m = 0.0;               // base z with the feet on the ground
  Eigen::Vector3d gravity_W{0.0, 0.0, -9.81};

  double TotalMass() const;
  /// q of the standing posture: base at (0, 0, standing height), identity orientation.
  VectorQ StandingQ() const;
};

}  // namespace hyq::dynamics
