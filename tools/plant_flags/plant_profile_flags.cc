#include "tools/plant_flags/plant_profile_flags.h"

#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace hyq::cli {
namespace {

constexpr double kNoMax = std::numeric_limits<double>::max();
constexpr long long kMaxSeed = std::numeric_limits<long long>::max();

// "on" or "off" as a bool
bool OnOff(CommandLine& cl) {
  const std::string v = cl.Value();
  if (v != "on" && v != "off") cl.BadValue("on or off", v);
  return v == "on";
}

}  // namespace

bool PlantProfileFlags::Read(CommandLine& cl) {
  using sim::PlantProfile;
  if (cl.Flag("--profile")) {
    const std::string v = cl.Value();
    try {
      named_ = sim::ProfileByName(v, "--profile");
    } catch (const std::invalid_argument& e) {
      cl.Fail(e.what());
    }
  } else if (cl.Flag("--payload")) {
    const std::string v = cl.Value();
    if (v == "off") {
      factors_.push_back([](PlantProfile* p) { p->model_error.payload_kg = 0.0; });
      return true;
    }
    const std::vector<std::string> f = Split(v, ',');
    if (f.size() != 4)
      cl.BadValue("KG,X,Y,Z (kg >= 0; m in the trunk frame, |X|,|Y|,|Z| <= 2) or off", v);
    const double kg = cl.NumberOf("--payload KG", f[0], 0.0, kNoMax, "kilograms >= 0");
    const Eigen::Vector3d pos(cl.NumberOf("--payload X", f[1], -2.0, 2.0),
                              cl.NumberOf("--payload Y", f[2], -2.0, 2.0),
                              cl.NumberOf("--payload Z", f[3], -2.0, 2.0));
    factors_.push_back([kg, pos](PlantProfile* p) {
      p->model_error.payload_kg = kg;
      p->model_error.p_BoP_B = pos;
    });
  } else if (cl.Flag("--link-errors")) {
    const std::string v = cl.Value();
    const std::optional<long long> seed = ParseInteger(v);
    if (v != "off" && (!seed || *seed < 0)) cl.BadValue("a seed (unsigned integer) or off", v);
    factors_.push_back([on = v != "off", seed](PlantProfile* p) {
      p->model_error.link_errors = on;
      if (on) p->model_error.seed = static_cast<std::uint64_t>(*seed);
    });
  } else if (cl.Flag("--hydraulics")) {
    factors_.push_back([on = OnOff(cl)](PlantProfile* p) { p->hydraulics = on; });
  } else if (cl.Flag("--joint-friction")) {
    factors_.push_back([on = OnOff(cl)](PlantProfile* p) {
      p->joint_friction = on ? PlantProfile::Realistic().joint_friction : sim::JointFrictionConfig{};
    });
  } else if (cl.Flag("--delay-cycles")) {
    const auto k = static_cast<int>(cl.Integer(
        0, sim::kMaxDelayCycles, "an integer 0.." + std::to_string(sim::kMaxDelayCycles)));
    factors_.push_back([k](PlantProfile* p) { p->delay_cycles = k; });
  } else if (cl.Flag("--load-cell-bias")) {
    const double b = cl.Number(0.0, kNoMax, "N·m >= 0");
    factors_.push_back([b](PlantProfile* p) { p->load_cell_bias_Nm = b; });
  } else if (sensors_ && cl.Flag("--imu-bias")) {
    const std::string v = cl.Value();
    const std::vector<std::string> f = Split(v, ',');
    if (f.size() != 2) cl.BadValue("G,A (rad/s, m/s², >= 0)", v);
    const double g = cl.NumberOf("--imu-bias G", f[0], 0.0, kNoMax, "rad/s >= 0");
    const double a = cl.NumberOf("--imu-bias A", f[1], 0.0, kNoMax, "m/s² >= 0");
    factors_.push_back([g, a](PlantProfile* p) {
      p->gyro_bias_rad_s = g;
      p->accel_bias_m_s2 = a;
    });
  } else if (sensors_ && cl.Flag("--encoder-noise")) {
    const double n = cl.Number(0.0, kNoMax, "rad >= 0");
    factors_.push_back([n](PlantProfile* p) { p->encoder_noise_rad = n; });
  } else if (sensors_ && cl.Flag("--load-cell-noise")) {
    const double n = cl.Number(0.0, kNoMax, "N·m >= 0");
    factors_.push_back([n](PlantProfile* p) { p->load_cell_noise_Nm = n; });
  } else if (sensors_ && cl.Flag("--imu-noise")) {
    const std::string v = cl.Value();
    const std::vector<std::string> f = Split(v, ',');
    if (f.size() > 2) cl.BadValue("GYRO[,ACCEL] (rad/s, m/s²)", v);
    const double g = cl.NumberOf("--imu-noise GYRO", f[0], 0.0, kNoMax, "rad/s >= 0");
    const std::optional<double> a =
        f.size() == 2 ? std::optional<double>(cl.NumberOf("--imu-noise ACCEL", f[1], 0.0, kNoMax, "m/s² >= 0"))
                      : std::nullopt;
    factors_.push_back([g, a](PlantProfile* p) {
      p->gyro_noise_rad_s = g;
      if (a) p->accel_noise_m_s2 = *a;
    });
  } else if (sensors_ && cl.Flag("--joint-velocity")) {
    const std::string v = cl.Value();
    sim::JointVelocity jv = sim::JointVelocity::kBoard;
    try {
      jv = sim::JointVelocityByName(v, "--joint-velocity");
    } catch (const std::invalid_argument& e) {
      cl.Fail(e.what());
    }
    factors_.push_back([jv](PlantProfile* p) { p->joint_velocity = jv; });
  } else if (sensors_ && cl.Flag("--velocity-cutoff")) {
    const double hz = cl.Number(0.0, 1e6, "Hz >= 0 (0: no filter)");
    factors_.push_back([hz](PlantProfile* p) { p->velocity_cutoff_hz = hz; });
  } else if (cl.Flag("--bias-seed")) {
    const auto seed = static_cast<std::uint64_t>(cl.Integer(0, kMaxSeed, "an unsigned integer"));
    factors_.push_back([seed](PlantProfile* p) { p->bias_seed = seed; });
  } else {
    return false;
  }
  return true;
}

sim::PlantProfile PlantProfileFlags::Profile() const {
  sim::PlantProfile p = named_;
  for (const auto& apply : factors_) apply(&p);
  return p;
}

}  // namespace hyq::cli
