#include "tools/loop_model/joint_inertia.h"

#include <memory>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/QR>

#include "dynamics/crba.h"
#include "dynamics/kinematics.h"
#include "dynamics/rnea.h"

namespace hyq::loop_model {
namespace {

using dynamics::kJointsPerLeg;
using dynamics::kNumBaseDofs;
using dynamics::kNumFeet;
using dynamics::kNumJoints;
using dynamics::kNv;

struct Dynamics {
  dynamics::Kinematics kin;
  dynamics::FootKinematics feet;
  dynamics::CrbaWorkspace crba;
  dynamics::RneaWorkspace rnea;
  dynamics::MatrixV M;
  dynamics::VectorV g;
};

// M(q), g(q) = h(q, 0) and the feet's Jacobians at rest
std::unique_ptr<Dynamics> Compute(const dynamics::Model& model, const dynamics::VectorQ& q) {
  auto d = std::make_unique<Dynamics>();
  dynamics::ForwardKinematics(model, q, dynamics::VectorV::Zero(), &d->kin);
  dynamics::ComputeFootKinematics(model, d->kin, &d->feet);
  dynamics::Crba(model, d->kin, &d->crba, &d->M);
  dynamics::BiasForces(model, d->kin, &d->rnea, &d->g);
  return d;
}

// the stance feet's Jacobians stacked, 3 rows per foot
Eigen::MatrixXd StanceJacobian(const Dynamics& d, const StanceSet& stance) {
  int n = 0;
  for (bool s : stance) n += s ? 1 : 0;
  Eigen::MatrixXd J(3 * n, kNv);
  int row = 0;
  for (int f = 0; f < kNumFeet; ++f) {
    if (!stance[static_cast<std::size_t>(f)]) continue;
    J.middleRows(row, 3) = d.feet.J_WF[static_cast<std::size_t>(f)];
    row += 3;
  }
  return J;
}

}  // namespace

dynamics::VectorJ SwingInertia(const dynamics::Model& model, const dynamics::VectorQ& q) {
  const auto d = Compute(model, q);
  // (1): the joint block's diagonal
  return d->M.diagonal().tail<kNumJoints>();
}

dynamics::VectorJ FreeLegInertia(const dynamics::Model& model, const dynamics::VectorQ& q) {
  const auto d = Compute(model, q);
  dynamics::VectorJ out;
  // (3): each leg's 3 × 3 block inverted, the diagonal of the inverse inverted
  for (int leg = 0; leg < dynamics::kNumLegs; ++leg) {
    const int v = kNumBaseDofs + kJointsPerLeg * leg;
    const Eigen::Matrix3d inv = d->M.block<3, 3>(v, v).inverse();
    for (int k = 0; k < kJointsPerLeg; ++k) out(kJointsPerLeg * leg + k) = 1.0 / inv(k, k);
  }
  return out;
}

dynamics::VectorJ StanceInertia(const dynamics::Model& model, const dynamics::VectorQ& q,
                                const StanceSet& stance) {
  const auto d = Compute(model, q);
  const Eigen::MatrixXd J = StanceJacobian(*d, stance);
  if (J.rows() == 0) throw std::invalid_argument("stance inertia: expected a foot in stance, found none");
  // (2): Λ = M⁻¹ − M⁻¹Jᵀ (J M⁻¹ Jᵀ)⁻¹ J M⁻¹
  const Eigen::LLT<Eigen::MatrixXd> llt(Eigen::MatrixXd(d->M));
  const Eigen::MatrixXd Minv = llt.solve(Eigen::MatrixXd::Identity(kNv, kNv));
  const Eigen::MatrixXd MinvJt = Minv * J.transpose();
  const Eigen::MatrixXd JMJt = J * MinvJt;
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(JMJt);
  if (!lu.isInvertible())
    throw std::invalid_argument("stance inertia: J M⁻¹ Jᵀ is singular (" +
                                std::to_string(J.rows() / 3) + " stance feet)");
  const Eigen::MatrixXd Lambda = Minv - MinvJt * lu.solve(MinvJt.transpose());
  dynamics::VectorJ out;
  for (int j = 0; j < kNumJoints; ++j) {
    const int v = dynamics::VIndexOfJoint(j);
    out(j) = 1.0 / Lambda(v, v);
  }
  return out;
}

dynamics::VectorJ HoldingTorque(const dynamics::Model& model, const dynamics::VectorQ& q,
                                const StanceSet& stance) {
  const auto d = Compute(model, q);
  const Eigen::MatrixXd J = StanceJacobian(*d, stance);
  dynamics::VectorJ tau = d->g.tail<kNumJoints>();
  if (J.rows() == 0) return tau;
  // (4): the base rows g_b = J_bᵀ f, least norm; then τ = g_j − J_jᵀ f
  const Eigen::MatrixXd Jbt = J.leftCols<kNumBaseDofs>().transpose();
  const Eigen::VectorXd f = Jbt.completeOrthogonalDecomposition().solve(d->g.head<kNumBaseDofs>());
  tau -= J.rightCols<kNumJoints>().transpose() * f;
  return tau;
}

}  // namespace hyq::loop_model
