#include "dynamics/mass_matrix_factor.h"

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
    out->llt_C[leg].compute(M.block<kL, kL>(o, o));
    if (out->llt_C[leg].info() != Eigen::Success) return FactorStatus::kNotPositiveDefinite;
    const auto B_l = M.block<kB, kL>(0, o);
    // Y_l = B_l C_l⁻¹  ⇔  C_l Y_lᵀ = B_lᵀ
    out->Y.middleCols<kL>(kL * leg) = out->llt_C[leg].solve(B_l.transpose()).transpose();
    Abar.noalias() -= out->Y.middleCols<kL>(kL * leg) * B_l.transpose();
  }
  out->llt_Abar.compute(Abar);
  if (out->llt_Abar.info() != Eigen::Success) return FactorStatus::kNotPositiveDefinite;
  out->llt_A.compute(M.topLeftCorner<kB, kB>());
  if (out->llt_A.info() != Eigen::Success) return FactorStatus::kNotPositiveDefinite;
  return FactorStatus::kOk;
}

void SolveInPlace(const MassMatrixFactor& f, VectorV* b) {
  // x_b = D (b_b − Y b_q),   x_q = C⁻¹ b_q − Yᵀ x_b
  Vector6d rhs = b->head<kB>();
  rhs.noalias() -= f.Y * b->tail<kNumJoints>();
  const Vector6d x_b = f.llt_Abar.solve(rhs);
  for (int leg = 0; leg < kNumLegs; ++leg) {
    auto b_l = b->segment<kL>(kB + kL * leg);
    const Eigen::Vector3d c = f.llt_C[leg].solve(Eigen::Vector3d(b_l));
    b_l = c - f.Y.middleCols<kL>(kL * leg).transpose() * x_b;
  }
  b->head<kB>() = x_b;
}

void ComputeMinvBlocks(const MassMatrixFactor& f, MinvBlocks* out) {
  // D = Ā⁻¹,  E = −D Y   (14)
  out->D = f.llt_Abar.solve(Matrix6d::Identity());
  out->E.noalias() = -out->D * f.Y;
  // F = C⁻¹ + Yᵀ D Y = C⁻¹ − Yᵀ E
  out->F.noalias() = -f.Y.transpose() * out->E;
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const int o = kL * leg;
    out->F.block<kL, kL>(o, o) += f.llt_C[leg].solve(Eigen::Matrix3d::Identity());
  }
}

void ComputeInverseBlocks(const MatrixV& M, const MassMatrixFactor& f, InverseBlocks* out) {
  const auto B = M.topRightCorner<kB, kNumJoints>();
  // A⁻¹ = L⁻ᵀ L⁻¹ from A = L Lᵀ: W = L⁻¹ by forward substitution on the identity, then the
  // lower triangle of WᵀW, mirrored (exactly symmetric; a generic triangular solve with a matrix
  // right-hand side costs several times this on 6 × 6)
  const Matrix6d& L = f.llt_A.matrixLLT();  // lower triangle holds L
  Matrix6d W = Matrix6d::Zero();
  for (int c = 0; c < kB; ++c) {
    W(c, c) = 1.0 / L(c, c);
    for (int r = c + 1; r < kB; ++r) {
      double s = 0.0;
      for (int k = c; k < r; ++k) s -= L(r, k) * W(k, c);
      W(r, c) = s / L(r, r);
    }
  }
  for (int c = 0; c < kB; ++c)
    for (int r = c; r < kB; ++r) {
      double s = 0.0;
      for (int k = r; k < kB; ++k) s += W(k, r) * W(k, c);
      out->A_inv(r, c) = out->A_inv(c, r) = s;
    }
  // A⁻¹ B, and F⁻¹ = C − Bᵀ A⁻¹ B (Schur complement of A), its lower triangle mirrored
  out->A_inv_B.noalias() = out->A_inv * B;
  for (int c = 0; c < kNumJoints; ++c) {
    const Vector6d ab = out->A_inv_B.col(c);
    for (int r = c; r < kNumJoints; ++r)
      out->F_inv(r, c) = out->F_inv(c, r) = M(kB + r, kB + c) - B.col(r).dot(ab);
  }
}

}  // namespace hyq::dynamics
