// Recursive Newton–Euler inverse dynamics of the floating-base tree, in world coordinates
// [Featherstone 2008, ch. 5, Table 5.1]:
//   A_i = A_parent + S_i v̇_i + V_i ×m S_i v_i       (forward, A_0 includes −g)
//   F_i = I_i A_i + V_i ×* I_i V_i                  (body forces)
//   F_parent += F_i,  τ_i = S_iᵀ F_i                 (backward)
// giving τ = M(q) v̇ + C(q, v) v + g(q). With v̇ = 0 it is the bias force h = C v + g (MuJoCo's
// qfrc_bias). Base entries are the generalized forces of the free joint: world force, then the
// moment about the base origin in the base frame.
#pragma once

#include <array>

#include "dynamics/kinematics.h"

namespace hyq::dynamics {

struct RneaWorkspace {
  std::array<Vector6d, kNumBodies> F_W;
};

/// τ = M v̇ + h. @pre ForwardKinematics() has run for (q, v). Allocates nothing.
void InverseDynamics(const Model& model, const Kinematics& kin, const VectorV& vdot,
                     RneaWorkspace* ws, VectorV* tau);

/// h = C(q, v) v + g(q): gravity, Coriolis and centrifugal forces. Allocates nothing.
void BiasForces(const Model& model, const Kinematics& kin, RneaWorkspace* ws, VectorV* h);

}  // namespace hyq::dynamics
