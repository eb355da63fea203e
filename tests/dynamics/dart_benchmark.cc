// The project's per-cycle rigid-body terms beside DART's (libdart-dev 6.12, Debian 12), on the
// same URDF (config/robots/hyq.urdf): the joint-space mass matrix, the bias forces (Coriolis,
// centrifugal and gravity) and the four feet's Jacobians (6 × 18 in DART, linear and angular; the
// project computes both as two 3 × 18 blocks). Table: docs/benchmarks.md, "Dynamics beside DART".
//   build/ci/tests/dynamics/dart_benchmark --benchmark_repetitions=5
//       --benchmark_report_aggregates_only=true
// Timings only: the states are random on each side (DART's free joint has its own coordinates for
// the base; the project's q holds a quaternion), drawn the same way for the joints. What is
// checked before timing is that both loaded the same robot (total mass, the four feet).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>

#include <benchmark/benchmark.h>
#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/Skeleton.hpp>
#include <dart/utils/urdf/DartLoader.hpp>

#include "dynamics/cycle_dynamics.h"
#include "tests/dynamics/hyq_fixture.h"
#include "tests/support/paths.h"

namespace hyq::dynamics {
namespace {

constexpr const char* kFeet[4] = {"lf_foot", "rf_foot", "lh_foot", "rh_foot"};

struct Dart {
  Dart() {
    dart::utils::DartLoader loader;
    skel = loader.parseSkeleton("file://" + testing::ProjectUrdf().string());
    if (!skel) {
      std::fprintf(stderr, "dart_benchmark: DART could not load %s\n",
                   testing::ProjectUrdf().c_str());
      std::abort();
    }
    for (int f = 0; f < 4; ++f) {
      feet[f] = skel->getBodyNode(kFeet[f]);
      if (feet[f] == nullptr) {
        std::fprintf(stderr, "dart_benchmark: no body %s in the URDF\n", kFeet[f]);
        std::abort();
      }
    }
    // DART gives a link without <inertial> a mass of 1 kg (the feet here: 4 kg that the URDF
    // does not have); the URDF's meaning is a massless frame. 1 µg (DART warns about 0), with a
    // point inertia, leaves every term within 1e-10 of the massless one
    for (auto* foot : feet) foot->setInertia(dart::dynamics::Inertia(1e-9));
    const double mass = skel->getMass(), ours = testing::HyqModel().TotalMass();
    if (std::abs(mass - ours) > 1e-8 * ours) {
      std::fprintf(stderr, "dart_benchmark: total mass %.9f kg in DART, %.9f kg here\n", mass,
                   ours);
      std::abort();
    }
  }
  dart::dynamics::SkeletonPtr skel;
  dart::dynamics::BodyNode* feet[4] = {};
};

struct States {
  States() {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (auto& s : ours) s = testing::MakeRandomState(testing::HyqModel(), &rng);
    for (auto& s : dart) {
      s.q = Eigen::VectorXd::Zero(18);
      s.v = Eigen::VectorXd::Zero(18);
      for (int i = 0; i < 18; ++i) s.q(i) = 0.5 * u(rng), s.v(i) = 2.0 * u(rng);
    }
  }
  std::array<testing::RandomState, 64> ours;
  struct DartState {
    Eigen::VectorXd q, v;
  };
  std::array<DartState, 64> dart;
};

const States& TheStates() {
  static const States s;
  return s;
}

// M, bias and the feet's Jacobians, DART
void BM_DartMassBiasFootJacobians(benchmark::State& state) {
  Dart d;
  const States& st = TheStates();
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& s = st.dart[i++ % st.dart.size()];
    d.skel->setPositions(s.q);
    d.skel->setVelocities(s.v);
    benchmark::DoNotOptimize(d.skel->getMassMatrix().data());
    benchmark::DoNotOptimize(d.skel->getCoriolisAndGravityForces().data());
    for (auto* foot : d.feet) benchmark::DoNotOptimize(d.skel->getJacobian(foot).data());
  }
  state.SetLabel("DART 6.12: M, C + g, 4 foot Jacobians");
}
BENCHMARK(BM_DartMassBiasFootJacobians);

// the same terms here: kinematics, the feet, CRBA, RNEA bias
void BM_OursMassBiasFootJacobians(benchmark::State& state) {
  auto d = std::make_unique<CycleDynamics>();
  const States& st = TheStates();
  const Model& model = testing::HyqModel();
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& s = st.ours[i++ % st.ours.size()];
    ForwardKinematics(model, s.q, s.v, &d->kin);
    ComputeFootKinematics(model, d->kin, &d->feet);
    Crba(model, d->kin, &d->crba_ws, &d->M);
    BiasForces(model, d->kin, &d->rnea_ws, &d->bias);
    benchmark::DoNotOptimize(d->M.data());
    benchmark::DoNotOptimize(d->bias.data());
  }
  state.SetLabel("hyq::dynamics: M, bias, 4 foot Jacobians");
}
BENCHMARK(BM_OursMassBiasFootJacobians);

// everything the servo computes per cycle (adds the factorisation and M⁻¹ blocks), for scale
void BM_OursFullCycleDynamics(benchmark::State& state) {
  auto d = std::make_unique<CycleDynamics>();
  const States& st = TheStates();
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& s = st.ours[i++ % st.ours.size()];
    const DynamicsStatus r = ComputeCycleDynamics(testing::HyqModel(), s.q, s.v, d.get());
    benchmark::DoNotOptimize(r);
  }
  state.SetLabel("hyq::dynamics: ComputeCycleDynamics (also L, M^-1 blocks)");
}
BENCHMARK(BM_OursFullCycleDynamics);

}  // namespace
}  // namespace hyq::dynamics

BENCHMARK_MAIN();
