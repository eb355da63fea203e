// Shared set-up for the dynamics tests: the project's model and reproducible random states.
#pragma once

#include <algorithm>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "dynamics/model.h"
#include "dynamics/urdf_loader.h"
#include "tests/support/paths.h"

namespace hyq::testing {

inline const dynamics::Model& HyqModel() {
  static const dynamics::Model model = dynamics::LoadModelFromUrdf(ProjectUrdf().string());
  return model;
}

/// Random base pose and velocity, joint angles uniformly within limits, joint rates in ±5 rad/s.
struct RandomState {
  dynamics::VectorQ q;
  dynamics::VectorV v;
};

inline RandomState MakeRandomState(const dynamics::Model& model, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  RandomState s;
  s.q.head<3>() << u(*rng), u(*rng), 0.5 + 0.3 * u(*rng);
  Eigen::Quaterniond quat(Eigen::Vector4d(u(*rng), u(*rng), u(*rng), u(*rng)));
  quat.normalize();
  s.q.segment<4>(3) << quat.w(), quat.x(), quat.y(), quat.z();
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const auto& lim = model.limits[j];
    const double t = 0.5 * (u(*rng) + 1.0);
    s.q(dynamics::QIndexOfJoint(j)) = lim.lower_rad + t * (lim.upper_rad - lim.lower_rad);
  }
  for (int i = 0; i < 3; ++i) s.v(i) = 2.0 * u(*rng);
  for (int i = 3; i < 6; ++i) s.v(i) = 3.0 * u(*rng);
  for (int i = 6; i < dynamics::kNv; ++i) s.v(i) = 5.0 * u(*rng);
  return s;
}

/// max |a − b| ≤ tol · max(max |b|, 1): the relative tolerance used against references.
template <class A, class B>
::testing::AssertionResult NearRel(const A& a, const B& b, double tol) {
  const double scale = std::max(1.0, b.cwiseAbs().maxCoeff());
  const double err = (a - b).cwiseAbs().maxCoeff();
  if (err <= tol * scale) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "max error " << err << " > " << tol << " × " << scale;
}

}  // namespace hyq::testing
