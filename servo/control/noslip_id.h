// Floating-base inverse dynamics with non-slipping contacts by orthogonal decomposition
// [Mistry, Buchli, Schaal, "Inverse dynamics control of floating base systems using orthogonal
// decomposition", ICRA 2010]: the paper's "existing (non slipping) ID".
//
// With the stacked contact-point Jacobian J_c (3k × 18) of the k stance feet:
//   base acceleration from the contact constraint J_c v̇ + J̇_c v = 0 with the joint part fixed
//   to q̈_des: a_b = −J_c,b⁺ (J̇_c v + J_c,q q̈_des)  (least squares, min-norm). With two feet
//   the rotation about the line between them is not constrained; the min-norm choice gives it
//   zero acceleration, which the dynamics need not allow (the base rows then keep a residual).
//   J_cᵀ = Q [R; 0], Q = [Q_c Q_u]                                                  (eq 9)
//   τ = (Q_uᵀ Sᵀ)⁺ Q_uᵀ (M v̇ + h)          (minimum-norm torques, eq 13)
//   λ = R⁻¹ Q_cᵀ (M v̇ + h − Sᵀ τ)          (contact forces, eq 14)
// No friction cone and no unilaterality: λ may pull or exceed any μ. Impulses reported as λ h.
#pragma once

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include "dynamics/cycle_dynamics.h"
#include "servo/control/contact_model.h"
#include "servo/control/two_stage_id.h"

namespace hyq::servo {

class NoSlipId {
 public:
  /// Same contract as TwoStageId::Solve (stage1/stage2 reports are left "not run").
  IdStatus Solve(const dynamics::Model& model, const dynamics::CycleDynamics& dyn,
                 const dynamics::VectorV& h, const IdInput& in, IdOutput* out) noexcept;
  /// As above with the model's h = dyn.bias.
  IdStatus Solve(const dynamics::Model& model, const dynamics::CycleDynamics& dyn,
                 const IdInput& in, IdOutput* out) noexcept {
    return Solve(model, dyn, dyn.bias, in, out);
  }
  const FallbackCounters& counters() const noexcept { return counters_; }

 private:
  static constexpr int kMaxRows = 3 * kMaxContacts;
  using JcMatrix = Eigen::Matrix<double, Eigen::Dynamic, dynamics::kNv, Eigen::ColMajor, kMaxRows,
                                 dynamics::kNv>;
  ContactSet set_;
  JcMatrix Jc_;
  Eigen::ColPivHouseholderQR<Eigen::Matrix<double, dynamics::kNv, Eigen::Dynamic, Eigen::ColMajor,
                                           dynamics::kNv, kMaxRows>> qr_;
  // minimum-norm least squares through the eigen-decomposition of the (fixed-size) normal
  // matrix; Eigen's CompleteOrthogonalDecomposition allocates when rank-deficient
  Eigen::SelfAdjointEigenSolver<dynamics::Matrix6d> eig_base_;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, dynamics::kNumJoints, dynamics::kNumJoints>>
      eig_tau_;
  dynamics::MatrixV Q_;
  FallbackCounters counters_;
};

}  // namespace hyq::servo
