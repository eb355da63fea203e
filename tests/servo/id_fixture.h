// Shared set-up for the inverse-dynamics tests: HyQ near its standing posture with contact-
// consistent velocities and accelerations.
#pragma once

#include <memory>
#include <random>

#include <Eigen/Dense>

#include "dynamics/cycle_dynamics.h"
#include "servo/control/contact_model.h"
#include "tests/dynamics/hyq_fixture.h"

namespace hyq::testing {

/// A stance situation: q near standing (small random base tilt and joint offsets).
inline servo::IdInput StandingInput(std::mt19937_64* rng, std::array<bool, 4> stance,
                                    double tilt = 0.05) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  servo::IdInput in;
  in.q = HyqModel().StandingQ();
  const Eigen::Quaterniond qt =
      Eigen::AngleAxisd(tilt * u(*rng), Eigen::Vector3d::UnitX()) *
      Eigen::AngleAxisd(tilt * u(*rng), Eigen::Vector3d::UnitY());
  in.q.segment<4>(3) << qt.w(), qt.x(), qt.y(), qt.z();
  for (int j = 0; j < 12; ++j) in.q(7 + j) += 0.05 * u(*rng);
  in.stance = stance;
  in.dt = 1e-3;
  return in;
}

/// Makes v and q̈_des contact-consistent for the stance feet: the base moves with twist
/// v_base and acceleration a_base, and each stance leg's joints are solved so that its contact
/// point has zero velocity and zero acceleration (J_c v = 0, J_c v̇ + J̇_c v = 0). Swing legs get
/// the given random joint rates / accelerations. With velocity_level, q̈_des instead gives
/// J_c v̇ = 0, so that the step of eqs 5–6 keeps the contact points still, J_c (v + h v̇) = 0:
/// with v ≠ 0, acceleration-level consistency leaves them a velocity −h J̇_c v, which the
/// velocity-level model sees as (micro-)sliding.
inline void MakeContactConsistent(servo::IdInput* in, const dynamics::Vector6d& v_base,
                                  const dynamics::Vector6d& a_base, std::mt19937_64* rng,
                                  bool velocity_level = false) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto d = std::make_unique<dynamics::CycleDynamics>();
  in->v.setZero();
  in->v.head<6>() = v_base;
  for (int j = 0; j < 12; ++j) in->v(6 + j) = 0.5 * u(*rng);
  for (int j = 0; j < 12; ++j) in->qdd_des(j) = 2.0 * u(*rng);
  // velocities first (J_c v = 0 per stance leg), then accelerations with J̇_c v at that v
  for (int pass = 0; pass < 2; ++pass) {
    (void)dynamics::ComputeCycleDynamics(HyqModel(), in->q, in->v, d.get());
    servo::ContactSet set;
    (void)servo::BuildContactSet(HyqModel(), d->feet, *in, 4, &set);
    for (int i = 0; i < set.count; ++i) {
      const int leg = set.foot[i];
      const auto& J = set.J_c[i];
      const Eigen::Matrix3d J_leg = J.middleCols<3>(6 + 3 * leg);
      Eigen::Vector3d rhs = -J.leftCols<6>() * (pass == 0 ? v_base : a_base);
      if (pass == 1 && !velocity_level) rhs -= set.Jdot_c_v[i];
      for (int other = 0; other < 4; ++other) {
        if (other == leg) continue;
        const Eigen::Vector3d x_other = pass == 0 ? Eigen::Vector3d(in->v.segment<3>(6 + 3 * other))
                                                  : Eigen::Vector3d(in->qdd_des.segment<3>(3 * other));
        rhs -= J.middleCols<3>(6 + 3 * other) * x_other;
      }
      const Eigen::Vector3d x = J_leg.partialPivLu().solve(rhs);
      if (pass == 0) in->v.segment<3>(6 + 3 * leg) = x;
      else in->qdd_des.segment<3>(3 * leg) = x;
    }
  }
}

}  // namespace hyq::testing
