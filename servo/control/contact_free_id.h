// Contact-free floating-base inverse dynamics: the joint torques that give the desired joint
// accelerations when no contact acts (the paper's f_ID, §2.2). With M = [A B; Bᵀ C] and h the bias,
//   A a_b + B q̈ + h_b = 0                       (the base is free)
//   τ = Bᵀ a_b + C q̈ + h_q
// so a_b = −A⁻¹(B q̈ + h_b) and τ = F⁻¹ q̈ + h_q − (A⁻¹B)ᵀ h_b, with F⁻¹ = C − Bᵀ A⁻¹ B.
#pragma once

#include "dynamics/cycle_dynamics.h"

namespace hyq::servo {

/// f_ID for qdd (12) with the bias forces h (18; the model's dyn.bias, or that bias corrected by
/// an estimated disturbance); *a_base (optional) receives the resulting base acceleration (6).
/// Never allocates.
dynamics::VectorJ ContactFreeId(const dynamics::CycleDynamics& dyn, const dynamics::VectorV& h,
                                const dynamics::VectorJ& qdd,
                                dynamics::Vector6d* a_base = nullptr) noexcept;
/// As above with the model's h = dyn.bias.
inline dynamics::VectorJ ContactFreeId(const dynamics::CycleDynamics& dyn,
                                       const dynamics::VectorJ& qdd,
                                       dynamics::Vector6d* a_base = nullptr) noexcept {
  return ContactFreeId(dyn, dyn.bias, qdd, a_base);
}

}  // namespace hyq::servo
