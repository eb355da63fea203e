// One simulated experiment (docs/experiments.md): the MuJoCo HyQ (sim/plant.h), the daemon's
// control pipeline (servo/runtime/control_pipeline.h) with the true state, a reference (stand,
// trot, figure eight), 1 kHz. The μ the controller gets is assumed, the plant's own (an oracle)
// or estimated online.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "servo/control/controller.h"
#include "servo/estimation/disturbance_observer.h"
#include "servo/estimation/friction_estimator.h"
#include "servo/reference/reference.h"
#include "sim/plant.h"
#include "sim/plant_profile.h"

namespace hyq::experiment {

/// Where the controller's μ per foot comes from.
enum class MuSource : std::uint8_t {
  kAssumed,    // mu / foot_mu everywhere, whatever the ground under the feet is
  kOracle,     // the plant's true μ under each foot, every cycle (a priori knowledge)
  kEstimated,  // servo::FrictionEstimator, from the applied torques and the foot velocities;
               // mu / foot_mu is its upper bound
};
const char* ToString(MuSource s) noexcept;

struct ExperimentConfig {
  std::string name;
  servo::Reference::Kind reference = servo::Reference::Kind::kTrot;
  servo::TrotParams trot;
  servo::FigureEightParams figure_eight;
  double duration_s = 4.0;
  double mu = 1.0;                        // ground friction (plant and controller)
  std::array<double, servo::kNumFeet> foot_mu{-1, -1, -1, -1};
  std::vector<sim::GroundPatch> patches;  // the plant's friction patches (the controller's μ: mu_source)
  MuSource mu_source = MuSource::kAssumed;
  servo::FrictionEstimatorConfig friction;  // for kEstimated (enabled is implied)
  servo::ControllerConfig controller;
  /// The trunk's disturbance observer: its estimate corrects the model's h for the controller
  /// (the ID kinds and PD + g).
  servo::DisturbanceObserverConfig disturbance;
  std::uint64_t seed = 1;                 // initial-state perturbation
  double initial_perturbation_rad = 0.0;  // random joint offsets at t = 0
  bool record_id_inputs = false;          // keep every cycle's ID problem (benchmarks, files)
  /// How the plant differs from the model (default ideal: the controller's torque is
  /// applied as it is). The controller keeps the nominal model and the true state; its measured
  /// torques (the friction estimator's input) are the load cells', bias included.
  sim::PlantProfile profile;
  /// The HAL's joint calibrations (lever arms), needed when profile.hydraulics.
  std::vector<hal::JointCalibration> joints;
};

/// Gains shared by every controller (the fairness rule of docs/experiments.md): PID uses them as
/// its PD; the ID controllers add the same PD torque to their model-based feed-forward.
servo::ControllerConfig StandardController(servo::ControllerKind kind);

struct Sample {
  double t;
  servo::VectorJ q, q_ref, tau;
  servo::VectorJ tau_applied;            // what the plant applied (the actuators' output)
  std::array<Eigen::Vector3d, servo::kNumFeet> contact_force_W;
  std::array<double, servo::kNumFeet> slip_speed;  // tangential contact-point speed of stance feet, m/s
  std::array<bool, servo::kNumFeet> stance_ref, touching;
  double error_norm_rad;                 // ‖q_ref − q‖
  double base_height_m;
  double control_time_us;                // dynamics + controller, wall clock
  double qp_time_us;                     // Stage I + Stage II solves (the paper's timing)
  std::uint8_t stage1_status, stage2_status, fallback;
  // plant, Stage I, estimator (or NaN)
  std::array<double, servo::kNumFeet> mu_true, mu_control, mu_estimate;
  std::array<bool, servo::kNumFeet> slipping;          // the estimator's slip flag
  Eigen::Matrix<double, 6, 1> disturbance = Eigen::Matrix<double, 6, 1>::Zero();  // d_b (observer on)
};

struct ExperimentResult {
  std::vector<Sample> samples;
  bool fell = false;
  double fell_at_s = 0.0;
  double mean_error_rad = 0.0, max_error_rad = 0.0;
  double mean_slip_speed = 0.0;          // over stance feet that touch
  double torque_total_variation = 0.0;   // Σ‖τ_k − τ_{k−1}‖, N·m (Fig. 1's chatter)
  servo::FallbackCounters fallbacks;
  // on ground with patches: the cycles in which a stance foot touched a patch (its μ differs
  // from the ground's), and the estimate's settling after each change of the ground under a foot
  long patch_cycles = 0;
  double patch_mean_error_rad = 0.0, patch_mean_slip_speed = 0.0;
  struct Settling {
    int foot;
    double t_s;            // the first loaded cycle on the new ground
    double from_mu, to_mu;  // true μ before and after
    int footfalls = -1;    // footfalls on the new ground before the one in which the estimate
                           // first came within tolerance (0: the first); -1: never in the run
    double lag_s = -1.0;   // from t_s to that cycle; -1: never
  };
  std::vector<Settling> settling;        // kEstimated only
  std::vector<servo::IdInput> id_inputs;  // when ExperimentConfig::record_id_inputs
};

/// Runs the experiment; `progress(fraction)` is called now and then (may be empty).
ExperimentResult RunExperiment(const dynamics::Model& model, const ExperimentConfig& cfg,
                               const std::function<void(double)>& progress = {});

/// Writes the time series as CSV (one row per sample).
void WriteCsv(const ExperimentResult& r, const std::string& path);

}  // namespace hyq::experiment
