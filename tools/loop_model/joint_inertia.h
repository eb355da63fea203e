// The inertia one joint's feedback loop acts on, from the robot's joint-space inertia M(q)
// (CRBA, dynamics/crba.h) and the feet's Jacobians J (dynamics/kinematics.h):
//
//   swing leg:  I_j = M_jj                                                            (1)
//     the diagonal of the leg's fixed-base inertia (the joint-joint block of the floating
//     base's M is the fixed-base leg's): the other joints of the leg held by their own loops.
//   stance:     I_j = 1 / [M⁻¹ − M⁻¹Jᵀ (J M⁻¹ Jᵀ)⁻¹ J M⁻¹]_jj                          (2)
//     the floating base with the stance feet's centres fixed (J: their 3 × 18 Jacobians
//     stacked): the bracket is the constrained system's response q̈ = Λ τ to a joint torque
//     [Featherstone 2008, ch. 8, eq. 8.20, the constrained inverse inertia], so (2) is the
//     inertia a torque on j alone meets while the base and the other joints move as the
//     contacts let them (their torques zero).
//   free leg:   I_j = 1 / (M⁻¹)_jj                                                    (3)
//     (1)'s counterpart with the leg's other joints free; (3) ≤ (1), bracketing the swing case.
//
// And the torques that hold a posture still, for the actuators' operating point:
//   g(q) = Sᵀ τ + Jᵀ f:  f = (J_bᵀ)⁺ g_b (the base rows; least norm),  τ = g_j − J_jᵀ f      (4)
// with g = h(q, 0) (dynamics/rnea.h); without stance feet τ = g_j.
#pragma once

#include <array>

#include "dynamics/model.h"

namespace hyq::loop_model {

using StanceSet = std::array<bool, dynamics::kNumFeet>;

/// (1) for every joint at the posture q (only the joint angles matter).
dynamics::VectorJ SwingInertia(const dynamics::Model& model, const dynamics::VectorQ& q);
/// (3) for every joint: each leg's fixed-base block inverted.
dynamics::VectorJ FreeLegInertia(const dynamics::Model& model, const dynamics::VectorQ& q);
/// (2) for every joint with the feet in `stance` fixed (the joints of the other legs too: they
/// swing with the base held by the stance feet). Throws std::invalid_argument when no foot is
/// in stance or J M⁻¹ Jᵀ is singular.
dynamics::VectorJ StanceInertia(const dynamics::Model& model, const dynamics::VectorQ& q,
                                const StanceSet& stance);
/// (4): the joint torques (N·m) that hold the posture q still on the feet in `stance`.
dynamics::VectorJ HoldingTorque(const dynamics::Model& model, const dynamics::VectorQ& q,
                                const StanceSet& stance);

}  // namespace hyq::loop_model
