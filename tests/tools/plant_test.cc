// The simulated HyQ's contact behaves like Coulomb friction, and its contact forces carry the
// robot's weight with the right signs.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "dynamics/cycle_dynamics.h"
#include "servo/estimation/friction_estimator.h"
#include "tests/dynamics/hyq_fixture.h"
#include "sim/plant.h"

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

// A joint's end stop is as stiff as the cylinder's mechanical stop: the full 150 N m driven into
// the LF knee's flexion stop (the robot in free fall high above the floor, so only the leg's own
// inertia is involved) holds it within 0.02 rad of its URDF range once it rests there. With
// MuJoCo's default limit (solref 0.02) the resting trunk on folded knees went 0.15 rad past.
TEST(Plant, JointStopsHoldTheActuatorsFullTorque) {
  Plant plant(HyqModel(), PlantConfig{});
  dynamics::VectorQ q = plant.q();
  q(2) = 50.0;  // far above the floor: no contact for the whole second
  plant.Reset(q, dynamics::VectorV::Zero());
  const int kfe = JointIndex(0, 2);  // lf_kfe
  const double lower = HyqModel().limits[kfe].lower_rad;
  double deepest = 0.0, resting = 0.0;  // over the run; once the impact has died out (last 0.5 s)
  for (int k = 0; k < 1000; ++k) {
    VectorJ tau = VectorJ::Zero();
    tau(kfe) = -150.0;  // flexion: towards the lower limit
    plant.Step(tau);
    const double past = lower - plant.q().tail<12>()(kfe);
    deepest = std::max(deepest, past);
    if (k >= 500) resting = std::max(resting, past);
  }
  std::printf("lf_kfe pushed with -150 N m into its stop at %.4f rad: %.4f rad past it at the "
              "impact, %.4f rad resting on it\n", lower, deepest, resting);
  EXPECT_GT(resting, 0.0) << "the knee is not on its stop: the test did not test it";
  EXPECT_LT(resting, 0.02);
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

// friction patches: each foot takes the μ of the patch under it, at every step.
TEST(Plant, FrictionPatchesFollowTheFeet) {
  PlantConfig cfg;
  cfg.ground_mu = 1.0;
  cfg.foot_mu = {-1.0, 0.7, -1.0, -1.0};  // rf has its own μ away from the patches
  Plant probe(HyqModel(), cfg);
  const auto feet0 = [&] {
    std::array<double, 4> x{};
    for (int f = 0; f < 4; ++f)
      x[static_cast<std::size_t>(f)] = probe.mj_data()->geom_xpos[3 * mj_name2id(probe.mj_model(), mjOBJ_GEOM, HyqModel().feet[static_cast<std::size_t>(f)].name.c_str())];
    return x;
  }();
  // a patch under the front feet only (front feet at x > 0, hind feet at x < 0)
  cfg.patches = {GroundPatch{0.1, 2.0, -1.0, 1.0, 0.1}};
  Plant plant(HyqModel(), cfg);
  ASSERT_GT(feet0[0], 0.1);
  ASSERT_LT(feet0[2], 0.1);
  EXPECT_DOUBLE_EQ(plant.foot_friction(0), 0.1);
  EXPECT_DOUBLE_EQ(plant.foot_friction(1), 0.1);   // the patch wins over the foot's own
  EXPECT_DOUBLE_EQ(plant.foot_friction(2), 1.0);
  EXPECT_DOUBLE_EQ(plant.FrictionAt(1, -5.0, 0.0), 0.7);  // off the patch: the foot's own
  EXPECT_DOUBLE_EQ(plant.FrictionAt(2, 0.5, 0.0), 0.1);
  // the robot moved under the patch: the hind feet on it, the front feet beyond it
  dynamics::VectorQ q = HyqModel().StandingQ();
  q(0) = 1.9 - feet0[2];  // hind feet at x ≈ 1.9: on the patch
  plant.Reset(q, dynamics::VectorV::Zero());
  EXPECT_DOUBLE_EQ(plant.foot_friction(2), 0.1);
  EXPECT_DOUBLE_EQ(plant.foot_friction(3), 0.1);
  EXPECT_DOUBLE_EQ(plant.foot_friction(0), 1.0);
  EXPECT_DOUBLE_EQ(plant.foot_friction(1), 0.7);
  // SetFootFriction changes the foot's own μ, not the patch's
  plant.SetFootFriction(3, 0.4);
  EXPECT_DOUBLE_EQ(plant.foot_friction(3), 0.1);
  EXPECT_DOUBLE_EQ(plant.FrictionAt(3, -5.0, 0.0), 0.4);
}

// The force the friction estimator reads from the joint torques (J_legᵀ f = h_leg − τ_leg)
// against MuJoCo's own contact force, HyQ standing still under a joint PD on the ground
TEST(Plant, FootForceFromJointTorquesMatchesMujocosContactForce) {
  PlantConfig cfg;
  Plant plant(HyqModel(), cfg);
  const VectorJ q0 = HyqModel().q_standing;
  VectorJ tau = VectorJ::Zero();
  for (int k = 0; k < 2000; ++k) {  // settle
    tau = 2000.0 * (q0 - plant.q().tail<12>()) - 50.0 * plant.v().tail<12>();
    plant.Step(tau);
  }
  auto dyn = std::make_unique<dynamics::CycleDynamics>();
  ASSERT_EQ(dynamics::ComputeCycleDynamics(HyqModel(), plant.q(), plant.v(), dyn.get()),
            dynamics::DynamicsStatus::kOk);
  const auto contacts = plant.FootContacts();
  for (int f = 0; f < 4; ++f) {
    const Eigen::Vector3d measured = servo::FootForceFromJointTorques(*dyn, f, tau.segment<3>(3 * f));
    const Eigen::Vector3d truth = contacts[static_cast<std::size_t>(f)].force_W;
    ASSERT_TRUE(contacts[static_cast<std::size_t>(f)].touching) << f;
    // still: v̇ ≈ 0, so the only error is the settling's residual (measured 1e-? N)
    EXPECT_LT((measured - truth).norm(), 0.01 * truth.norm() + 1.0)
        << "foot " << f << ": from torques " << measured.transpose() << ", MuJoCo " << truth.transpose();
  }
}

}  // namespace
}  // namespace hyq::sim
