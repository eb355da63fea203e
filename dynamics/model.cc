#include "dynamics/model.h"

namespace hyq::dynamics {

double Model::TotalMass() const {
  double m = 0.0;
  for (const Body& b : bodies) m += b.inertia.mass;
  return m;
}

VectorQ Model::StandingQ() const {
  VectorQ q = VectorQ::Zero();
  q(2) = standing_base_height_m;
  q(3) = 1.0;
  q.tail<kNumJoints>() = q_standing;
  return q;
}

}  // namespace hyq::dynamics
