// Everything the controllers need from the rigid-body model, once per servo cycle.
#pragma once

#include <cstdint>

#include "dynamics/crba.h"
#include "dynamics/kinematics.h"
#include "dynamics/mass_matrix_factor.h"
#include "dynamics/rnea.h"

namespace hyq::dynamics {

enum class [[nodiscard]] DynamicsStatus : std::uint8_t {
  kOk,
  kBadInput,             // q or v not finite, or a quaternion of (near) zero norm
  kNotPositiveDefinite,  // M failed to factor (a broken model or a numerical fault)
};

const char* ToString(DynamicsStatus s);

/// One cycle's dynamics and its workspaces, allocated once (construct before the loop).
struct CycleDynamics {
  Kinematics kin;
  FootKinematics feet;
  MatrixV M;             // joint-space inertia (CRBA)
  VectorV bias;          // h = C v + g (RNEA)
  MassMatrixFactor factor;
  InverseBlocks inv;     // A⁻¹, A⁻¹B, F⁻¹ (D, E, F on demand: ComputeMinvBlocks)
  CrbaWorkspace crba_ws;
  RneaWorkspace rnea_ws;
};

/// Forward kinematics, foot positions / velocities / Jacobians / J̇v, M (CRBA), h (RNEA), the
/// factorisation of M and its inverse blocks, for the state (q, v). Never throws or allocates.
DynamicsStatus ComputeCycleDynamics(const Model& model, const VectorQ& q, const VectorV& v,
                                    CycleDynamics* out);

}  // namespace hyq::dynamics
