// Steps on the ground (sim::GroundBox): a box's top is ground like the floor, for the feet (their
// contact pairs, forces and friction), for the trunk and the legs (fall detection) and for the
// simulated robot's start posture.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <span>
#include <string>
#include <vector>

#include "dynamics/leg_kinematics.h"
#include "hal/loopback_bus.h"
#include "sim/plant.h"
#include "sim/simulated_robot.h"
#include "tests/hil/hil_rig.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::sim {
namespace {

using testing::HilModel;

constexpr double kStep = 0.03;      // the 3 cm step of the touchdown tests
constexpr double kRestTol = 0.002;  // a loaded foot's sphere centre, from ground + radius
constexpr int kLf = 0, kRf = 1;

double Weight() { return HilModel().TotalMass() * 9.81; }

// Where a foot stands in the standing posture with the base over the origin (world x-y).
Eigen::Vector3d StandingFoot(int leg) {
  const dynamics::LegKinematics legs(HilModel());
  return legs.Foot(leg, HilModel().q_standing.segment<3>(3 * leg));
}

// A square box of side `side_m` centred under the standing place of `leg`.
GroundBox BoxUnder(int leg, double height_m, double side_m = 0.3) {
  const Eigen::Vector3d p = StandingFoot(leg);
  return {p.x() - side_m / 2, p.x() + side_m / 2, p.y() - side_m / 2, p.y() + side_m / 2, height_m};
}

// The standing posture with the base at the standing height, each foot's sphere on `ground_m`
// (by the legs' inverse kinematics; the test's own construction, not SimulatedRobot's).
dynamics::VectorQ StandingOn(const std::array<double, 4>& ground_m) {
  const dynamics::Model& model = HilModel();
  const dynamics::LegKinematics legs(model);
  dynamics::VectorQ q = model.StandingQ();
  for (int leg = 0; leg < 4; ++leg) {
    dynamics::FootMotion foot;
    foot.p_BF_B = StandingFoot(leg);
    foot.p_BF_B.z() = ground_m[static_cast<std::size_t>(leg)] + model.feet[leg].radius_m -
                      model.standing_base_height_m;
    dynamics::LegJointMotion j;
    EXPECT_EQ(legs.Solve(leg, foot, model.q_standing.segment<3>(3 * leg), &j), dynamics::IkStatus::kOk);
    q.segment<3>(7 + 3 * leg) = j.q;
  }
  return q;
}

// The foot's sphere centre in the world, as MuJoCo has it.
Eigen::Vector3d FootCentre(const Plant& plant, int leg) {
  const int g = mj_name2id(plant.mj_model(), mjOBJ_GEOM, HilModel().feet[leg].name.c_str());
  const mjtNum* p = const_cast<Plant&>(plant).mj_data()->geom_xpos + 3 * g;
  return {p[0], p[1], p[2]};
}

// The names of the ground geoms the foot's contacts are with ("floor", "box0", ...).
std::vector<std::string> GroundsTouched(const Plant& plant, int leg) {
  const mjModel* m = plant.mj_model();
  const mjData* d = const_cast<Plant&>(plant).mj_data();
  const int foot = mj_name2id(m, mjOBJ_GEOM, HilModel().feet[leg].name.c_str());
  std::vector<std::string> out;
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& c = d->contact[i];
    if (c.geom1 != foot && c.geom2 != foot) continue;
    out.emplace_back(mj_id2name(m, mjOBJ_GEOM, c.geom1 == foot ? c.geom2 : c.geom1));
  }
  return out;
}

// Holds the joint posture of q0 with a stiff PD for `steps` plant steps.
void Hold(Plant* plant, const dynamics::VectorQ& q0, int steps) {
  const dynamics::VectorJ qj = q0.tail<12>();
  for (int k = 0; k < steps; ++k)
    plant->Step(600.0 * (qj - plant->q().tail<12>()) - 20.0 * plant->v().tail<12>());
}

// --- without MuJoCo's physics ---------------------------------------------------------------

TEST(GroundBox, GroundHeightIsTheHighestBoxOverThePointElseTheFloor) {
  const std::vector<GroundBox> boxes = {{0.0, 1.0, 0.0, 1.0, 0.03}, {0.5, 2.0, 0.0, 1.0, 0.10}};
  EXPECT_EQ(GroundHeight({}, 0.5, 0.5), 0.0);
  EXPECT_EQ(GroundHeight(boxes, -0.1, 0.5), 0.0);
  EXPECT_EQ(GroundHeight(boxes, 0.2, 0.5), 0.03);
  EXPECT_EQ(GroundHeight(boxes, 0.7, 0.5), 0.10);  // overlap: the higher
  EXPECT_EQ(GroundHeight(boxes, 1.0, 1.0), 0.10);  // edges belong to the box
  EXPECT_EQ(GroundHeight(boxes, 1.5, 1.01), 0.0);
}

// No boxes: the model is the floor's alone (the per-step cost of a run without steps is
// unchanged); each box adds one geom and one contact pair per foot, with the floor's settings.
TEST(GroundBox, EachBoxIsAGeomWithOnePairPerFootAndNoBoxesAddNothing) {
  auto count = [](const std::string& s, const std::string& what) {
    int n = 0;
    for (std::size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
    return n;
  };
  PlantConfig cfg;
  const std::string flat = MakeMjcf(HilModel(), cfg);
  EXPECT_EQ(count(flat, "<pair "), 4);
  EXPECT_EQ(count(flat, "type=\"box\""), 1);  // the trunk
  cfg.boxes = {{0.0, 1.0, -0.5, 0.5, 0.03}, {2.0, 3.0, -0.5, 0.5, 0.1}};
  const std::string stepped = MakeMjcf(HilModel(), cfg);
  EXPECT_EQ(count(stepped, "<pair "), 12);
  EXPECT_EQ(count(stepped, "type=\"box\""), 3);
  EXPECT_EQ(count(stepped, "geom1=\"box1\" geom2=\"rh_foot\""), 1);
  EXPECT_NE(stepped.find("name=\"box0\" type=\"box\" pos=\"0.5 0 0.014999999999999999\" "
                         "size=\"0.5 0.5 0.014999999999999999\""),
            std::string::npos)
      << stepped;
}

TEST(GroundBox, AMalformedBoxIsRefusedAtConfigurationTime) {
  for (const GroundBox& bad : {GroundBox{1.0, 0.0, 0.0, 1.0, 0.03}, GroundBox{0.0, 1.0, 0.0, 0.0, 0.03},
                               GroundBox{0.0, 1.0, 0.0, 1.0, 0.0}, GroundBox{0.0, 1.0, 0.0, 1.0, NAN}}) {
    PlantConfig cfg;
    cfg.boxes = {bad};
    EXPECT_THROW(Plant(HilModel(), cfg), std::invalid_argument);
  }
}

// --- the plant ------------------------------------------------------------------------------

// HyQ standing with the LF foot on a 3 cm box: that foot rests on the box's top and carries its
// share of the weight; the RF foot, 1 cm beside a second box, stands on the floor.
TEST(GroundBox, AFootOnABoxRestsOnItsTopAndCarriesLoadAFootBesideItOnTheFloor) {
  const dynamics::Model& model = HilModel();
  const double r = model.feet[kLf].radius_m;
  PlantConfig cfg;
  const Eigen::Vector3d rf = StandingFoot(kRf);
  // inboard of RF (towards +y), its edge 1 cm from the sphere
  cfg.boxes = {BoxUnder(kLf, kStep), {rf.x() - 0.15, rf.x() + 0.15, rf.y() + r + 0.01, rf.y() + 0.3, kStep}};
  Plant plant(model, cfg);
  const dynamics::VectorQ q0 = StandingOn({kStep, 0.0, 0.0, 0.0});
  plant.Reset(q0, dynamics::VectorV::Zero());
  Hold(&plant, q0, 2000);
  const auto contacts = plant.FootContacts();
  double fz = 0.0;
  for (int leg = 0; leg < 4; ++leg) {
    const auto i = static_cast<std::size_t>(leg);
    const double ground = leg == kLf ? kStep : 0.0;
    const Eigen::Vector3d p = FootCentre(plant, leg);
    std::printf("%s: centre z %.5f m (ground %.2f + r %.5f), fz %.1f N, on", model.feet[leg].name.c_str(),
                p.z(), ground, r, contacts[i].force_W.z());
    for (const std::string& g : GroundsTouched(plant, leg)) std::printf(" %s", g.c_str());
    std::printf("\n");
    EXPECT_NEAR(p.z(), ground + r, kRestTol) << model.feet[leg].name;
    EXPECT_TRUE(contacts[i].touching) << model.feet[leg].name;
    EXPECT_GT(contacts[i].force_W.z(), 0.15 * Weight()) << model.feet[leg].name;
    EXPECT_EQ(GroundsTouched(plant, leg),
              std::vector<std::string>{leg == kLf ? "box0" : "floor"}) << model.feet[leg].name;
    fz += contacts[i].force_W.z();
  }
  EXPECT_NEAR(fz, Weight(), 0.02 * Weight());
  EXPECT_FALSE(plant.BodyTouchesGround());
  EXPECT_NEAR(plant.q()(2), model.standing_base_height_m, 0.03);  // the PD's sag
}

// A foot on a box has the μ a foot on the floor has: its own (foot_mu, SetFootFriction) or the
// patch's under its sphere; the box's pair follows it, and the tangential force stays within it.
TEST(GroundBox, AFootOnABoxHasTheFrictionItWouldHaveOnTheFloor) {
  const dynamics::Model& model = HilModel();
  PlantConfig cfg;
  cfg.boxes = {BoxUnder(kLf, kStep)};
  cfg.foot_mu = {0.05, -1.0, -1.0, -1.0};  // LF on ice
  Plant plant(model, cfg);
  const mjModel* m = plant.mj_model();
  const int box_pair = mj_name2id(m, mjOBJ_PAIR, "lf_foot_box0");
  ASSERT_GE(box_pair, 0);
  EXPECT_DOUBLE_EQ(m->pair_friction[5 * box_pair], 0.05);
  EXPECT_DOUBLE_EQ(plant.foot_friction(kLf), 0.05);
  const dynamics::VectorQ q0 = StandingOn({kStep, 0.0, 0.0, 0.0});
  plant.Reset(q0, dynamics::VectorV::Zero());
  // wiggle the LF hip sideways: the foot on the box never holds more than 0.05 of its load
  double worst = 0.0;
  for (int k = 0; k < 1500; ++k) {
    dynamics::VectorJ target = q0.tail<12>();
    target(dynamics::JointIndex(kLf, 0)) += 0.2 * std::sin(k * 1e-2);
    plant.Step(600.0 * (target - plant.q().tail<12>()) - 20.0 * plant.v().tail<12>());
    const FootContact c = plant.FootContacts()[kLf];
    if (c.touching && c.force_W.z() > 10.0) worst = std::max(worst, c.force_W.head<2>().norm() / c.force_W.z());
  }
  EXPECT_GT(worst, 0.04) << "the foot did not slide: the test did not test the limit";
  EXPECT_LE(worst, 0.05 * 1.03);
  EXPECT_EQ(GroundsTouched(plant, kLf), std::vector<std::string>{"box0"});
  // a patch over the box gives the foot on it the patch's μ, on every pair of the foot
  plant.SetFootFriction(kLf, 0.8);
  EXPECT_DOUBLE_EQ(m->pair_friction[5 * box_pair], 0.8);
  PlantConfig patched = cfg;
  const GroundBox& b = cfg.boxes[0];
  patched.patches = {{b.x0_m, b.x1_m, b.y0_m, b.y1_m, 0.3}};
  Plant on_patch(model, patched);
  on_patch.Reset(q0, dynamics::VectorV::Zero());
  EXPECT_DOUBLE_EQ(on_patch.foot_friction(kLf), 0.3);
  EXPECT_DOUBLE_EQ(on_patch.mj_model()->pair_friction[5 * box_pair], 0.3);
}

// The lowest point of the LF lower leg's capsule (the shin), world frame.
Eigen::Vector3d ShinLowestPoint(const Plant& plant) {
  const mjModel* m = plant.mj_model();
  const mjData* d = const_cast<Plant&>(plant).mj_data();
  const int foot = mj_name2id(m, mjOBJ_GEOM, HilModel().feet[kLf].name.c_str());
  for (int g = 0; g < m->ngeom; ++g) {
    if (g == foot || m->geom_bodyid[g] != m->geom_bodyid[foot] || m->geom_type[g] != mjGEOM_CAPSULE)
      continue;
    const Eigen::Vector3d c(d->geom_xpos[3 * g], d->geom_xpos[3 * g + 1], d->geom_xpos[3 * g + 2]);
    const Eigen::Vector3d axis(d->geom_xmat[9 * g + 2], d->geom_xmat[9 * g + 5], d->geom_xmat[9 * g + 8]);
    const double half = m->geom_size[3 * g + 1];
    const Eigen::Vector3d end = c + (axis.z() < 0 ? half : -half) * axis;
    return end - Eigen::Vector3d(0, 0, m->geom_size[3 * g]);
  }
  ADD_FAILURE() << "no capsule on the LF foot's body";
  return Eigen::Vector3d::Zero();
}

// A shin on a box's edge (what stepping past the edge does; measured through the loop with
// today's trot) is the legs touching the ground, but not the robot down on it; the same shin on
// the floor is both.
TEST(GroundBox, AShinGrazingABoxIsNotTheRobotDownOnTheGround) {
  const dynamics::Model& model = HilModel();
  const dynamics::VectorQ q0 = model.StandingQ();
  Plant probe(model, PlantConfig{});
  probe.Reset(q0, dynamics::VectorV::Zero());
  const Eigen::Vector3d p = ShinLowestPoint(probe);
  ASSERT_GT(p.z(), 0.0);
  PlantConfig cfg;
  cfg.boxes = {{p.x() - 0.01, p.x() + 0.01, p.y() - 0.01, p.y() + 0.01, p.z() + 0.001}};
  Plant grazed(model, cfg);
  grazed.Reset(q0, dynamics::VectorV::Zero());
  EXPECT_TRUE(grazed.BodyTouchesGround());
  EXPECT_FALSE(grazed.BodyDownOnGround());
  Plant low(model, PlantConfig{});
  dynamics::VectorQ q_low = q0;
  q_low(2) -= p.z() + 0.001;
  low.Reset(q_low, dynamics::VectorV::Zero());
  EXPECT_TRUE(low.BodyTouchesGround());
  EXPECT_TRUE(low.BodyDownOnGround());
}

// A step of the plant with boxes and patches, its contact reading and the fall rule's queries
// touch no heap (the simulated robot's lock-step cycle runs them every step).
TEST(GroundBox, SteppingAndReadingTheGroundDoNotAllocate) {
  HYQ_REQUIRE_HEAP_HOOKS();
  PlantConfig cfg;
  cfg.boxes = {BoxUnder(kLf, kStep), {-2.0, -1.0, -1.0, 1.0, 0.1}};
  const GroundBox& b = cfg.boxes[0];
  cfg.patches = {{b.x0_m, b.x1_m, b.y0_m, b.y1_m, 0.3}};
  Plant plant(HilModel(), cfg);
  const dynamics::VectorQ q0 = StandingOn({kStep, 0.0, 0.0, 0.0});
  plant.Reset(q0, dynamics::VectorV::Zero());
  Hold(&plant, q0, 10);  // warm-up
  bool touching = false;
  double z = 0.0;
  testing::NoHeapGuard guard;
  for (int k = 0; k < 100; ++k) {
    Hold(&plant, q0, 1);
    touching = plant.FootContacts()[kLf].touching;
    touching = touching && !plant.BodyDownOnGround() && !plant.BodyTouchesGround();
    z += plant.GroundHeightAt(plant.q()(0), plant.q()(1));
    plant.SetFootFriction(kRf, 0.5);
  }
  EXPECT_EQ(guard.allocations(), 0u);
  EXPECT_TRUE(touching);
  EXPECT_EQ(z, 0.0);
}

// --- the simulated robot --------------------------------------------------------------------

// A SimulatedRobot on in-process loopback buses that nobody drives (its steps taken directly).
struct Robot {
  explicit Robot(const SimulatedRobotConfig& rc) : cfg(testing::HilHalConfig()) {
    std::vector<hal::CanChannel*> d;
    for (const hal::BusConfig& b : cfg.buses) {
      wires.push_back(std::make_unique<hal::LoopbackBus>(b.name, 2, 256, true));
      d.push_back(&wires.back()->endpoint(1));
    }
    robot = std::make_unique<SimulatedRobot>(HilModel(), cfg, d, rc);
  }
  hal::HalConfig cfg;
  std::vector<std::unique_ptr<hal::LoopbackBus>> wires;
  std::unique_ptr<SimulatedRobot> robot;
};

// The start posture puts a foot over a box on the box's top: standing (start height 0) and in
// the resting crouch; on a platform under all four feet the base height is above the platform.
TEST(GroundBox, TheSimulatedRobotStartsWithEachFootOnTheGroundUnderIt) {
  const dynamics::Model& model = HilModel();
  const double r = model.feet[kLf].radius_m;
  for (const double start : {0.0, 0.40}) {
    SimulatedRobotConfig rc;
    rc.start_height_m = start;
    rc.plant.boxes = {BoxUnder(kLf, kStep)};
    Robot one(rc);
    const double base = start > 0 ? start : model.standing_base_height_m;
    EXPECT_NEAR(one.robot->plant().q()(2), base, 1e-12);
    for (int leg = 0; leg < 4; ++leg)
      EXPECT_NEAR(FootCentre(one.robot->plant(), leg).z(), (leg == kLf ? kStep : 0.0) + r, 1e-6)
          << "start " << start << ", " << model.feet[leg].name;
    rc.plant.boxes = {{-1.0, 1.0, -1.0, 1.0, 0.1}};
    Robot platform(rc);
    EXPECT_NEAR(platform.robot->plant().q()(2), base + 0.1, 1e-12);
    for (int leg = 0; leg < 4; ++leg)
      EXPECT_NEAR(FootCentre(platform.robot->plant(), leg).z(), 0.1 + r, 1e-6) << model.feet[leg].name;
  }
}

// The in-process rig (tests/hil/hil_rig.h) with a 3 cm step under LF: brought up and held by
// the rig's joint PD, HyQ stands with LF loaded on the box's top and does not fall.
TEST(GroundBox, TheInProcessRigStandsWithOneFootOnAStep) {
  SimulatedRobotConfig rc = testing::Standing();
  rc.plant.boxes = {BoxUnder(kLf, kStep)};
  testing::LoopbackRig rig(rc);
  rig.BringUp();
  for (int i = 0; i < 1500; ++i)
    (void)rig.Cycle([](hal::ProcessImage& im) { testing::StandingPd(HilModel(), im); });
  EXPECT_FALSE(rig.robot->holding());
  EXPECT_FALSE(rig.robot->fell());
  EXPECT_FALSE(rig.robot->sat_down());
  const Plant& plant = rig.robot->plant();
  const FootContact lf = plant.FootContacts()[kLf];
  const double z = FootCentre(plant, kLf).z();
  std::printf("LF on the step: centre z %.5f m, fz %.1f N (%.0f %% of the weight)\n", z,
              lf.force_W.z(), 100 * lf.force_W.z() / Weight());
  EXPECT_NEAR(z, kStep + HilModel().feet[kLf].radius_m, kRestTol);
  EXPECT_TRUE(lf.touching);
  EXPECT_GT(lf.force_W.z(), 0.1 * Weight());
}

// HyQ, unpowered, collapses onto a 0.3 m box under its trunk (between its feet): the trunk on
// the box is a ground contact (a fall at that speed) with the base far above the floor. The
// height rule is off (fall height 0), so the contact alone is what is seen.
TEST(GroundBox, TheTrunkLandingOnABoxIsAFall) {
  SimulatedRobotConfig rc = testing::Standing();
  rc.hold = false;
  rc.profile.pump_on = false;  // unpowered: the legs fold
  rc.fall_height_m = 0.0;
  rc.plant.boxes = {{-0.2, 0.2, -0.1, 0.1, 0.3}};
  Robot r(rc);
  const mjModel* m = r.robot->plant().mj_model();
  const int trunk = mj_name2id(m, mjOBJ_GEOM, "trunk"), box = mj_name2id(m, mjOBJ_GEOM, "box0");
  bool trunk_on_box = false;
  double z_at_contact = 0.0;
  r.robot->SetStepObserver([&](const SimulatedRobot& s) {
    if (z_at_contact > 0.0 || !(s.fell() || s.sat_down())) return;
    z_at_contact = s.plant().q()(2);
    const mjData* d = const_cast<SimulatedRobot&>(s).plant().mj_data();
    for (int i = 0; i < d->ncon; ++i)
      trunk_on_box = trunk_on_box || (d->contact[i].geom1 == box && d->contact[i].geom2 == trunk) ||
                     (d->contact[i].geom1 == trunk && d->contact[i].geom2 == box);
  });
  while (r.robot->time_s() < 2.0 && !r.robot->fell() && !r.robot->sat_down()) r.robot->Step();
  std::printf("ground contact at %.3f s, base z %.3f m, %.2f m/s down, trunk on the box: %d\n",
              r.robot->fell() ? r.robot->fell_at_s() : r.robot->sat_down_at_s(), z_at_contact,
              r.robot->contact_speed_m_s(), trunk_on_box ? 1 : 0);
  EXPECT_TRUE(r.robot->fell());
  EXPECT_TRUE(trunk_on_box);
  EXPECT_GT(z_at_contact, 0.3 + 0.1 - 0.01);  // the trunk's half-height above the box's top
}

// The fall height is measured from the ground under the base: HyQ standing on a 0.2 m platform,
// unpowered, folds its legs onto their stops (its base comes to rest 0.27 m above the platform,
// 0.47 m above the floor); with a fall height of 0.35 m that is a ground contact when the base
// passes 0.2 + 0.35 m, before the trunk touches anything (measured from the floor, never).
TEST(GroundBox, TheFallHeightIsAboveTheGroundUnderTheBase) {
  SimulatedRobotConfig rc = testing::Standing();
  rc.hold = false;
  rc.profile.pump_on = false;  // unpowered: the legs fold
  rc.fall_height_m = 0.35;
  rc.plant.boxes = {{-1.5, 1.5, -1.0, 1.0, 0.2}};
  Robot r(rc);
  double z_at_contact = 0.0;
  bool body_touching = true;
  r.robot->SetStepObserver([&](const SimulatedRobot& s) {
    if (z_at_contact > 0.0 || !(s.fell() || s.sat_down())) return;
    z_at_contact = s.plant().q()(2);
    body_touching = s.plant().BodyTouchesGround();
  });
  while (r.robot->time_s() < 2.0 && !r.robot->fell() && !r.robot->sat_down()) r.robot->Step();
  std::printf("ground contact at base z %.3f m (platform 0.2 m), body touching: %d\n", z_at_contact,
              body_touching ? 1 : 0);
  EXPECT_GT(r.robot->time_s(), 0.01);
  EXPECT_TRUE(r.robot->fell() || r.robot->sat_down());
  EXPECT_NEAR(z_at_contact, 0.2 + 0.35, 0.01);
  EXPECT_FALSE(body_touching);
}

}  // namespace
}  // namespace hyq::sim
