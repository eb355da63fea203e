// hyq-dynamics-demo: loads the HyQ model and evaluates the per-cycle dynamics the servo loop
// will use, at the standing posture and along a short swaying motion, printing what a person
// checks first (mass, foot placement, M conditioning, gravity load) and the per-cycle cost.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Eigenvalues>

#include "dynamics/configuration.h"
#include "dynamics/cycle_dynamics.h"
#include "dynamics/urdf_loader.h"
#include "tools/cli/command_line.h"
#include "tools/cli/install_paths.h"

namespace {

using namespace hyq::dynamics;

constexpr std::string_view kUsage =
    "usage: hyq-dynamics-demo [--urdf FILE] [--cycles N] [--help]\n"
    "\n"
    "Loads the HyQ model (URDF) and runs the servo loop's per-cycle dynamics (kinematics, feet,\n"
    "mass matrix, bias forces, factorisation, inverse blocks) at the standing posture and along\n"
    "a swaying motion, then prints the model facts and the per-cycle timing.\n"
    "\n"
    "  --urdf FILE   model file (default: @config@/robots/hyq.urdf)\n"
    "  --cycles N    cycles of the swaying motion to time (default 20000, 1 kHz = 20 s of motion)\n"
    "  --help        this text\n";

}  // namespace

int main(int argc, char** argv) {
  std::string urdf = hyq::cli::DefaultUrdf();
  long cycles = 20000;
  hyq::cli::CommandLine cl(argc, argv, "hyq-dynamics-demo", hyq::cli::WithPaths(std::string(kUsage)));
  while (cl.Next()) {
    if (cl.Flag("--urdf")) {
      urdf = cl.Value();
    } else if (cl.Flag("--cycles")) {
      cycles = static_cast<long>(cl.Integer(1, 100'000'000, "an integer from 1 to 1e8"));
    } else {
      cl.Unknown();
    }
  }

  Model model;
  try {
    model = LoadModelFromUrdf(urdf);
  } catch (const ModelError& e) {
    std::fprintf(stderr, "hyq-dynamics-demo: %s\n", e.what());
    return 1;
  }
  std::printf("model %s: %d bodies, %d joints, total mass %.3f kg\n", model.source.c_str(),
              kNumBodies, kNumJoints, model.TotalMass());

  auto d = std::make_unique<CycleDynamics>();
  const VectorQ q0 = model.StandingQ();
  if (ComputeCycleDynamics(model, q0, VectorV::Zero(), d.get()) != DynamicsStatus::kOk) {
    std::fprintf(stderr, "hyq-dynamics-demo: dynamics failed at the standing posture\n");
    return 1;
  }
  std::printf("\nstanding posture, base at z = %.4f m\n", model.standing_base_height_m);
  std::printf("  %-8s %9s %9s %9s   (foot sphere centre, world, m)\n", "foot", "x", "y", "z");
  for (int f = 0; f < kNumFeet; ++f)
    std::printf("  %-8s %9.4f %9.4f %9.4f\n", model.feet[f].name.c_str(), d->feet.p_WF_W[f].x(),
                d->feet.p_WF_W[f].y(), d->feet.p_WF_W[f].z());
  const Eigen::SelfAdjointEigenSolver<MatrixV> eig(d->M);
  std::printf("  mass matrix eigenvalues %.3e .. %.3e (condition %.1f)\n", eig.eigenvalues()(0),
              eig.eigenvalues()(kNv - 1), eig.eigenvalues()(kNv - 1) / eig.eigenvalues()(0));
  std::printf("  gravity load on the base %.1f N (m g = %.1f N)\n", d->bias(2),
              model.TotalMass() * 9.81);
  std::printf("  gravity torques of the LF leg (haa, hfe, kfe): %.2f %.2f %.2f N m\n", d->bias(6),
              d->bias(7), d->bias(8));

  // a swaying motion: body roll and pitch at 1 Hz, knees bending at 2 Hz
  std::vector<double> ns;
  ns.reserve(static_cast<std::size_t>(cycles));
  const long progress_every = std::max(1L, cycles / 10);
  VectorQ q = q0;
  VectorV v = VectorV::Zero();
  for (long k = 0; k < cycles; ++k) {
    const double t = 1e-3 * static_cast<double>(k);
    v.setZero();
    v(3) = 0.2 * std::cos(2 * M_PI * t);
    v(4) = 0.1 * std::sin(2 * M_PI * t);
    for (int leg = 0; leg < kNumLegs; ++leg) v(VIndexOfJoint(JointIndex(leg, 2))) = 0.3 * std::sin(4 * M_PI * t);
    q = Integrate(q, v, 1e-3);
    const auto t0 = std::chrono::steady_clock::now();
    const DynamicsStatus st = ComputeCycleDynamics(model, q, v, d.get());
    const auto t1 = std::chrono::steady_clock::now();
    if (st != DynamicsStatus::kOk) {
      std::fprintf(stderr, "hyq-dynamics-demo: cycle %ld: %s\n", k, ToString(st));
      return 1;
    }
    ns.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count());
    if ((k + 1) % progress_every == 0)
      std::fprintf(stderr, "\r  swaying: %3ld %%", 100 * (k + 1) / cycles);
  }
  std::fprintf(stderr, "\n");
  std::sort(ns.begin(), ns.end());
  auto pct = [&](double p) { return ns[std::min(ns.size() - 1, static_cast<std::size_t>(p * static_cast<double>(ns.size())))]; };
  std::printf("\nper-cycle dynamics over %ld cycles: median %.2f us, p99 %.2f us, p99.9 %.2f us, max %.2f us\n",
              cycles, pct(0.5) / 1e3, pct(0.99) / 1e3, pct(0.999) / 1e3, ns.back() / 1e3);
  std::printf("  (the servo budget at 1 kHz is 1000 us; the controller and the QPs come on top)\n");
  return 0;
}
