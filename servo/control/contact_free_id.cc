#include "servo/control/contact_free_id.h"

#include "dynamics/fixed_products.h"

namespace hyq::servo {

dynamics::VectorJ ContactFreeId(const dynamics::CycleDynamics& dyn, const dynamics::VectorV& h,
                                const dynamics::VectorJ& qdd, dynamics::Vector6d* a_base) noexcept {
  const auto h_b = h.head<dynamics::kNumBaseDofs>();
  const auto h_q = h.tail<dynamics::kNumJoints>();
  dynamics::VectorJ tau = dynamics::Times(dyn.inv.F_inv, qdd) + h_q;
  tau.noalias() -= dyn.inv.A_inv_B.transpose() * h_b;
  if (a_base != nullptr) {
    *a_base = -dynamics::Times(dyn.inv.A_inv_B, qdd);
    a_base->noalias() -= dyn.inv.A_inv * h_b;
  }
  return tau;
}

}  // namespace hyq::servo
