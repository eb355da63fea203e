// The daemon's YAML fills every module's own configuration struct: each key of the telemetry and
// command-channel sections (once shadowed by copies in the daemon's config, with other defaults)
// reaches TelemetryConfig / CommandChannelConfig, and the command rules then apply the loaded
// ranges (CommandValidator, no LCM instance).
#include <gtest/gtest.h>

#include <filesystem>

#include <array>
#include <cmath>
#include <cstring>
#include <string>

#include "config/servo_config_loader.h"
#include "hal/config_error.h"
#include "servo/command/command_channel.h"

namespace hyq {
namespace {

const std::filesystem::path kConfigDir = std::filesystem::path(HYQ_SOURCE_DIR) / "config";

servo::ServoConfig Parse(const std::string& extra) {
  const std::string yaml =
      "robot:\n  urdf: robots/hyq.urdf\n  hal: hyq_hal.yaml\ncontroller:\n  gains:\n    kp_acc: 100\n" +
      extra;
  return config::ParseServoConfig(yaml, "test.yaml", kConfigDir);
}

TEST(ServoConfigYaml, EveryTelemetryKeyReachesTelemetryConfig) {
  const servo::ServoConfig c = Parse(R"(telemetry:
  enabled: false
  lcm_url: memq://
  channel_prefix: ROBOT7_
  joint_state_every: 2
  joint_torque_every: 3
  base_state_every: 5
  contact_every: 7
  timing_every: 11
  health_every: 13
  snapshot_queue_capacity: 64
  event_queue_capacity: 32
  command_queue_capacity: 8
  idle_wait_ms: 4
)");
  const servo::TelemetryConfig& t = c.telemetry;
  EXPECT_FALSE(t.enabled);
  EXPECT_EQ(t.lcm_url, "memq://");
  EXPECT_EQ(t.channel_prefix, "ROBOT7_");
  EXPECT_EQ(t.joint_state_every, 2u);
  EXPECT_EQ(t.joint_torque_every, 3u);
  EXPECT_EQ(t.base_state_every, 5u);
  EXPECT_EQ(t.contact_every, 7u);
  EXPECT_EQ(t.timing_every, 11u);
  EXPECT_EQ(t.health_every, 13u);
  EXPECT_EQ(t.snapshot_queue_capacity, 64u);
  EXPECT_EQ(t.event_queue_capacity, 32u);
  EXPECT_EQ(t.command_queue_capacity, 8u);
  EXPECT_EQ(t.idle_wait_ms, 4);
}

TEST(ServoConfigYaml, EveryFrictionEstimationKeyReachesItsConfig) {
  const servo::ServoConfig c = Parse(R"(contact:
  mu: 0.8
  friction_estimation:
    enabled: true
    prior_mu: 0.9
    min_mu: 0.07
    margin: 0.3
    min_normal_N: 55
    slip_speed_m_s: 0.06
    slip_cycles: 4
    slip_alignment: 0.6
    touchdown_blank_s: 0.02
    stick_speed_m_s: 0.01
    rise_per_s: 0.7
    slip_filter: 0.4
    confidence_time_s: 0.8
    memory_radius_m: 0.25
telemetry:
  friction_every: 9
)");
  const servo::FrictionEstimatorConfig& f = c.friction;
  EXPECT_TRUE(f.enabled);
  EXPECT_DOUBLE_EQ(f.prior_mu, 0.9);
  EXPECT_DOUBLE_EQ(f.min_mu, 0.07);
  EXPECT_DOUBLE_EQ(f.margin, 0.3);
  EXPECT_DOUBLE_EQ(f.min_normal_N, 55.0);
  EXPECT_DOUBLE_EQ(f.slip_speed_m_s, 0.06);
  EXPECT_EQ(f.slip_cycles, 4);
  EXPECT_DOUBLE_EQ(f.slip_alignment, 0.6);
  EXPECT_DOUBLE_EQ(f.touchdown_blank_s, 0.02);
  EXPECT_DOUBLE_EQ(f.stick_speed_m_s, 0.01);
  EXPECT_DOUBLE_EQ(f.rise_per_s, 0.7);
  EXPECT_DOUBLE_EQ(f.slip_filter, 0.4);
  EXPECT_DOUBLE_EQ(f.confidence_time_s, 0.8);
  EXPECT_DOUBLE_EQ(f.memory_radius_m, 0.25);
  EXPECT_EQ(c.telemetry.friction_every, 9u);
  EXPECT_DOUBLE_EQ(c.mu[0], 0.8);
  // the shipped files: off on the robot and with hyq-sim (the operator turns it on)
  EXPECT_FALSE(config::LoadServoConfig(kConfigDir / "hyq_servo.yaml").friction.enabled);
  EXPECT_FALSE(config::LoadServoConfig(kConfigDir / "hyq_servo_sim.yaml").friction.enabled);
}

TEST(ServoConfigYaml, EveryDeadlineKeyReachesDeadlineConfig) {
  const servo::ServoConfig c = Parse("deadline:\n  budget_fraction: 0.8\n  max_consecutive_misses: 7\n"
                                     "  stop_in_lockstep: true\n");
  EXPECT_DOUBLE_EQ(c.deadline.budget_fraction, 0.8);
  EXPECT_EQ(c.deadline.max_consecutive_misses, 7);
  EXPECT_TRUE(c.deadline.stop_in_lockstep);
  // shipped: the lock-step plant waits, so its misses are only counted
  EXPECT_FALSE(config::LoadServoConfig(kConfigDir / "hyq_servo.yaml").deadline.stop_in_lockstep);
  EXPECT_FALSE(config::LoadServoConfig(kConfigDir / "hyq_servo_sim.yaml").deadline.stop_in_lockstep);
}

// the real-time read's wait for answers still owed, in periods (at most half of one),
// so that it scales with the rate
// after the command-line overrides the rate-scaled gains are checked again, with their keys' bounds
TEST(ServoConfigYaml, ValidateChecksTheRateScaledGainsWithTheirKeysBounds) {
  servo::ServoConfig c = config::LoadServoConfig(kConfigDir / "hyq_servo.yaml");
  EXPECT_NO_THROW(config::ValidateServoConfig(c));
  c.controller.feedback.kd_acc(4) = 0.6 * c.rate_hz();
  try {
    config::ValidateServoConfig(c);
    FAIL();
  } catch (const hal::ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("key 'controller.gains.kd_acc': expected kd_acc · dt <= 0.5 at 1000 Hz, found 600"),
              std::string::npos) << m;
  }
}

TEST(ServoConfigYaml, AnswerWaitIsAFractionOfThePeriod) {
  EXPECT_DOUBLE_EQ(Parse("loop:\n  answer_wait_periods: 0.25\n").answer_wait_s(), 250e-6);
  EXPECT_DOUBLE_EQ(Parse("loop:\n  rate_hz: 800\n  answer_wait_periods: 0.25\n").answer_wait_s(), 312.5e-6);
  EXPECT_DOUBLE_EQ(Parse("loop:\n  rate_hz: 500\n").answer_wait_s(), 600e-6);  // the default 0.3
  EXPECT_DOUBLE_EQ(Parse("loop:\n  answer_wait_periods: 0\n").answer_wait_s(), 0.0);
  EXPECT_DOUBLE_EQ(config::LoadServoConfig(kConfigDir / "hyq_servo.yaml").answer_wait_s(), 300e-6);
  try {
    (void)Parse("loop:\n  answer_wait_periods: 0.6\n");
    ADD_FAILURE() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("loop.answer_wait_periods"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("0.6"), std::string::npos) << e.what();
  }
}

TEST(ServoConfigYaml, EveryOperationKeyReachesServoConfig) {
  const servo::ServoConfig c = Parse(R"(operation:
  auto_enable: true
  stand_up_s: 2.5
  sit_down_s: 1.25
  crouch_height_m: 0.42
  sit_damping_Nms_per_rad: 120
  sit_settle_speed_rad_s: 0.03
  sit_damping_max_s: 4
)");
  EXPECT_TRUE(c.auto_enable);
  EXPECT_DOUBLE_EQ(c.stand_up_s, 2.5);
  EXPECT_DOUBLE_EQ(c.sit_down_s, 1.25);
  EXPECT_DOUBLE_EQ(c.crouch_height_m, 0.42);
  EXPECT_DOUBLE_EQ(c.sit_damping_Nms_per_rad, 120.0);
  EXPECT_DOUBLE_EQ(c.sit_settle_speed_rad_s, 0.03);
  EXPECT_DOUBLE_EQ(c.sit_damping_max_s, 4.0);
  // the shipped robot file: the sit-down rests the robot before the torque goes
  const servo::ServoConfig shipped = config::LoadServoConfig(kConfigDir / "hyq_servo.yaml");
  EXPECT_DOUBLE_EQ(shipped.sit_settle_speed_rad_s, 0.05);
  EXPECT_DOUBLE_EQ(shipped.sit_damping_max_s, 5.0);
}

// every controller's gains (the tuned ones live in the shipped files)
TEST(ServoConfigYaml, EveryGainKeyReachesControllerConfig) {
  const std::string robot = "robot:\n  urdf: robots/hyq.urdf\n  hal: hyq_hal.yaml\n";
  const servo::ServoConfig c = config::ParseServoConfig(robot + R"(controller:
  kind: pd_gravity
  gains:
    kp_tau: 410
    kd_tau: [11, 12, 13]
    ki_tau: 55
    i_limit_tau: 40
    pid_kp: 900
    pid_ki: 120
    pid_kd: 21
    pid_i_limit: 90
    pdg_kp: 650
    pdg_kd: 17
    swing_scale: 0.4
    pid_swing_scale: 0.6
    pdg_swing_scale: 0.7
  disturbance_observer:
    enabled: true
    bandwidth_hz: 5
    max_force_N: 250
    max_torque_Nm: 80
telemetry:
  disturbance_every: 7
)", "test.yaml", kConfigDir);
  const servo::ControllerConfig& k = c.controller;
  EXPECT_EQ(k.kind, servo::ControllerKind::kPdGravity);
  EXPECT_DOUBLE_EQ(k.feedback.kp_tau(4), 410.0);
  EXPECT_DOUBLE_EQ(k.feedback.kd_tau(5), 13.0);
  EXPECT_DOUBLE_EQ(k.feedback.ki_tau(0), 55.0);
  EXPECT_DOUBLE_EQ(k.feedback.i_limit_tau(11), 40.0);
  EXPECT_DOUBLE_EQ(k.pid.kp(3), 900.0);
  EXPECT_DOUBLE_EQ(k.pid.ki(3), 120.0);
  EXPECT_DOUBLE_EQ(k.pid.kd(3), 21.0);
  EXPECT_DOUBLE_EQ(k.pid.i_limit(3), 90.0);
  EXPECT_DOUBLE_EQ(k.pd_gravity.kp(7), 650.0);
  EXPECT_DOUBLE_EQ(k.pd_gravity.kd(7), 17.0);
  EXPECT_DOUBLE_EQ(k.swing_gain_scale, 0.4);
  EXPECT_DOUBLE_EQ(k.pid_swing_gain_scale, 0.6);
  EXPECT_DOUBLE_EQ(k.pdg_swing_gain_scale, 0.7);
  // the shipped files' swing scales reach the controller, the robot's as the simulator's
  const servo::ControllerConfig robot_cc = config::LoadServoConfig(kConfigDir / "hyq_servo.yaml").controller;
  const servo::ControllerConfig sim_cc = config::LoadServoConfig(kConfigDir / "hyq_servo_sim.yaml").controller;
  EXPECT_GT(robot_cc.swing_gain_scale, 0.0);
  EXPECT_LT(robot_cc.swing_gain_scale, 1.0);  // the IDs' swing legs are scaled (docs/tuning.md)
  EXPECT_DOUBLE_EQ(sim_cc.swing_gain_scale, robot_cc.swing_gain_scale);
  EXPECT_DOUBLE_EQ(sim_cc.pid_swing_gain_scale, robot_cc.pid_swing_gain_scale);
  EXPECT_DOUBLE_EQ(sim_cc.pdg_swing_gain_scale, robot_cc.pdg_swing_gain_scale);
  try {  // the same bounds for the PID's
    (void)config::ParseServoConfig(robot + "controller:\n  gains:\n    pid_swing_scale: 1.5\n", "test.yaml", kConfigDir);
    ADD_FAILURE() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("controller.gains.pid_swing_scale"), std::string::npos) << e.what();
  }
  try {  // a scale that would switch the swing legs' feedback off (or amplify it) is refused
    (void)config::ParseServoConfig(robot + "controller:\n  gains:\n    swing_scale: 0\n", "test.yaml", kConfigDir);
    ADD_FAILURE() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("controller.gains.swing_scale"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("[0.05, 1]"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(c.disturbance.enabled);
  EXPECT_DOUBLE_EQ(c.disturbance.bandwidth_hz, 5.0);
  EXPECT_DOUBLE_EQ(c.disturbance.max_force_N, 250.0);
  EXPECT_DOUBLE_EQ(c.disturbance.max_torque_Nm, 80.0);
  EXPECT_EQ(c.telemetry.disturbance_every, 7u);
  EXPECT_FALSE(config::LoadServoConfig(kConfigDir / "hyq_servo.yaml").disturbance.enabled);
  // pd_gravity without its own position gain is refused by name
  try {
    (void)config::ParseServoConfig(robot + "controller:\n  kind: pd_gravity\n", "test.yaml", kConfigDir);
    ADD_FAILURE() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("pd_gravity"), std::string::npos) << e.what();
  }
}

TEST(ServoConfigYaml, EveryCommandKeyReachesCommandChannelConfig) {
  const servo::ServoConfig c = Parse(R"(commands:
  enabled: true
  channel: ROBOT7_COMMAND
  max_rate_hz: 3
  mu_min: 0.05
  mu_max: 1.2
  gain_scale_min: 0.5
  gain_scale_max: 1.5
  allowed_controllers: [pid, two_stage]
  key_file: keys/robot7.key
  max_age_ms: 250
  max_senders: 4
  interface: eth1
  max_velocity: [0.3, 0.1, 0.25]
)");
  const servo::CommandChannelConfig& k = c.commands;
  EXPECT_TRUE(k.enabled);
  EXPECT_EQ(k.channel, "ROBOT7_COMMAND");
  EXPECT_DOUBLE_EQ(k.max_rate_hz, 3.0);
  EXPECT_DOUBLE_EQ(k.mu_min, 0.05);
  EXPECT_DOUBLE_EQ(k.mu_max, 1.2);
  EXPECT_DOUBLE_EQ(k.gain_scale_min, 0.5);
  EXPECT_DOUBLE_EQ(k.gain_scale_max, 1.5);
  EXPECT_EQ(k.allowed_controllers, (std::vector<std::string>{"pid", "two_stage"}));
  EXPECT_EQ(k.key_file, (std::filesystem::path(kConfigDir) / "keys/robot7.key").lexically_normal().string());
  EXPECT_DOUBLE_EQ(k.max_age_ms, 250.0);
  EXPECT_EQ(k.max_senders, 4u);
  EXPECT_EQ(k.interface, "eth1");

  // the loaded ranges are the ones the command rules apply
  const servo::CommandValidator v(k);
  hyq_lcm::lcmt_hyq_command msg{};
  msg.kind = hyq_lcm::lcmt_hyq_command::KIND_SET_MU;
  msg.num_feet = 4;
  msg.mu = {0.5, 0.5, 1.3, 0.5};
  servo::ServoCommand out;
  char why[96];
  EXPECT_FALSE(v.Validate(msg, &out, why, sizeof why));
  EXPECT_STREQ(why, "mu[2]: expected [0.05, 1.2], found 1.3");
  msg.mu[2] = 1.2;
  EXPECT_TRUE(v.Validate(msg, &out, why, sizeof why));
  msg.kind = hyq_lcm::lcmt_hyq_command::KIND_SET_CONTROLLER;
  msg.controller = "noslip";
  EXPECT_FALSE(v.Validate(msg, &out, why, sizeof why));
  EXPECT_STREQ(why, "controller: expected one of pid,two_stage, found 'noslip'");
  msg.controller = "two_stage";
  ASSERT_TRUE(v.Validate(msg, &out, why, sizeof why));
  EXPECT_EQ(out.controller, servo::ControllerKind::kTwoStageId);
  msg.kind = hyq_lcm::lcmt_hyq_command::KIND_SET_GAINS;
  msg.kp_scale = 1.0;
  msg.kd_scale = 1.6;
  EXPECT_FALSE(v.Validate(msg, &out, why, sizeof why));
  EXPECT_STREQ(why, "kd_scale: expected [0.5, 1.5], found 1.6");
  msg.kind = hyq_lcm::lcmt_hyq_command::KIND_SET_VELOCITY;
  msg.velocity[0] = 0.3;
  msg.velocity[1] = -0.1;
  msg.velocity[2] = 0.3;
  EXPECT_FALSE(v.Validate(msg, &out, why, sizeof why));
  EXPECT_STREQ(why, "velocity.wz: expected [-0.25, 0.25] rad/s, found 0.3");
  msg.velocity[2] = std::nan("");
  EXPECT_FALSE(v.Validate(msg, &out, why, sizeof why));
  EXPECT_STREQ(why, "velocity.wz: expected [-0.25, 0.25] rad/s, found nan");
  msg.velocity[2] = -0.25;
  ASSERT_TRUE(v.Validate(msg, &out, why, sizeof why));
  EXPECT_EQ(out.kind, servo::ServoCommand::Kind::kSetVelocity);
  EXPECT_EQ(out.velocity, (std::array<double, 3>{0.3, -0.1, -0.25}));
}

TEST(ServoConfigYaml, TrotSteeringKeysReachTrotParams) {
  const servo::ServoConfig c = Parse(R"(reference:
  kind: trot
  trot: {max_velocity: [0.3, 0.15, 0.4], max_acceleration: [0.6, 0.4, 1.0]}
)");
  EXPECT_EQ(c.trot.max_velocity, (std::array<double, 3>{0.3, 0.15, 0.4}));
  EXPECT_EQ(c.trot.max_acceleration, (std::array<double, 3>{0.6, 0.4, 1.0}));
  const servo::TrotParams defaults;  // the shipped file keeps the defaults
  EXPECT_EQ(config::LoadServoConfig(kConfigDir / "hyq_servo.yaml").trot.max_velocity,
            defaults.max_velocity);
  EXPECT_EQ(config::LoadServoConfig(kConfigDir / "hyq_servo.yaml").trot.max_acceleration,
            defaults.max_acceleration);
  EXPECT_EQ(config::LoadServoConfig(kConfigDir / "hyq_servo.yaml").commands.max_velocity,
            servo::CommandChannelConfig{}.max_velocity);
}

TEST(ServoConfigYaml, TwoStageKeysReachTwoStageSettings) {
  const servo::TwoStageSettings defaults;
  EXPECT_TRUE(defaults.velocity_consistent_qdd);
  EXPECT_DOUBLE_EQ(defaults.optimal_set_tolerance, 1e-9);  // eq 9 held by default
  const servo::ServoConfig c = Parse(R"(  two_stage:
    velocity_consistent_qdd: false
    optimal_set_tolerance: 1.0
    project_contact_velocity: false
    frictionless_mu: 0.001
)");
  EXPECT_FALSE(c.controller.id.velocity_consistent_qdd);
  EXPECT_DOUBLE_EQ(c.controller.id.optimal_set_tolerance, 1.0);
  EXPECT_FALSE(c.controller.id.project_contact_velocity);
  EXPECT_DOUBLE_EQ(c.controller.id.frictionless_mu, 0.001);
  // the shipped robot file spells out the defaults
  const servo::ServoConfig robot = config::LoadServoConfig(kConfigDir / "hyq_servo.yaml");
  EXPECT_TRUE(robot.controller.id.velocity_consistent_qdd);
  EXPECT_DOUBLE_EQ(robot.controller.id.optimal_set_tolerance, 1e-9);
}

TEST(ServoConfigYaml, ShippedFilesKeepTheirPublishingRates) {
  const servo::ServoConfig robot = config::LoadServoConfig(kConfigDir / "hyq_servo.yaml");
  EXPECT_EQ(robot.telemetry.joint_state_every, 1u);
  EXPECT_EQ(robot.telemetry.timing_every, 10u);
  EXPECT_EQ(robot.telemetry.health_every, 100u);
  EXPECT_DOUBLE_EQ(robot.commands.max_rate_hz, 20.0);
  const servo::ServoConfig sim = config::LoadServoConfig(kConfigDir / "hyq_servo_sim.yaml");
  EXPECT_EQ(sim.telemetry.joint_state_every, 4u);
  EXPECT_EQ(sim.telemetry.contact_every, 4u);
  EXPECT_EQ(sim.telemetry.timing_every, 40u);
}

TEST(ServoConfigYaml, BadValuesNameTheKey) {
  const auto message = [](const std::string& extra) {
    try {
      (void)Parse(extra);
    } catch (const hal::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("telemetry:\n  state_decimation: 4\n").find("state_decimation"),
            std::string::npos);
  const std::string cap = message("telemetry:\n  snapshot_queue_capacity: 1000\n");
  EXPECT_NE(cap.find("telemetry.snapshot_queue_capacity"), std::string::npos) << cap;
  EXPECT_NE(cap.find("power of two"), std::string::npos) << cap;
  const std::string mu = message("commands:\n  mu_min: 1.0\n  mu_max: 0.5\n");
  EXPECT_NE(mu.find("commands.mu_max"), std::string::npos) << mu;
  const std::string twice = message("commands:\n  max_rate_hz: 5\n  enabled: true\n  max_rate_hz: 50\n");
  EXPECT_NE(twice.find("commands.max_rate_hz"), std::string::npos) << twice;
  EXPECT_NE(twice.find("a second time (first on line"), std::string::npos) << twice;
  // one policy for late or missing inputs: the safety layer's old key names the HAL's
  const std::string held = message("safety:\n  max_missing_cycles: 20\n");
  EXPECT_NE(held.find("safety.max_missing_cycles"), std::string::npos) << held;
  EXPECT_NE(held.find("timing.max_held_cycles"), std::string::npos) << held;
  const std::string fe = message("contact:\n  friction_estimation:\n    slip_cycles: 2.5\n");
  EXPECT_NE(fe.find("contact.friction_estimation.slip_cycles"), std::string::npos) << fe;
  const std::string fe2 = message(
      "contact:\n  friction_estimation:\n    slip_speed_m_s: 0.01\n    stick_speed_m_s: 0.02\n");
  EXPECT_NE(fe2.find("contact.friction_estimation.stick_speed_m_s"), std::string::npos) << fe2;
  EXPECT_NE(fe2.find("at most slip_speed_m_s"), std::string::npos) << fe2;
  const std::string fe3 = message("contact:\n  friction_estimation:\n    colour: blue\n");
  EXPECT_NE(fe3.find("colour"), std::string::npos) << fe3;
  const std::string ctrl = message("commands:\n  allowed_controllers: [pid, warp]\n");
  EXPECT_NE(ctrl.find("commands.allowed_controllers[1]"), std::string::npos) << ctrl;
  EXPECT_NE(ctrl.find("warp"), std::string::npos) << ctrl;

  // URLs liblcm would take or fail on late, and channel names it reads as patterns
  const struct {
    const char* yaml;
    const char* message;
  } bad[] = {
      {"telemetry:\n  lcm_url: udp::99999\n", "telemetry.lcm_url"},
      {"telemetry:\n  lcm_url: \"udpm://[[[::\"\n", "telemetry.lcm_url (group)"},
      {"telemetry:\n  lcm_url: udpm://239.255.76.67:99999\n", "expected 1..65535, found"},
      {"commands:\n  channel: \"HYQ_.*\"\n", "commands.channel"},
      {"commands:\n  channel: HYQ_HEALTH\n", "a channel the telemetry does not publish on"},
      {"telemetry:\n  channel_prefix: \"HYQ.*\"\n", "telemetry.channel_prefix"},
      {"commands:\n  max_age_ms: 0\n", "commands.max_age_ms"},
      {"commands:\n  max_velocity: [0.1, 0.1]\n",
       "key 'commands.max_velocity': expected 3 numbers [vx, vy, wz]"},
      {"reference:\n  trot: {max_velocity: [0.1, -0.2, 0.1]}\n",
       "key 'reference.trot.max_velocity[1]': expected a number in [0, 0.5], found '-0.2'"},
      {"reference:\n  trot: {max_acceleration: [0.5, 0, 0.5]}\n",
       "key 'reference.trot.max_acceleration[1]': expected a number > 0"},
  };
  for (const auto& b : bad) {
    const std::string m = message(b.yaml);
    EXPECT_NE(m.find(b.message), std::string::npos) << b.yaml << " -> " << m;
  }
}

}  // namespace
}  // namespace hyq
