// Forward kinematics of the floating-base tree: poses, motion subspaces, spatial velocities and
// velocity-product accelerations of every body, and the foot kinematics built on them.
#pragma once

#include <array>

#include "dynamics/model.h"
#include "dynamics/spatial.h"

namespace hyq::dynamics {

/// Output of ForwardKinematics. All quantities in world coordinates, spatial ones about the
/// world origin ([angular; linear]).
struct Kinematics {
  std::array<Eigen::Matrix3d, kNumBodies> R_WB;
  std::array<Eigen::Vector3d, kNumBodies> p_WB_W;
  /// Column d: the spatial motion produced by a unit v(d). Base columns 0–2 are [0; e_k]
  /// (world translation), 3–5 are [a; p_WB × a] with a = R_WB e_k (rotation about the base
  /// origin, base-frame axes); joint columns are [a; p × a] for joint axis a through point p.
  Eigen::Matrix<double, 6, kNv> S_W;
  std::array<Vector6d, kNumBodies> V_WB;      // body spatial velocity
  std::array<Vector6d, kNumBodies> A_vp_WB;   // spatial acceleration when v̇ = 0 and g = 0
  std::array<SpatialInertia, kNumBodies> I_W;  // body inertia about the world origin
};

/// Poses, S, velocities and velocity-product accelerations for (q, v). The quaternion q(3:7) is
/// normalized internally. Allocates nothing.
void ForwardKinematics(const Model& model, const VectorQ& q, const VectorV& v, Kinematics* kin);

/// Kinematics of the foot frames (centres of the foot spheres).
struct FootKinematics {
  std::array<Eigen::Vector3d, kNumFeet> p_WF_W;     // position
  std::array<Eigen::Vector3d, kNumFeet> v_WF_W;     // velocity,  = J v
  std::array<Eigen::Vector3d, kNumFeet> Jdot_v_W;   // J̇ v: foot acceleration when v̇ = 0
  std::array<FootJacobian, kNumFeet> J_WF;          // 3 × 18, world-aligned: v_WF_W = J v
  std::array<FootJacobian, kNumFeet> Jw_WF;         // angular: w_WF_W = Jw v (the lower leg's)
  std::array<Eigen::Vector3d, kNumFeet> Jwdot_v_W;  // J̇w v: angular acceleration when v̇ = 0
};

/// The Jacobian and J̇v of the contact point of foot f's sphere on a surface with unit normal n
/// (world): c = p_WF − r n and w × (−r n) = r n × w, so J_c = J + r [n]× Jw and
/// J̇_c v = J̇v + r n × J̇w v (n fixed in the world). Rolling moves
/// the contact point relative to the sphere's centre; this is the velocity that slips.
void ContactPointJacobian(const Model& model, const FootKinematics& feet, int f,
                          const Eigen::Vector3d& n_W, FootJacobian* J_c,
                          Eigen::Vector3d* Jdot_c_v);

/// Foot positions, velocities, world-aligned 3 × 18 Jacobians and J̇v from a completed
/// ForwardKinematics. Column d of J is S_lin(d) + S_ang(d) × p_WF for the foot's ancestor dofs
/// and zero for the other legs' joints. Allocates nothing.
void ComputeFootKinematics(const Model& model, const Kinematics& kin, FootKinematics* feet);

}  // namespace hyq::dynamics
