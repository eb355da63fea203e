#include "servo/control/noslip_id.h"

#include <algorithm>
#include <cmath>

#include "dynamics/fixed_products.h"
#include "servo/control/contact_free_id.h"

namespace hyq::servo {
namespace {
constexpr int kB = dynamics::kNumBaseDofs;
constexpr int kJ = dynamics::kNumJoints;
constexpr int kNv = dynamics::kNv;

// x = (AᵀA)⁺ Aᵀ c, the minimum-norm least-squares solution, from the eigen-decomposition of
// N = AᵀA (eigenvalues below 1e-12 · max are treated as zero).
template <int n, class Solver>
Eigen::Matrix<double, n, 1> MinNormSolve(Solver* eig, const Eigen::Matrix<double, n, n>& N,
                                         const Eigen::Matrix<double, n, 1>& Atc) {
  eig->compute(N);
  const auto& lambda = eig->eigenvalues();
  const double cut = 1e-12 * std::max(lambda.maxCoeff(), 1e-300);
  Eigen::Matrix<double, n, 1> y = eig->eigenvectors().transpose() * Atc;
  for (int i = 0; i < n; ++i) y(i) = lambda(i) > cut ? y(i) / lambda(i) : 0.0;
  return eig->eigenvectors() * y;
}

}  // namespace

IdStatus NoSlipId::Solve(const dynamics::Model& model, const dynamics::CycleDynamics& dyn,
                         const dynamics::VectorV& h, const IdInput& in, IdOutput* out) noexcept {
  ++counters_.calls;
  *out = IdOutput{};
  if (!in.qdd_des.allFinite() || !in.v.allFinite() || !(in.dt > 0.0) || !std::isfinite(in.dt) ||
      BuildContactSet(model, dyn.feet, in, 1, &set_) != ContactStatus::kOk) {
    ++counters_.bad_input;
    out->fallback = Fallback::kSafety;
    return IdStatus::kBadInput;
  }
  const int k = set_.count;
  dynamics::Vector6d a_b;
  if (k == 0) {
    ++counters_.no_contact;
    out->tau_Nm = ContactFreeId(dyn, h, in.qdd_des, &a_b);
  } else {
    Jc_.resize(3 * k, kNv);
    Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxRows, 1> rhs(3 * k);
    for (int i = 0; i < k; ++i) {
      Jc_.middleRows<3>(3 * i) = set_.J_c[i];
      rhs.segment<3>(3 * i) = set_.Jdot_c_v[i];
    }
    // a_b = −J_c,b⁺ (J̇_c v + J_c,q q̈_des)
    rhs.noalias() += Jc_.rightCols<kJ>() * in.qdd_des;
    const auto Jb = Jc_.leftCols<kB>();
    const dynamics::Matrix6d Nb = Jb.transpose() * Jb;
    const dynamics::Vector6d Jbt_rhs = Jb.transpose() * rhs;
    a_b = -MinNormSolve<kB>(&eig_base_, Nb, Jbt_rhs);
    VectorV vdot;
    vdot << a_b, in.qdd_des;
    VectorV b = h;
    b += dynamics::Times(dyn.M, vdot);

    // J_cᵀ Π = Q [R; 0]; Q_u = the columns past the rank
    qr_.compute(Jc_.transpose());
    const int rank = static_cast<int>(qr_.rank());
    if (rank == 0) {
      ++counters_.decomposition_failed;
      out->tau_Nm = ContactFreeId(dyn, h, in.qdd_des, &a_b);
      out->fallback = Fallback::kContactFreeId;
      if (ClampToEffortLimits(model, &out->tau_Nm)) ++counters_.clamped;
    } else {
      Q_ = qr_.householderQ();
      const auto Qu = Q_.rightCols(kNv - rank);
      // τ = (Q_uᵀ Sᵀ)⁺ Q_uᵀ b with Q_uᵀ Sᵀ = (bottom 12 rows of Q_u)ᵀ =: Aᵀ, A = Q_u,q
      const auto Aq = Qu.bottomRows<kJ>();
      const Eigen::Matrix<double, kJ, kJ> Nt = Aq * Aq.transpose();
      const Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kNv, 1> Qub = Qu.transpose() * b;
      const VectorJ Atc = Aq * Qub;
      out->tau_Nm = MinNormSolve<kJ>(&eig_tau_, Nt, Atc);
      // λ: J_cᵀ λ = b − Sᵀ τ  (least squares through the same QR)
      VectorV r = b;
      r.tail<kJ>() -= out->tau_Nm;
      const Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxRows, 1> lambda =
          qr_.solve(r);
      for (int i = 0; i < k; ++i) {
        const Eigen::Vector3d f = lambda.segment<3>(3 * i) * in.dt;  // impulse, N·s
        ContactImpulse& c = out->impulses[set_.foot[i]];
        c.active = true;
        c.normal_Ns = f.dot(set_.normal_W[i]);
        c.tangent_Ns_W = f - c.normal_Ns * set_.normal_W[i];
      }
    }
  }
  out->v_star = in.v;
  out->v_star.head<kB>() += in.dt * a_b;
  out->v_star.tail<kJ>() += in.dt * in.qdd_des;
  out->kinetic_energy_J = dynamics::HalfQuadraticForm(dyn.M, out->v_star);
  return out->fallback == Fallback::kNone ? IdStatus::kOk : IdStatus::kFallback;
}

}  // namespace hyq::servo
