// The simulated HyQ's contact behaves like Coulomb friction, and its contact forces carry the
// robot's weight with the right signs.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "tests/dynamics/hyq_fixture.h"
#include "tools/sim/plant.h"

namespace hyq::sim {
namespace {

using dynamics::JointIndex;
using dynamics::VectorJ;
using testing::HyqModel;

// A 10 kg block on the floor, pushed horizontally in direction θ with a force growing at 5 % of
// its weight per second: the force/weight ratio at which it starts to slide (speed above
// 0.2 mm/s; the detection lag is ~0.15 % of the weight).
double SlipRatio(double mu, double theta) {
  const std::string xml =
      "<mujoco><option timestep=\"0.001\" cone=\"elliptic\" impratio=\"100\"/><worldbody>" +
      CoulombFloorMjcf(mu) +
      "<body name=\"block\" pos=\"0 0 0.05\"><freejoint/>"
      "<geom type=\"box\" size=\"0.1 0.1 0.05\" mass=\"10\" contype=\"2\" conaffinity=\"0\"/>"
      "</body></worldbody></mujoco>";
  mjVFS vfs;
  mj_defaultVFS(&vfs);
  mj_makeEmptyFileVFS(&vfs, "b.xml", static_cast<int>(xml.size()));
  std::memcpy(vfs.filedata[mj_findFileVFS(&vfs, "b.xml")], xml.data(), xml.size());
  char err[500] = "";
  mjModel* m = mj_loadXML("b.xml", &vfs, err, sizeof(err));
  mj_deleteVFS(&vfs);
  EXPECT_NE(m, nullptr) << err;
  if (m == nullptr) return -1;
  mjData* d = mj_makeData(m);
  const double weight = 10 * 9.81;
  const int body = mj_name2id(m, mjOBJ_BODY, "block");
  for (int i = 0; i < 500; ++i) mj_step(m, d);  // settle
  double ratio = -1;
  for (int step = 0; step < 40000 && ratio < 0; ++step) {
    const double F = weight * 0.05 * step * m->opt.timestep;
    d->xfrc_applied[6 * body + 0] = F * std::cos(theta);
    d->xfrc_applied[6 * body + 1] = F * std::sin(theta);
    mj_step(m, d);
    if (std::hypot(d->qvel[0], d->qvel[1]) > 2e-4) ratio = F / weight;
  }
  mj_deleteData(d);
  mj_deleteModel(m);
  return ratio;
}

TEST(Plant, BlockSlidesWhenTheForceReachesMuTimesWeightInAnyDirection) {
  for (double mu : {0.1, 1.0}) {
    for (double deg : {0.0, 30.0, 45.0, 90.0, 135.0, 200.0, 290.0}) {
      const double r = SlipRatio(mu, deg * M_PI / 180);
      EXPECT_NEAR(r / mu, 1.0, 0.03) << "mu " << mu << ", direction " << deg << " deg: slides at "
                                     << r << " m g";
      std::printf("mu %.1f, push at %5.1f deg: slides at %.4f m g (%.2f mu)\n", mu, deg, r, r / mu);
    }
  }
}

TEST(Plant, StandsOnItsFeetWithTheWeightOnTheContacts) {
  Plant plant(HyqModel(), PlantConfig{});
  const VectorJ q0 = HyqModel().q_standing;
  for (int k = 0; k < 2000; ++k) {
    const VectorJ tau = 600.0 * (q0 - plant.q().tail<12>()) - 20.0 * plant.v().tail<12>();
    plant.Step(tau);
  }
  EXPECT_NEAR(plant.q()(2), HyqModel().standing_base_height_m, 0.03);
  const auto contacts = plant.FootContacts();
  double fz = 0;
  for (const auto& c : contacts) {
    EXPECT_TRUE(c.touching);
    EXPECT_GT(c.force_W.z(), 0.0);  // the ground pushes the feet up
    fz += c.force_W.z();
  }
  EXPECT_NEAR(fz, HyqModel().TotalMass() * 9.81, 0.02 * HyqModel().TotalMass() * 9.81);
}

TEST(Plant, FrictionPerFoot) {
  PlantConfig cfg;
  cfg.ground_mu = 1.0;
  cfg.foot_mu = {-1.0, -1.0, 0.05, -1.0};  // lh on ice
  Plant plant(HyqModel(), cfg);
  EXPECT_DOUBLE_EQ(plant.foot_friction(0), 1.0);
  EXPECT_DOUBLE_EQ(plant.foot_friction(2), 0.05);
  plant.SetFootFriction(1, 0.3);
  EXPECT_DOUBLE_EQ(plant.foot_friction(1), 0.3);
  // the ice foot never carries more tangential force than 0.05 of its normal force
  const VectorJ q0 = HyqModel().q_standing;
  double worst = 0;
  for (int k = 0; k < 1500; ++k) {
    VectorJ target = q0;
    target(JointIndex(2, 0)) += 0.2 * std::sin(k * 1e-2);  // wiggle the lh hip sideways
    const VectorJ tau = 600.0 * (target - plant.q().tail<12>()) - 20.0 * plant.v().tail<12>();
    plant.Step(tau);
    const auto c = plant.FootContacts()[2];
    if (c.touching && c.force_W.z() > 10.0)
      worst = std::max(worst, c.force_W.head<2>().norm() / c.force_W.z());
  }
  EXPECT_LE(worst, 0.05 * 1.03);
}

}  // namespace
}  // namespace hyq::sim
