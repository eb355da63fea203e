// Factorisation of the floating-base mass matrix and the blocks of its inverse that the
// contact-aware inverse dynamics needs (Zapolsky et al., eqs 13–16):
//
//   M = [A B; Bᵀ C]  (A: 6 × 6 base, C: 12 × 12 joints)          M⁻¹ = [D E; Eᵀ F]      (13, 14)
//
// C is block diagonal (the legs do not couple through the joints), so the joints are eliminated
// first, leg by leg, with no fill-in (the LTDL idea of Featherstone 2005):
//   Y = B C⁻¹,   Ā = A − Y Bᵀ = D⁻¹ (the articulated-body inertia of the base),
//   D = Ā⁻¹,   E = −D Y,   F = C⁻¹ + Yᵀ D Y,
// and the Schur complement of A gives the inverse of F without inverting F:
//   F⁻¹ = C − Bᵀ A⁻¹ B,   E F⁻¹ = −A⁻¹ B.
// Nothing forms a general 18 × 18 inverse (tests compare every block with one).
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Core>

#include "dynamics/model.h"

namespace hyq::dynamics {

using BaseJointMatrix = Eigen::Matrix<double, kNumBaseDofs, kNumJoints>;
using JointMatrix = Eigen::Matrix<double, kNumJoints, kNumJoints>;

enum class [[nodiscard]] FactorStatus : std::uint8_t { kOk, kNotPositiveDefinite };

/// The factorisation: each leg's 3 × 3 block of C inverted through its Cholesky factor,
/// Y = B C⁻¹, Ā⁻¹ = D through the Cholesky factor of Ā = A − Y Bᵀ, and the Cholesky factor of A.
/// The inverses are explicit because every use applies them to several vectors or needs them
/// as blocks (eq 14), and on 3 × 3 and 6 × 6 fixed-size products beat triangular solves.
struct MassMatrixFactor {
  std::array<Eigen::Matrix3d, kNumLegs> C_inv;  // exactly symmetric
  BaseJointMatrix Y;
  Matrix6d Abar_inv;  // D, exactly symmetric
  Matrix6d L_A;       // A = L_A L_Aᵀ in the lower triangle (dynamics/small_cholesky.h)
};

/// What the contact ID uses every cycle: A⁻¹, A⁻¹B and F⁻¹ (then Z = A⁻¹R_b, E F⁻¹ = −A⁻¹B,
/// and [D E], [Eᵀ F] applied to a vector through SolveInPlace).
struct InverseBlocks {
  Matrix6d A_inv;
  BaseJointMatrix A_inv_B;
  JointMatrix F_inv;
};

/// The blocks of M⁻¹ themselves (eq 14), on demand (tests, tools): not needed per cycle.
struct MinvBlocks {
  Matrix6d D;
  BaseJointMatrix E;
  JointMatrix F;
};

/// Factors M. Returns kNotPositiveDefinite (and leaves `out` unusable) when a pivot fails.
/// Allocates nothing.
FactorStatus FactorMassMatrix(const MatrixV& M, MassMatrixFactor* out);

/// Solves M x = b in place (b ← M⁻¹ b) with a completed factorisation. Allocates nothing.
void SolveInPlace(const MassMatrixFactor& factor, VectorV* b);

/// A⁻¹, A⁻¹B and F⁻¹ from M and its factorisation. Allocates nothing.
void ComputeInverseBlocks(const MatrixV& M, const MassMatrixFactor& factor, InverseBlocks* out);

/// D, E and F (eq 14) from the factorisation. Allocates nothing.
void ComputeMinvBlocks(const MassMatrixFactor& factor, MinvBlocks* out);

}  // namespace hyq::dynamics
