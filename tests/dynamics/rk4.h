// One RK4 step of the floating-base dynamics on the configuration manifold, for tests that need a
// motion they know exactly (the forward dynamics integrated finely): q moves by
// dynamics::Integrate with each stage's velocity.
#pragma once

#include "dynamics/configuration.h"
#include "dynamics/model.h"

namespace hyq::testing {

/// Advances (q, v) from time t by h under v̇ = vdot(q, v, t).
template <class Vdot>
void Rk4Step(const Vdot& vdot, double t, double h, dynamics::VectorQ* q, dynamics::VectorV* v) {
  using dynamics::Integrate;
  using dynamics::VectorV;
  const VectorV k1v = *v, k1a = vdot(*q, *v, t);
  const VectorV k2v = *v + 0.5 * h * k1a, k2a = vdot(Integrate(*q, k1v, 0.5 * h), k2v, t + 0.5 * h);
  const VectorV k3v = *v + 0.5 * h * k2a, k3a = vdot(Integrate(*q, k2v, 0.5 * h), k3v, t + 0.5 * h);
  const VectorV k4v = *v + h * k3a, k4a = vdot(Integrate(*q, k3v, h), k4v, t + h);
  *q = Integrate(*q, (k1v + 2.0 * k2v + 2.0 * k3v + k4v) / 6.0, h);
  *v += h * (k1a + 2.0 * k2a + 2.0 * k3a + k4a) / 6.0;
}

}  // namespace hyq::testing
