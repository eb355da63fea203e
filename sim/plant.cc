#include "sim/plant.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>
#include <mujoco/mujoco.h>

namespace hyq::sim {
namespace {

// Contact settings that give Coulomb friction (docs/simulation.md; DESIGN §7, measured): an
// elliptic cone with a high impedance ratio, a stiff floor, the floor's friction used.
constexpr const char* kFloorContact = "solref=\"0.005 1\" solimp=\"0.9 0.99 0.001\"";
// A joint's end stop (the cylinder's or the rotary actuator's mechanical stop) as stiff as the
// floor: with MuJoCo's default (solref 0.02) the trunk's weight, resting on folded knees after a
// sit-down, pushed a knee 0.15 rad past its URDF range.
constexpr const char* kJointStop = "solreflimit=\"0.005 1\"";

std::string Vec(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s.precision(17);
  s << v.x() << ' ' << v.y() << ' ' << v.z();
  return s.str();
}

std::string Quat(const Eigen::Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  std::ostringstream s;
  s.precision(17);
  s << q.w() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z();
  return s.str();
}

std::string FullInertia(const Eigen::Matrix3d& I) {
  std::ostringstream s;
  s.precision(17);
  s << I(0, 0) << ' ' << I(1, 1) << ' ' << I(2, 2) << ' ' << I(0, 1) << ' ' << I(0, 2) << ' '
    << I(1, 2);
  return s.str();
}

double FootMu(const PlantConfig& c, int f) { return c.foot_mu[f] >= 0 ? c.foot_mu[f] : c.ground_mu; }

std::string BoxName(int index) { return "box" + std::to_string(index); }

}  // namespace

double GroundHeight(const std::vector<GroundBox>& boxes, double x, double y) noexcept {
  double h = 0.0;
  for (const GroundBox& b : boxes)
    if (b.Contains(x, y)) h = std::max(h, b.height_m);
  return h;
}

std::string CoulombFloorMjcf(double mu) {
  std::ostringstream x;
  x << "<geom name=\"floor\" type=\"plane\" size=\"0 0 1\" contype=\"0\" conaffinity=\"2\" "
    << "priority=\"1\" condim=\"3\" friction=\"" << mu << " 0.005 0.0001\" " << kFloorContact
    << "/>";
  return x.str();
}

std::string CoulombBoxMjcf(const GroundBox& box, int index, double mu) {
  std::ostringstream x;
  x.precision(17);
  // MuJoCo's box: centre and half-sizes; resting on the floor, its bottom face on z = 0
  x << "<geom name=\"" << BoxName(index) << "\" type=\"box\" pos=\"" << 0.5 * (box.x0_m + box.x1_m)
    << ' ' << 0.5 * (box.y0_m + box.y1_m) << ' ' << 0.5 * box.height_m << "\" size=\""
    << 0.5 * (box.x1_m - box.x0_m) << ' ' << 0.5 * (box.y1_m - box.y0_m) << ' '
    << 0.5 * box.height_m << "\" contype=\"0\" conaffinity=\"2\" priority=\"1\" condim=\"3\" "
    << "friction=\"" << mu << " 0.005 0.0001\" " << kFloorContact << "/>";
  return x.str();
}

std::string MakeMjcf(const dynamics::Model& model, const PlantConfig& config) {
  using dynamics::kNumBodies;
  std::ostringstream x;
  x.precision(17);
  x << "<mujoco model=\"hyq\">\n"
    << "  <compiler angle=\"radian\" inertiafromgeom=\"false\" balanceinertia=\"false\"/>\n"
    << "  <option timestep=\"" << config.timestep_s
    << "\" cone=\"elliptic\" impratio=\"100\"/>\n"
    // the robot's own geoms collide only with the ground (contype 2 → the floor's and the
    // boxes' conaffinity 2); the feet touch the ground through explicit pairs that carry their
    // friction
    << "  <default><geom contype=\"2\" conaffinity=\"0\" condim=\"3\"/></default>\n"
    << "  <worldbody>\n    " << CoulombFloorMjcf(config.ground_mu) << "\n";
  for (std::size_t b = 0; b < config.boxes.size(); ++b)
    x << "    " << CoulombBoxMjcf(config.boxes[b], static_cast<int>(b), config.ground_mu) << "\n";
  // bodies, depth first (parents precede children in the model)
  std::array<int, kNumBodies> depth{};
  std::function<void(int, int)> emit = [&](int b, int indent) {
    const dynamics::Body& body = model.bodies[b];
    const std::string pad(static_cast<std::size_t>(indent), ' ');
    if (b == dynamics::kTrunk) {
      x << pad << "<body name=\"" << body.name << "\" pos=\"0 0 " << model.standing_base_height_m
        << "\">\n"
        << pad << "  <freejoint name=\"floating_base\"/>\n"
        << pad << "  <geom name=\"trunk\" type=\"box\" size=\"0.465 0.175 0.1\"/>\n"
        << pad << "  <site name=\"imu\" pos=\"" << Vec(model.imu.p_BF_B) << "\" quat=\""
        << Quat(model.imu.R_BF) << "\"/>\n";
    } else {
      const int j = b - 1;
      const auto& lim = model.limits[j];
      x << pad << "<body name=\"" << body.name << "\" pos=\"" << Vec(body.p_PJ_P) << "\" quat=\""
        << Quat(body.R_PJ) << "\">\n"
        << pad << "  <joint name=\"" << model.joint_names[j] << "\" type=\"hinge\" axis=\""
        << Vec(body.axis_B) << "\" limited=\"true\" range=\"" << lim.lower_rad << ' '
        << lim.upper_rad << "\" " << kJointStop << "/>\n";
      const int k = j % dynamics::kJointsPerLeg;
      if (k == 1) x << pad << "  <geom type=\"capsule\" fromto=\"0.05 0 0 0.3 0 0\" size=\"0.03\"/>\n";
      if (k == 2) {
        x << pad << "  <geom type=\"capsule\" fromto=\"0.05 0 0 0.3 0 0\" size=\"0.02\"/>\n";
        const dynamics::FootFrame& foot = model.feet[j / dynamics::kJointsPerLeg];
        x << pad << "  <geom name=\"" << foot.name << "\" type=\"sphere\" size=\"" << foot.radius_m
          << "\" pos=\"" << Vec(foot.p_BF_B) << "\" contype=\"0\" conaffinity=\"0\"/>\n";
      }
    }
    const auto& in = body.inertia;
    x << pad << "  <inertial pos=\"" << Vec(in.p_BoBcm_B) << "\" mass=\"" << in.mass
      << "\" fullinertia=\"" << FullInertia(in.I_Bcm_B) << "\"/>\n";
    for (int c = 0; c < kNumBodies; ++c)
      if (model.bodies[c].parent == b) emit(c, indent + 2);
    x << pad << "</body>\n";
  };
  (void)depth;
  emit(dynamics::kTrunk, 4);
  x << "  </worldbody>\n  <contact>\n";
  // a foot has one μ on the floor and on every box (Plant::ApplyPatches keeps them equal)
  auto pair = [&](int f, const std::string& suffix, const std::string& ground) {
    const double mu = FootMu(config, f);
    x << "    <pair name=\"" << model.feet[f].name << '_' << suffix << "\" geom1=\"" << ground
      << "\" geom2=\"" << model.feet[f].name << "\" condim=\"3\" friction=\"" << mu << ' ' << mu
      << " 0.005 0.0001 0.0001\" " << kFloorContact << "/>\n";
  };
  for (int f = 0; f < dynamics::kNumFeet; ++f) {
    pair(f, "floor", "floor");
    for (std::size_t b = 0; b < config.boxes.size(); ++b)
      pair(f, BoxName(static_cast<int>(b)), BoxName(static_cast<int>(b)));
  }
  x << "  </contact>\n  <actuator>\n";
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const double e = model.limits[j].effort_Nm;
    x << "    <motor name=\"" << model.joint_names[j] << "\" joint=\"" << model.joint_names[j]
      << "\" ctrllimited=\"true\" ctrlrange=\"" << -e << ' ' << e << "\"/>\n";
  }
  x << "  </actuator>\n";
  if (config.imu_sensor)
    x << "  <sensor>\n    <gyro name=\"imu_gyro\" site=\"imu\"/>\n"
      << "    <accelerometer name=\"imu_accel\" site=\"imu\"/>\n  </sensor>\n";
  x << "</mujoco>\n";
  return x.str();
}

double JointFrictionConfig::Torque(int joint, double qd) const noexcept {
  if (!enabled) return 0.0;
  const auto k = static_cast<std::size_t>(joint % dynamics::kJointsPerLeg);
  return -(coulomb_Nm[k] * std::tanh(qd / band_rad_s) + viscous_Nm_s[k] * qd);
}

dynamics::Model PerturbModel(const dynamics::Model& nominal, const ModelErrorConfig& e) {
  if (!(e.payload_kg >= 0) || !e.p_BoP_B.allFinite() || !(e.mass_rel >= 0 && e.mass_rel < 1) ||
      !(e.com_m >= 0) || !(e.inertia_rel >= 0 && e.inertia_rel < 1))
    throw std::invalid_argument("model error: expected payload >= 0 kg at a finite position, "
                                "0 <= mass and inertia errors < 1, CoM error >= 0");
  dynamics::Model m = nominal;
  if (e.link_errors) {
    // xorshift64* uniforms in [-1, 1): the same draws on every platform, in body order
    std::uint64_t s = e.seed == 0 ? 0x9E3779B97F4A7C15ull : e.seed;
    auto uniform = [&s] {
      s ^= s >> 12;
      s ^= s << 25;
      s ^= s >> 27;
      return 2.0 * static_cast<double>((s * 2685821657736338717ull) >> 11) * 0x1.0p-53 - 1.0;
    };
    for (dynamics::Body& b : m.bodies) {
      dynamics::RigidBodyInertia& in = b.inertia;
      in.mass *= 1.0 + e.mass_rel * uniform();
      for (int i = 0; i < 3; ++i) in.p_BoBcm_B(i) += e.com_m * uniform();
      // one factor for the whole tensor keeps it a physical inertia (triangle inequalities)
      in.I_Bcm_B *= 1.0 + e.inertia_rel * uniform();
    }
  }
  if (e.payload_kg > 0) {
    // a point mass lumped into the trunk: combined CoM, parallel-axis theorem for both parts
    dynamics::RigidBodyInertia& t = m.bodies[dynamics::kTrunk].inertia;
    const double mt = t.mass, mp = e.payload_kg, mc = mt + mp;
    const Eigen::Vector3d c = (mt * t.p_BoBcm_B + mp * e.p_BoP_B) / mc;
    auto shift = [](double mass, const Eigen::Vector3d& d) {
      return Eigen::Matrix3d(mass * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose()));
    };
    t.I_Bcm_B = t.I_Bcm_B + shift(mt, t.p_BoBcm_B - c) + shift(mp, e.p_BoP_B - c);
    t.p_BoBcm_B = c;
    t.mass = mc;
  }
  return m;
}

Plant::Plant(const dynamics::Model& model, const PlantConfig& config)
    : patches_(config.patches),
      boxes_(config.boxes),
      friction_(config.joint_friction) {
  if (friction_.enabled && !(friction_.band_rad_s > 0))
    throw std::invalid_argument("joint friction: expected a velocity band > 0 rad/s, found " +
                                std::to_string(friction_.band_rad_s));
  for (std::size_t b = 0; b < boxes_.size(); ++b) {
    const GroundBox& g = boxes_[b];
    if (!(std::isfinite(g.x0_m) && std::isfinite(g.x1_m) && std::isfinite(g.y0_m) &&
          std::isfinite(g.y1_m) && g.x0_m < g.x1_m && g.y0_m < g.y1_m && g.height_m > 0 &&
          std::isfinite(g.height_m)))
      throw std::invalid_argument(
          "box " + std::to_string(b) + ": expected finite x0 < x1, y0 < y1 and a height > 0 m, found [" +
          std::to_string(g.x0_m) + ", " + std::to_string(g.x1_m) + "] x [" + std::to_string(g.y0_m) +
          ", " + std::to_string(g.y1_m) + "], height " + std::to_string(g.height_m));
  }
  mjcf_ = MakeMjcf(PerturbModel(model, config.model_error), config);
  mjVFS vfs;
  mj_defaultVFS(&vfs);
  if (mj_makeEmptyFileVFS(&vfs, "hyq.xml", static_cast<int>(mjcf_.size())) != 0)
    throw PlantError("MuJoCo: cannot create the in-memory model file");
  std::memcpy(vfs.filedata[mj_findFileVFS(&vfs, "hyq.xml")], mjcf_.data(), mjcf_.size());
  char error[1000] = "";
  m_ = mj_loadXML("hyq.xml", &vfs, error, sizeof(error));
  mj_deleteVFS(&vfs);
  if (m_ == nullptr) throw PlantError(std::string("MuJoCo rejected the generated model: ") + error);
  d_ = mj_makeData(m_);
  floor_geom_ = mj_name2id(m_, mjOBJ_GEOM, "floor");
  for (int f = 0; f < dynamics::kNumFeet; ++f) {
    foot_geom_[f] = mj_name2id(m_, mjOBJ_GEOM, model.feet[f].name.c_str());
    foot_pairs_[f].push_back(mj_name2id(m_, mjOBJ_PAIR, (model.feet[f].name + "_floor").c_str()));
    for (std::size_t b = 0; b < boxes_.size(); ++b)
      foot_pairs_[f].push_back(mj_name2id(
          m_, mjOBJ_PAIR, (model.feet[f].name + '_' + BoxName(static_cast<int>(b))).c_str()));
    foot_body_[f] = m_->geom_bodyid[foot_geom_[f]];
    base_mu_[static_cast<std::size_t>(f)] = FootMu(config, f);
  }
  const int gyro = mj_name2id(m_, mjOBJ_SENSOR, "imu_gyro");
  const int accel = mj_name2id(m_, mjOBJ_SENSOR, "imu_accel");
  if (gyro >= 0) gyro_adr_ = m_->sensor_adr[gyro];
  if (accel >= 0) accel_adr_ = m_->sensor_adr[accel];
  Reset(model.StandingQ(), dynamics::VectorV::Zero());
}

Plant::~Plant() {
  if (d_ != nullptr) mj_deleteData(d_);
  if (m_ != nullptr) mj_deleteModel(m_);
}

void Plant::Reset(const dynamics::VectorQ& q, const dynamics::VectorV& v) {
  mj_resetData(m_, d_);
  Eigen::Map<dynamics::VectorQ>(d_->qpos) = q;
  Eigen::Map<dynamics::VectorV>(d_->qvel) = v;
  mj_forward(m_, d_);
  ApplyPatches();
}

void Plant::Step(const dynamics::VectorJ& tau_Nm) {
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    d_->ctrl[j] = tau_Nm(j);
    // joint friction at the velocity the step starts from (explicit: b h / I << 1 for HyQ's
    // links at h = 1 ms)
    d_->qfrc_applied[6 + j] = friction_.Torque(j, d_->qvel[6 + j]);
  }
  mj_step(m_, d_);
  ApplyPatches();
}

void Plant::SetLockDamping(const dynamics::VectorJ& b) noexcept {
  for (int j = 0; j < dynamics::kNumJoints; ++j) m_->dof_damping[6 + j] = b(j);
}

// each foot's contact pairs (the floor's and the boxes') take the μ of the ground under the
// sphere's centre (geom_xpos is the state the next step starts from)
void Plant::ApplyPatches() {
  if (patches_.empty()) return;
  for (int f = 0; f < dynamics::kNumFeet; ++f) {
    const mjtNum* p = d_->geom_xpos + 3 * foot_geom_[f];
    SetPairFriction(f, FrictionAt(f, p[0], p[1]));
  }
}

void Plant::SetPairFriction(int foot, double mu) {
  for (const int pair : foot_pairs_[static_cast<std::size_t>(foot)]) {
    m_->pair_friction[5 * pair + 0] = mu;
    m_->pair_friction[5 * pair + 1] = mu;
  }
}

bool Plant::IsGround(int geom) const noexcept { return m_->geom_bodyid[geom] == 0; }

double Plant::FrictionAt(int foot, double x, double y) const {
  for (const GroundPatch& p : patches_)
    if (p.Contains(x, y)) return p.mu;
  return base_mu_[static_cast<std::size_t>(foot)];
}

dynamics::VectorQ Plant::q() const { return Eigen::Map<const dynamics::VectorQ>(d_->qpos); }
dynamics::VectorV Plant::v() const { return Eigen::Map<const dynamics::VectorV>(d_->qvel); }
double Plant::time() const { return d_->time; }

ImuReading Plant::Imu() const {
  ImuReading r;
  if (gyro_adr_ >= 0) r.gyro_rad_s = Eigen::Map<const Eigen::Vector3d>(d_->sensordata + gyro_adr_);
  if (accel_adr_ >= 0)
    r.specific_force_m_s2 = Eigen::Map<const Eigen::Vector3d>(d_->sensordata + accel_adr_);
  return r;
}

bool Plant::IsFoot(int geom) const noexcept {
  return std::find(foot_geom_.begin(), foot_geom_.end(), geom) != foot_geom_.end();
}

bool Plant::BodyTouchesGround() const {
  for (int i = 0; i < d_->ncon; ++i) {
    const mjContact& c = d_->contact[i];
    const bool ground1 = IsGround(c.geom1), ground2 = IsGround(c.geom2);
    if (ground1 != ground2 && !IsFoot(ground1 ? c.geom2 : c.geom1)) return true;
  }
  return false;
}

bool Plant::BodyDownOnGround() const {
  for (int i = 0; i < d_->ncon; ++i) {
    const mjContact& c = d_->contact[i];
    const bool ground1 = IsGround(c.geom1), ground2 = IsGround(c.geom2);
    if (ground1 == ground2) continue;
    const int ground = ground1 ? c.geom1 : c.geom2, other = ground1 ? c.geom2 : c.geom1;
    if (IsFoot(other)) continue;
    // a shin on a box's edge: the lower leg's body is the foot's
    const int body = m_->geom_bodyid[other];
    if (ground != floor_geom_ &&
        std::find(foot_body_.begin(), foot_body_.end(), body) != foot_body_.end())
      continue;
    return true;
  }
  return false;
}

void Plant::SetFootFriction(int foot, double mu) {
  base_mu_[static_cast<std::size_t>(foot)] = mu;
  SetPairFriction(foot, mu);
  ApplyPatches();
}
double Plant::foot_friction(int foot) const {
  return m_->pair_friction[5 * foot_pairs_[static_cast<std::size_t>(foot)].front()];
}

std::array<FootContact, 4> Plant::FootContacts() const {
  std::array<FootContact, 4> out{};
  std::array<double, 4> strongest{};  // the largest normal force of each foot's contacts
  for (int i = 0; i < d_->ncon; ++i) {
    const mjContact& c = d_->contact[i];
    const bool ground1 = IsGround(c.geom1), ground2 = IsGround(c.geom2);
    if (ground1 == ground2) continue;
    const int other = ground1 ? c.geom2 : c.geom1;
    for (int f = 0; f < dynamics::kNumFeet; ++f) {
      if (other != foot_geom_[f]) continue;
      const auto fi = static_cast<std::size_t>(f);
      mjtNum local[6];
      mj_contactForce(m_, d_, i, local);
      // the contact frame's rows are its axes (normal first), pointing from geom1 to geom2; the
      // force is the one geom1 exerts on geom2
      const Eigen::Map<const Eigen::Matrix<mjtNum, 3, 3, Eigen::RowMajor>> frame(c.frame);
      Eigen::Vector3d f_W = frame.transpose() * Eigen::Vector3d(local[0], local[1], local[2]);
      if (c.geom1 == foot_geom_[f]) f_W = -f_W;
      const bool first = !out[fi].touching;
      out[fi].touching = true;
      out[fi].force_W += f_W;
      if (!first && local[0] <= strongest[fi]) continue;
      strongest[fi] = local[0];
      // velocity of the foot's material point at the contact
      mjtNum vel[6];
      mj_objectVelocity(m_, d_, mjOBJ_GEOM, foot_geom_[f], vel, 0);
      const Eigen::Vector3d w(vel[0], vel[1], vel[2]), v_c(vel[3], vel[4], vel[5]);
      const Eigen::Vector3d r = Eigen::Vector3d(c.pos[0], c.pos[1], c.pos[2]) -
                                Eigen::Vector3d(d_->geom_xpos + 3 * foot_geom_[f]);
      const Eigen::Vector3d v_p = v_c + w.cross(r);
      const Eigen::Vector3d n(c.frame[0], c.frame[1], c.frame[2]);
      out[fi].slip_velocity_W = v_p - v_p.dot(n) * n;
    }
  }
  return out;
}

}  // namespace hyq::sim
