// Composite-rigid-body algorithm: the joint-space inertia matrix of the floating-base tree,
//   M(i, j) = S_iᵀ Ic_b(j) S_j   for dof i on body b(i) an ancestor of (or equal to) b(j)     (1)
// where Ic_b is the composite inertia of the subtree rooted at b, all in world coordinates
// about the world origin [Featherstone 2008, ch. 6, eq 6.15, in a common frame].
#pragma once

#include <array>

#include "dynamics/kinematics.h"

namespace hyq::dynamics {

struct CrbaWorkspace {
  std::array<SpatialInertia, kNumBodies> Ic_W;
};

/// @pre ForwardKinematics() has run for this q. M is symmetric, positive definite, with zero
/// blocks between different legs. Allocates nothing (tests/dynamics/dynamics_test.cc).
void Crba(const Model& model, const Kinematics& kin, CrbaWorkspace* ws, MatrixV* M);

}  // namespace hyq::dynamics
