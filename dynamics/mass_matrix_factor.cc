#include "dynamics/mass_matrix_factor.h"

#include "dynamics/small_cholesky.h"

namespace hyq::dynamics {
namespace {
constexpr int kB = kNumBaseDofs;
constexpr int kL = kJointsPerLeg;
}  // namespace

FactorStatus FactorMassMatrix(const MatrixV& M, MassMatrixFactor* out) {
  // joints first, one leg at a time: C_l = L Lᵀ,  Y_l = B_l C_l⁻¹,  Ā = A − Σ Y_l B_lᵀ
  Matrix6d Abar = M.topLeftCorner<kB, kB>();
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const int o = kB + kL * leg;
    Eigen::Matrix3d L = M.block<kL, kL>(o, o);
    if (!CholeskyInPlace(L)) return FactorStatus::kNotPositiveDefinite;
    InverseFromCholesky<kL>(L, &out->C_inv[leg]);
    const auto B_l = M.block<kB, kL>(0, o);
    out->Y.middleCols<kL>(kL * leg).noalias() = B_l * out->C_inv[leg];
    Abar.noalias() -= out->Y.middleCols<kL>(kL * leg) * B_l.transpose();
  }
  if (!CholeskyInPlace(Abar)) return FactorStatus::kNotPositiveDefinite;
  InverseFromCholesky<kB>(Abar, &out->Abar_inv);
  out->L_A = M.topLeftCorner<kB, kB>();
  if (!CholeskyInPlace(out->L_A)) return FactorStatus::kNotPositiveDefinite;
  return FactorStatus::kOk;
}

void SolveInPlace(const MassMatrixFactor& f, VectorV* b) {
  // x_b = D (b_b − Y b_q),   x_q = C⁻¹ b_q − Yᵀ x_b
  Vector6d rhs = b->head<kB>();
  rhs.noalias() -= f.Y * b->tail<kNumJoints>();
  const Vector6d x_b = f.Abar_inv * rhs;
  for (int leg = 0; leg < kNumLegs; ++leg) {
    auto b_l = b->segment<kL>(kB + kL * leg);
    const Eigen::Vector3d c = f.C_inv[leg] * b_l;
    b_l = c - f.Y.middleCols<kL>(kL * leg).transpose() * x_b;
  }
  b->head<kB>() = x_b;
}

void ComputeMinvBlocks(const MassMatrixFactor& f, MinvBlocks* out) {
  // D = Ā⁻¹,  E = −D Y   (14)
  out->D = f.Abar_inv;
  out->E.noalias() = -out->D * f.Y;
  // F = C⁻¹ + Yᵀ D Y = C⁻¹ − Yᵀ E
  out->F.noalias() = -f.Y.transpose() * out->E;
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const int o = kL * leg;
    out->F.block<kL, kL>(o, o) += f.C_inv[leg];
  }
}

void ComputeInverseBlocks(const MatrixV& M, const MassMatrixFactor& f, InverseBlocks* out) {
  const auto B = M.topRightCorner<kB, kNumJoints>();
  InverseFromCholesky<kB>(f.L_A, &out->A_inv);
  // A⁻¹ B, and F⁻¹ = C − Bᵀ A⁻¹ B (Schur complement of A), its lower triangle mirrored
  out->A_inv_B.noalias() = out->A_inv * B;
  for (int c = 0; c < kNumJoints; ++c) {
    const Vector6d ab = out->A_inv_B.col(c);
    for (int r = c; r < kNumJoints; ++r)
      out->F_inv(r, c) = out->F_inv(c, r) = M(kB + r, kB + c) - B.col(r).dot(ab);
  }
}

}  // namespace hyq::dynamics
