// The contact model of the two-stage inverse dynamics (Zapolsky et al. §2): per stance foot a
// unit normal n, r tangent directions evenly spaced in the tangent plane (an inscribed friction
// pyramid), and the generalized contact directions
//   N(:, i) = J_iᵀ n_i,   D(:, (i, k)) = J_iᵀ d_ik,   R = [N D]                       (11)
// where J_i is the 3 × 18 Jacobian of foot i's contact point (dynamics/kinematics.h). Unknowns
// z = [c_N; c_D] (12): normals first, then the r tangential impulses of each contact in turn.
#pragma once

#include <array>

#include "dynamics/kinematics.h"
#include "servo/control/id_types.h"

namespace hyq::servo {

inline constexpr int kMaxTangents = 8;
inline constexpr int kMaxContacts = kNumFeet;
inline constexpr int kMaxImpulses = kMaxContacts * (1 + kMaxTangents);
static_assert(kMaxImpulses <= qp::kMaxVariables, "Stage I must fit the QP's capacity");

using ContactMatrix = Eigen::Matrix<double, dynamics::kNv, Eigen::Dynamic, Eigen::ColMajor,
                                    dynamics::kNv, kMaxImpulses>;

struct ContactSet {
  int count = 0;        // n: stance contacts
  int tangents = 4;     // r
  std::array<int, kMaxContacts> foot{};
  std::array<double, kMaxContacts> mu{};
  std::array<Eigen::Vector3d, kMaxContacts> normal_W, t1_W, t2_W;
  std::array<dynamics::FootJacobian, kMaxContacts> J_c;  // contact point Jacobians
  std::array<Eigen::Vector3d, kMaxContacts> Jdot_c_v;
  ContactMatrix R;      // [N D], 18 × n(1 + r)
  std::array<double, kMaxTangents> cos_k{}, sin_k{};  // cos(2πk/r), sin(2πk/r)

  int num_impulses() const noexcept { return count * (1 + tangents); }
  int NormalIndex(int i) const noexcept { return i; }
  int TangentIndex(int i, int k) const noexcept { return count + tangents * i + k; }
  /// The contact whose impulse z(c) is (the inverse of NormalIndex and TangentIndex).
  int ContactOfImpulse(int c) const noexcept { return c < count ? c : (c - count) / tangents; }
  /// d_ik = cos(2πk/r) t1 + sin(2πk/r) t2
  Eigen::Vector3d Direction(int i, int k) const noexcept {
    return cos_k[k] * t1_W[i] + sin_k[k] * t2_W[i];
  }
};

enum class [[nodiscard]] ContactStatus : std::uint8_t { kOk, kBadNormal, kBadFriction, kBadTangents };

/// Fills `out` for the stance feet of `in`. Normals are normalised; t1 is world x (or y when n is
/// near x) projected on the tangent plane, t2 = n × t1. Never allocates.
ContactStatus BuildContactSet(const dynamics::Model& model, const dynamics::FootKinematics& feet,
                              const IdInput& in, int tangents, ContactSet* out) noexcept;

/// Per-foot impulses from z (N·s, world tangent vectors).
void ImpulsesFromZ(const ContactSet& set, const Eigen::Ref<const qp::VectorN>& z,
                   std::array<ContactImpulse, kNumFeet>* out) noexcept;

}  // namespace hyq::servo
