// The loop model of every joint of HyQ (docs/tuning.md, "Loop model"): for each joint, gait
// phase and plant, the joint loop of joint_loop.h with
//  - the inertia the joint sees (joint_inertia.h) at the standing posture, and its range over
//    the trot's swing or stance (servo/reference/reference.h samples the gait);
//  - the controller's kp, kd (and ki) from the servo configuration, × the swing scale in swing;
//  - the plant's actuator: the ideal profile's first-order lag (hyq-sim --actuator-tau), or the
//    realistic profile's hydraulics with the boards' torque loop (sim/hydraulic_actuator.h)
//    measured by sines (frequency_response.h) with the joint clamped (A) and with the joint
//    moving at a fixed set-point (Z), at the torque that holds the phase's posture, and fitted
//    (rational_fit.h); its transport delay and viscous joint friction (sim/plant_profile.h);
//  - the boards' velocity (sim/board_velocity.h).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "dynamics/model.h"
#include "hal/calibration.h"
#include "servo/common/servo_types.h"
#include "servo/control/controller.h"
#include "servo/reference/reference.h"
#include "tools/loop_model/frequency_response.h"
#include "tools/loop_model/joint_inertia.h"
#include "tools/loop_model/joint_loop.h"

namespace hyq::loop_model {

enum class Phase { kSwing, kTrotStance, kStand };
inline constexpr int kNumPhases = 3;
/// "swing", "stance", "stand".
const char* ToString(Phase p) noexcept;

enum class PlantKind { kIdeal, kRealistic };
/// "ideal", "realistic".
const char* ToString(PlantKind p) noexcept;

/// The PD (+ I) a controller kind adds per joint, and its swing scale.
struct JointGains {
  dynamics::VectorJ kp = dynamics::VectorJ::Zero();  // N·m/rad
  dynamics::VectorJ kd = dynamics::VectorJ::Zero();  // N·m·s/rad
  dynamics::VectorJ ki = dynamics::VectorJ::Zero();  // N·m/(rad·s); not swing-scaled
  double swing_scale = 1.0;
};
/// The gains controller kind `kind` uses from `c` (the IDs: kp_tau, kd_tau, ki_tau, swing_scale;
/// PID: pid_*; PD + g: pdg_*).
JointGains GainsOf(const servo::ControllerConfig& c, servo::ControllerKind kind);

struct LoopModelSettings {
  double period_s = 1e-3;
  double actuator_tau_s = 0.005;          // the ideal plant's lag (hyq-sim --actuator-tau)
  double velocity_cutoff_hz = 250.0;      // the boards' low-pass (hyq-sim --velocity-cutoff)
  Mechanics mechanics = Mechanics::kSemiImplicitEuler;
  int max_extra_cycles = 30;              // the exact search's bound
  int report_extra_cycles = 2;            // K at which each loop's dominant root is reported
  servo::TrotParams trot;                 // the gait whose postures bound the inertias
  // the hydraulics' measurement: sines from f_lo to f_hi, amplitudes at the joint
  double measure_f_lo_hz = 2.0, measure_f_hi_hz = 480.0;
  int measure_points = 60;
  double setpoint_amplitude_Nm = 5.0;
  double motion_amplitude_rad_s = 0.5;
  int fit_order = 8;                      // the fits' highest order (FitBestOrder)
};

/// The inertias of every joint in every phase: at the standing posture and their range over the
/// trot's samples of that phase (swing: feet in the air, joint_inertia.h's (1) and, below it,
/// the free leg's (3): at the knee's crossover the hip's softer loop no longer holds the hip
/// still; stance: the diagonal pair alone on the ground; stand: the standing posture only).
struct PhaseInertia {
  dynamics::VectorJ nominal = dynamics::VectorJ::Zero();
  dynamics::VectorJ min = dynamics::VectorJ::Zero();
  dynamics::VectorJ max = dynamics::VectorJ::Zero();
  dynamics::VectorJ free_leg = dynamics::VectorJ::Zero();  // swing only: (3) at standing
};
std::array<PhaseInertia, kNumPhases> ComputeInertias(const dynamics::Model& model,
                                                     const servo::TrotParams& trot);

/// The stance feet a joint's leg is on in `phase` (none in swing; its diagonal pair; all four).
StanceSet StanceOf(Phase phase, int joint);

/// One actuator as the loop sees it: A(z) and Z(z) (and what they were fitted to).
struct ActuatorModel {
  TransferFunction setpoint;            // A
  TransferFunction motion;              // Z, N·m per rad/s
  int own_delay_cycles = 0;             // the plant's transport delay d_p
  double viscous_Nms = 0.0;
  double operating_torque_Nm = 0.0;     // the hydraulics' bias
  std::vector<ResponsePoint> setpoint_measured, motion_measured;  // empty for the lag
  double setpoint_fit_error = 0.0, motion_fit_error = 0.0;        // max relative, in kBandHz
};

/// The ideal plant's lag (τ_a = 0: none) at period T.
ActuatorModel LagActuator(double tau_s, double period_s);
/// The realistic plant's hydraulic actuator of `joint`, at posture q_joint holding tau_bias.
ActuatorModel HydraulicActuatorModel(const dynamics::Model& model,
                                     const hal::JointCalibration& cal, int joint, double q_joint,
                                     double tau_bias_Nm, const LoopModelSettings& s);

/// One joint × phase × plant: the loop and what it predicts.
struct LoopRow {
  int joint = 0;
  Phase phase = Phase::kSwing;
  PlantKind plant = PlantKind::kIdeal;
  double inertia_kgm2 = 0.0, inertia_min = 0.0, inertia_max = 0.0;
  double kp = 0.0, kd = 0.0, ki = 0.0;  // as applied in this phase
  int plant_delay_cycles = 0;           // d_p
  Margins margins;                      // from L(e^{jωT}) with no extra delay
  int max_extra_cycles = 0;             // exact: stable with 0..this many extra cycles (−1: not with 0)
  int max_extra_cycles_over_range = 0;  // the same, the worst over the inertia's range
  ClosedLoopRoot root_at_report;        // with report_extra_cycles: the fastest-growing root when
                                        // unstable, else the least damped oscillatory one
  bool stable_at_report = false;
};

struct LoopModel {
  LoopModelSettings settings;
  JointGains gains;
  std::array<PhaseInertia, kNumPhases> inertia;
  std::vector<LoopRow> rows;  // joint-major, then phase, then plant
  /// Actuators per plant, phase and joint ([plant][phase][joint]).
  std::array<std::array<std::array<ActuatorModel, dynamics::kNumJoints>, kNumPhases>, 2> actuators;
};

/// The loop of `joint` in `phase` on an actuator, with gains g (swing-scaled in swing) and
/// inertia I.
JointLoop MakeJointLoop(const LoopModelSettings& s, const JointGains& g, const ActuatorModel& a,
                        int joint, Phase phase, double inertia_kgm2);

/// Every joint × phase × plant in `plants`. Throws std::invalid_argument for unusable inputs.
LoopModel BuildLoopModel(const dynamics::Model& model,
                         const std::array<hal::JointCalibration, dynamics::kNumJoints>& joints,
                         const JointGains& gains, const LoopModelSettings& s,
                         const std::vector<PlantKind>& plants);

/// The rows evaluated again with other gains on the same actuators and inertias (the search).
std::vector<LoopRow> Evaluate(const LoopModel& m, const JointGains& g);

/// Per joint type (haa, hfe, kfe), phase and plant: the leg whose loop has the least margin
/// (fewest exact extra cycles, then the shortest delay margin).
std::vector<LoopRow> WorstPerJointType(const std::vector<LoopRow>& rows);

}  // namespace hyq::loop_model
