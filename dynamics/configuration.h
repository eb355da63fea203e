// Integration and differences on the configuration manifold (free joint + 12 revolute joints),
// as MuJoCo's mj_integratePos / mj_differentiatePos: the base angular velocity is in the base
// frame, so the orientation updates by right-multiplication, R ← R exp([w_B dt]×).
#pragma once

#include "dynamics/model.h"

namespace hyq::dynamics {

/// q ⊕ v dt. Allocates nothing.
VectorQ Integrate(const VectorQ& q, const VectorV& v, double dt);

/// The velocity v with Integrate(q0, v, dt) = q1. Allocates nothing.
VectorV Difference(const VectorQ& q0, const VectorQ& q1, double dt);

}  // namespace hyq::dynamics
