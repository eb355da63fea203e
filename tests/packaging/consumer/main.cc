#include <cstdio>
#include <memory>

#include "dynamics/cycle_dynamics.h"
#include "dynamics/urdf_loader.h"

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  const auto model = hyq::dynamics::LoadModelFromUrdf(argv[1]);
  auto d = std::make_unique<hyq::dynamics::CycleDynamics>();
  const auto s = hyq::dynamics::ComputeCycleDynamics(model, model.StandingQ(),
                                                     hyq::dynamics::VectorV::Zero(), d.get());
  std::printf("consumer: %s, mass %.3f kg, gravity load %.1f N\n", hyq::dynamics::ToString(s),
              model.TotalMass(), d->bias(2));
  return s == hyq::dynamics::DynamicsStatus::kOk ? 0 : 1;
}
