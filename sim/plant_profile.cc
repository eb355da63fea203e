#include "sim/plant_profile.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace hyq::sim {
namespace {

// xorshift64* uniforms in [-1, 1) (the same draws on every platform); `stream` separates the
// load-cell, gyro and accelerometer draws so that one level does not shift the others
class Uniform {
 public:
  Uniform(std::uint64_t seed, std::uint64_t stream)
      : s_((seed == 0 ? 0x9E3779B97F4A7C15ull : seed) ^ (stream * 0xD1B54A32D192ED03ull)) {
    if (s_ == 0) s_ = 1;
  }
  double operator()() {
    s_ ^= s_ >> 12;
    s_ ^= s_ << 25;
    s_ ^= s_ >> 27;
    return 2.0 * static_cast<double>((s_ * 2685821657736338717ull) >> 11) * 0x1.0p-53 - 1.0;
  }

 private:
  std::uint64_t s_;
};

}  // namespace

const char* ToString(JointVelocity v) noexcept {
  switch (v) {
    case JointVelocity::kBoard: return "board";
    case JointVelocity::kExact: return "exact";
  }
  return "?";
}

JointVelocity JointVelocityByName(std::string_view name, const std::string& what) {
  if (name == "board") return JointVelocity::kBoard;
  if (name == "exact") return JointVelocity::kExact;
  throw std::invalid_argument(what + ": expected a joint velocity board or exact, found '" +
                              std::string(name) + "'");
}

PlantProfile PlantProfile::Ideal() { return PlantProfile{}; }

// The levels and their sources: docs/simulation.md, "Plant profiles".
PlantProfile PlantProfile::Realistic() {
  PlantProfile p;
  p.name = "realistic";
  p.model_error.payload_kg = 1.0;
  p.model_error.p_BoP_B = Eigen::Vector3d(0.10, 0.05, 0.08);
  p.model_error.link_errors = true;
  p.model_error.seed = 1;
  p.model_error.mass_rel = 0.05;
  p.model_error.com_m = 0.01;
  p.model_error.inertia_rel = 0.10;
  p.joint_friction.enabled = true;
  p.joint_friction.coulomb_Nm = {1.0, 1.0, 1.0};
  p.joint_friction.viscous_Nm_s = {0.2, 0.2, 0.2};
  p.joint_friction.band_rad_s = 0.01;
  p.hydraulics = true;
  p.delay_cycles = 1;
  p.load_cell_bias_Nm = 1.0;
  p.gyro_bias_rad_s = 0.0035;
  p.accel_bias_m_s2 = 0.05;
  p.bias_seed = 1;
  p.encoder_noise_rad = 1.2e-5;   // a quarter of a count (47.9 µrad): read-out jitter, assumed
  p.load_cell_noise_Nm = 0.1;     // 0.05 % of the sensors' full scale at the joint, assumed
  p.gyro_noise_rad_s = 0.0166;    // 0.03 °/s/√Hz × √(1 kHz)
  p.accel_noise_m_s2 = 0.0248;    // 80 µg/√Hz × √(1 kHz)
  return p;
}

PlantProfile ProfileByName(std::string_view name, const std::string& what) {
  if (name == "ideal") return PlantProfile::Ideal();
  if (name == "realistic") return PlantProfile::Realistic();
  throw std::invalid_argument(what + ": expected a plant profile ideal or realistic, found '" +
                              std::string(name) + "'");
}

void PlantProfile::ApplyTo(PlantConfig* pc) const {
  pc->model_error = model_error;
  pc->joint_friction = joint_friction;
}

std::array<double, dynamics::kNumJoints> PlantProfile::LoadCellBiases() const {
  std::array<double, dynamics::kNumJoints> b{};
  Uniform u(bias_seed, 1);
  for (double& x : b) x = load_cell_bias_Nm * u();
  return b;
}

Eigen::Vector3d PlantProfile::GyroBias() const {
  Uniform u(bias_seed, 2);
  Eigen::Vector3d b;
  for (int i = 0; i < 3; ++i) b(i) = gyro_bias_rad_s * u();
  return b;
}

Eigen::Vector3d PlantProfile::AccelBias() const {
  Uniform u(bias_seed, 3);
  Eigen::Vector3d b;
  for (int i = 0; i < 3; ++i) b(i) = accel_bias_m_s2 * u();
  return b;
}

std::string PlantProfile::Json() const {
  std::ostringstream s;
  s.precision(9);
  const auto& e = model_error;
  const auto& f = joint_friction;
  s << "{\"name\": \"" << name << "\", \"payload\": {\"mass_kg\": " << e.payload_kg
    << ", \"p_BoP_B_m\": [" << e.p_BoP_B.x() << ", " << e.p_BoP_B.y() << ", " << e.p_BoP_B.z()
    << "]}, \"link_errors\": ";
  if (e.link_errors)
    s << "{\"seed\": " << e.seed << ", \"mass_rel\": " << e.mass_rel << ", \"com_m\": " << e.com_m
      << ", \"inertia_rel\": " << e.inertia_rel << "}";
  else
    s << "null";
  s << ", \"joint_friction\": ";
  if (f.enabled)
    s << "{\"coulomb_Nm\": [" << f.coulomb_Nm[0] << ", " << f.coulomb_Nm[1] << ", " << f.coulomb_Nm[2]
      << "], \"viscous_Nm_s\": [" << f.viscous_Nm_s[0] << ", " << f.viscous_Nm_s[1] << ", "
      << f.viscous_Nm_s[2] << "], \"band_rad_s\": " << f.band_rad_s << "}";
  else
    s << "null";
  s << ", \"hydraulics\": ";
  if (hydraulics) {
    const auto& h = hydraulic;
    s << "{\"supply_pressure_Pa\": " << h.supply_pressure_Pa << ", \"bulk_modulus_Pa\": "
      << h.bulk_modulus_Pa << ", \"valve_bandwidth_hz\": " << h.valve_bandwidth_hz
      << ", \"valve_rated_flow_m3_s\": " << h.valve_rated_flow_m3_s << ", \"loop_rate_hz\": "
      << h.loop_rate_hz << "}";
  } else {
    s << "null";
  }
  s << ", \"pump_on\": " << (pump_on ? "true" : "false");
  s << ", \"delay_cycles\": " << delay_cycles << ", \"load_cell_bias_Nm\": " << load_cell_bias_Nm
    << ", \"gyro_bias_rad_s\": " << gyro_bias_rad_s << ", \"accel_bias_m_s2\": " << accel_bias_m_s2
    << ", \"bias_seed\": " << bias_seed << ", \"sensor_noise\": {\"encoder_rad\": "
    << encoder_noise_rad << ", \"load_cell_Nm\": " << load_cell_noise_Nm << ", \"gyro_rad_s\": "
    << gyro_noise_rad_s << ", \"accel_m_s2\": " << accel_noise_m_s2
    << "}, \"joint_velocity\": \"" << ToString(joint_velocity) << "\"";
  if (joint_velocity == JointVelocity::kBoard) s << ", \"velocity_cutoff_hz\": " << velocity_cutoff_hz;
  s << "}";
  return s.str();
}

Actuation::Actuation(const dynamics::Model& model, std::span<const hal::JointCalibration> joints,
                     const PlantProfile& profile, double lag_tau_s, double rate_limit_Nm_s,
                     double step_s)
    : profile_(profile),
      alpha_(lag_tau_s > 0 ? -std::expm1(-step_s / lag_tau_s) : 1.0),
      rate_step_Nm_(rate_limit_Nm_s * step_s),
      passthrough_(!(lag_tau_s > 0) && !(rate_limit_Nm_s > 0)),
      bias_(profile.LoadCellBiases()) {
  if (profile.delay_cycles < 0 || profile.delay_cycles > kMaxDelayCycles)
    throw std::invalid_argument("plant profile: expected a delay of 0.." +
                                std::to_string(kMaxDelayCycles) + " cycles, found " +
                                std::to_string(profile.delay_cycles));
  if (!(profile.load_cell_bias_Nm >= 0) || !(profile.gyro_bias_rad_s >= 0) ||
      !(profile.accel_bias_m_s2 >= 0))
    throw std::invalid_argument("plant profile: expected bias levels >= 0");
  if (profile.hydraulics && joints.size() != static_cast<std::size_t>(dynamics::kNumJoints))
    throw std::invalid_argument("plant profile: the hydraulic actuators need the HAL's 12 joint "
                                "calibrations, found " + std::to_string(joints.size()));
  // the actuators: stepped with the hydraulics, their lock's damping without them
  if (joints.size() == static_cast<std::size_t>(dynamics::kNumJoints)) {
    for (int j = 0; j < dynamics::kNumJoints; ++j) {
      const auto& lim = model.limits[static_cast<std::size_t>(j)];
      hyd_[static_cast<std::size_t>(j)] = std::make_unique<HydraulicActuator>(
          profile.hydraulic, joints[static_cast<std::size_t>(j)], lim.lower_rad, lim.upper_rad,
          step_s, model.joint_names[static_cast<std::size_t>(j)]);
    }
  }
  for (auto& slot : ring_) slot.setZero();
  for (auto& slot : on_ring_) slot.fill(true);
}

Actuation::~Actuation() = default;

const HydraulicActuator* Actuation::hydraulic(int joint) const noexcept {
  return profile_.hydraulics ? hyd_[static_cast<std::size_t>(joint)].get() : nullptr;
}

void Actuation::Reset(const dynamics::VectorJ& q) noexcept {
  for (auto& slot : ring_) slot.setZero();
  for (auto& slot : on_ring_) slot.fill(true);
  head_ = 0;
  applied_.setZero();
  lock_.setZero();
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    if (hyd_[static_cast<std::size_t>(j)]) hyd_[static_cast<std::size_t>(j)]->Reset(q(j), 0.0);
    measured_(j) = bias_[static_cast<std::size_t>(j)];
  }
}

void Actuation::Step(const dynamics::VectorJ& u, const std::array<bool, dynamics::kNumJoints>& on,
                     const dynamics::VectorJ& q, const dynamics::VectorJ& qd) noexcept {
  // the delay line: the set-point given now comes out delay_cycles steps later
  const int n = profile_.delay_cycles + 1;
  ring_[static_cast<std::size_t>(head_)] = u;
  on_ring_[static_cast<std::size_t>(head_)] = on;
  const dynamics::VectorJ& cmd = ring_[static_cast<std::size_t>((head_ + 1) % n)];
  const std::array<bool, dynamics::kNumJoints>& cmd_on = on_ring_[static_cast<std::size_t>((head_ + 1) % n)];
  head_ = (head_ + 1) % n;
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const auto i = static_cast<std::size_t>(j);
    double out;
    HydraulicActuator* h = hyd_[i].get();
    lock_(j) = 0.0;
    if (h != nullptr && profile_.hydraulics) {
      // the pump off: nothing locks the joint (the board's loop at its 0 N·m stands for that)
      applied_(j) = h->Step(cmd(j), q(j), qd(j), cmd_on[i] || !profile_.pump_on);
      out = h->torque_Nm();
    } else if (!cmd_on[i]) {
      // outputs off: no torque from the board, the joint locked by its closed valve
      applied_(j) = 0.0;
      // its damping, bounded so that the torque stays under the relief valve's (a leg swinging
      // when its valve closes is stopped by at most that, not in one step)
      if (h != nullptr && profile_.pump_on) {
        const double b = h->LockDamping(q(j)), speed = std::abs(qd(j));
        lock_(j) = speed * b > h->LockTorqueLimitNm(q(j)) ? h->LockTorqueLimitNm(q(j)) / speed : b;
      }
      out = 0.0;
    } else {
      if (passthrough_) {
        applied_(j) = cmd(j);  // ideal: exactly the set-point
        measured_(j) = cmd(j) + bias_[static_cast<std::size_t>(j)];
        continue;
      }
      // SimulatedRobot's eq. (1) and its rate limit
      double d = alpha_ * (cmd(j) - applied_(j));
      if (rate_step_Nm_ > 0) d = std::clamp(d, -rate_step_Nm_, rate_step_Nm_);
      applied_(j) += d;
      out = applied_(j);
    }
    measured_(j) = out + bias_[static_cast<std::size_t>(j)];
  }
}

}  // namespace hyq::sim
