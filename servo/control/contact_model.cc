#include "servo/control/contact_model.h"

#include <cmath>

namespace hyq::servo {

ContactStatus BuildContactSet(const dynamics::Model& model, const dynamics::FootKinematics& feet,
                              const IdInput& in, int tangents, ContactSet* out) noexcept {
  if (tangents < 1 || tangents > kMaxTangents) return ContactStatus::kBadTangents;
  if (out->tangents != tangents || out->cos_k[0] != 1.0) {
    for (int k = 0; k < tangents; ++k) {
      const double a = 2.0 * M_PI * k / tangents;
      out->cos_k[k] = std::cos(a);
      out->sin_k[k] = std::sin(a);
    }
  }
  out->tangents = tangents;
  out->count = 0;
  for (int f = 0; f < kNumFeet; ++f) {
    if (!in.stance[f]) continue;
    const int i = out->count++;
    const Eigen::Vector3d& n_raw = in.normal_W[f];
    const double norm = n_raw.norm();
    if (!std::isfinite(norm) || norm < 1e-9) return ContactStatus::kBadNormal;
    if (!std::isfinite(in.mu[f]) || in.mu[f] < 0.0) return ContactStatus::kBadFriction;
    const Eigen::Vector3d n = n_raw / norm;
    const Eigen::Vector3d seed =
        std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    out->foot[i] = f;
    out->mu[i] = in.mu[f];
    out->normal_W[i] = n;
    out->t1_W[i] = (seed - seed.dot(n) * n).normalized();
    out->t2_W[i] = n.cross(out->t1_W[i]);
    dynamics::ContactPointJacobian(model, feet, f, n, &out->J_c[i], &out->Jdot_c_v[i]);
  }
  // R = [N D]   (11)
  out->R.resize(dynamics::kNv, out->num_impulses());
  for (int i = 0; i < out->count; ++i) {
    out->R.col(out->NormalIndex(i)).noalias() = out->J_c[i].transpose() * out->normal_W[i];
    for (int k = 0; k < tangents; ++k)
      out->R.col(out->TangentIndex(i, k)).noalias() = out->J_c[i].transpose() * out->Direction(i, k);
  }
  return ContactStatus::kOk;
}

void ImpulsesFromZ(const ContactSet& set, const Eigen::Ref<const qp::VectorN>& z,
                   std::array<ContactImpulse, kNumFeet>* out) noexcept {
  for (auto& c : *out) c = ContactImpulse{};
  for (int i = 0; i < set.count; ++i) {
    ContactImpulse& c = (*out)[set.foot[i]];
    c.active = true;
    c.normal_Ns = z(set.NormalIndex(i));
    for (int k = 0; k < set.tangents; ++k) c.tangent_Ns_W += z(set.TangentIndex(i, k)) * set.Direction(i, k);
  }
}

}  // namespace hyq::servo
