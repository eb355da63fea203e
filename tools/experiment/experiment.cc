#include "tools/experiment/experiment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <random>
#include <stdexcept>

#include <Eigen/Geometry>

#include "dynamics/cycle_dynamics.h"
#include "servo/runtime/control_pipeline.h"

namespace hyq::experiment {

servo::ControllerConfig StandardController(servo::ControllerKind kind) {
  servo::ControllerConfig c;
  c.kind = kind;
  // PD shared by all (N m/rad, N m s/rad), per joint type haa, hfe, kfe
  const double kp[3] = {300.0, 300.0, 300.0}, kd[3] = {8.0, 8.0, 8.0};
  for (int j = 0; j < servo::kNumJoints; ++j) {
    c.pid.kp(j) = kp[j % dynamics::kJointsPerLeg];
    c.pid.kd(j) = kd[j % dynamics::kJointsPerLeg];
    c.pid.ki(j) = 0.0;
    c.pid.i_limit(j) = 0.0;
    c.feedback.kp_tau(j) = kp[j % dynamics::kJointsPerLeg];
    c.feedback.kd_tau(j) = kd[j % dynamics::kJointsPerLeg];
    c.pd_gravity.kp(j) = kp[j % dynamics::kJointsPerLeg];
    c.pd_gravity.kd(j) = kd[j % dynamics::kJointsPerLeg];
  }
  // the ID controllers' q̈_des = q̈_ref (no acceleration feedback: the PD above is the feedback)
  return c;
}

const char* ToString(MuSource s) noexcept {
  switch (s) {
    case MuSource::kAssumed: return "assumed";
    case MuSource::kOracle: return "oracle";
    case MuSource::kEstimated: return "estimated";
  }
  return "?";
}

namespace {

constexpr std::array<bool, servo::kNumFeet> kEveryFoot{true, true, true, true};

// The estimate is "settled" on ground of true μ within this: 0.05 absolute on slippery ground,
// 20 % of the truth on grippy ground
bool Settled(double estimate, double truth) {
  return std::abs(estimate - truth) <= std::max(0.05, 0.2 * truth);
}

// Follows each foot's ground and the estimate on it: a change of the true μ under a loaded foot
// opens a Settling entry, closed at the first loaded cycle with the estimate settled.
class SettlingTracker {
 public:
  void Observe(double t, int f, bool loaded, double truth, double estimate,
               std::vector<ExperimentResult::Settling>* out) {
    const auto i = static_cast<std::size_t>(f);
    if (loaded) {
      if (has_last_[i] && std::abs(truth - last_[i]) > 1e-9) {
        out->push_back({f, t, last_[i], truth});
        open_[i] = static_cast<int>(out->size()) - 1;
        footfalls_[i] = 0;
      } else if (!was_loaded_[i] && open_[i] >= 0) {
        ++footfalls_[i];
      }
      last_[i] = truth;
      has_last_[i] = true;
      if (open_[i] >= 0 && Settled(estimate, truth)) {
        auto& s = (*out)[static_cast<std::size_t>(open_[i])];
        s.lag_s = t - s.t_s;
        s.footfalls = footfalls_[i];
        open_[i] = -1;
      }
    }
    was_loaded_[i] = loaded;
  }

 private:
  std::array<double, servo::kNumFeet> last_{};
  std::array<bool, servo::kNumFeet> has_last_{}, was_loaded_{};
  std::array<int, servo::kNumFeet> open_{-1, -1, -1, -1}, footfalls_{};
};

}  // namespace

ExperimentResult RunExperiment(const dynamics::Model& model, const ExperimentConfig& cfg,
                               const std::function<void(double)>& progress) {
  sim::PlantConfig pc;
  pc.ground_mu = cfg.mu;
  pc.foot_mu = cfg.foot_mu;
  pc.patches = cfg.patches;
  cfg.profile.ApplyTo(&pc);
  sim::Plant plant(model, pc);
  sim::Actuation actuation(model, cfg.joints, cfg.profile, 0.0, 0.0, pc.timestep_s);
  servo::Reference ref = cfg.reference == servo::Reference::Kind::kTrot
                             ? servo::Reference::Trot(model, cfg.trot)
                         : cfg.reference == servo::Reference::Kind::kFigureEight
                             ? servo::Reference::FigureEight(model, cfg.figure_eight)
                             : servo::Reference::Stand(model);
  auto dyn = std::make_unique<dynamics::CycleDynamics>();

  dynamics::VectorQ q0 = model.StandingQ();
  if (cfg.initial_perturbation_rad > 0) {
    std::mt19937_64 rng(cfg.seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int j = 0; j < servo::kNumJoints; ++j)
      q0(dynamics::kNq - servo::kNumJoints + j) += cfg.initial_perturbation_rad * u(rng);
  }
  plant.Reset(q0, dynamics::VectorV::Zero());
  actuation.Reset(q0.tail<servo::kNumJoints>());

  // the controller's μ ceiling: the assumed μ (the estimate's upper bound), or the plant's own
  servo::ContactEnvironment mu_ceiling;
  for (std::size_t f = 0; f < servo::kNumFeet; ++f)
    mu_ceiling.mu[f] = cfg.foot_mu[f] >= 0 ? cfg.foot_mu[f] : cfg.mu;
  const std::array<double, servo::kNumFeet> base_mu = mu_ceiling.mu;  // the ground's off the patches
  servo::FrictionEstimatorConfig fc = cfg.friction;
  fc.enabled = cfg.mu_source == MuSource::kEstimated;
  servo::ControlPipeline pipeline(model, cfg.controller, fc, cfg.disturbance, pc.timestep_s);
  pipeline.HoldEnvironment(mu_ceiling);
  const servo::FrictionEstimator& friction = pipeline.friction();
  SettlingTracker settling;
  servo::VectorJ tau_measured = servo::VectorJ::Zero();  // the load cells (Actuation::measured_Nm)
  double patch_err = 0, patch_slip = 0;
  long patch_slip_n = 0;

  ExperimentResult r;
  const double dt = pc.timestep_s;
  const auto steps = static_cast<long>(cfg.duration_s / dt);
  r.samples.reserve(static_cast<std::size_t>(steps));
  servo::ReferenceSample rs;
  servo::IdOutput out;
  double err_sum = 0, slip_sum = 0;
  long slip_n = 0;
  for (long k = 0; k < steps; ++k) {
    const double t = k * dt;
    const dynamics::VectorQ q = plant.q();
    const dynamics::VectorV v = plant.v();
    ref.Sample(t, &rs);
    const auto t0 = std::chrono::steady_clock::now();
    const auto ds = dynamics::ComputeCycleDynamics(model, q, v, dyn.get());
    servo::VectorJ tau = servo::VectorJ::Zero();
    if (ds == dynamics::DynamicsStatus::kOk) {
      if (cfg.mu_source == MuSource::kOracle)
        for (int f = 0; f < servo::kNumFeet; ++f)
          mu_ceiling.mu[static_cast<std::size_t>(f)] = plant.foot_friction(f);
      // the plant's true velocity: every foot's slip is evidence
      (void)pipeline.Compute(*dyn, q, v, tau_measured, rs.joints.stance, kEveryFoot, rs.joints,
                             mu_ceiling, &out);
      tau = out.tau_Nm;
      if (cfg.record_id_inputs) r.id_inputs.push_back(pipeline.controller().last_input());
    }
    const auto t1 = std::chrono::steady_clock::now();
    for (int j = 0; j < servo::kNumJoints; ++j)
      tau(j) = std::clamp(tau(j), -model.limits[j].effort_Nm, model.limits[j].effort_Nm);
    std::array<double, servo::kNumFeet> mu_true;
    for (int f = 0; f < servo::kNumFeet; ++f)
      mu_true[static_cast<std::size_t>(f)] = plant.foot_friction(f);
    actuation.Step(tau, q.tail<servo::kNumJoints>(), v.tail<servo::kNumJoints>());
    plant.Step(actuation.applied_Nm());
    tau_measured = actuation.measured_Nm();

    Sample s;
    s.t = t;
    s.q = q.tail<servo::kNumJoints>();
    s.q_ref = rs.joints.q;
    s.tau = tau;
    s.tau_applied = actuation.applied_Nm();
    const auto contacts = plant.FootContacts();
    bool on_patch = false;
    double patch_slip_cycle = 0;
    int patch_slip_feet = 0;
    for (std::size_t f = 0; f < servo::kNumFeet; ++f) {
      const auto& fr = friction.feet()[f];
      const bool estimated = cfg.mu_source == MuSource::kEstimated;
      s.mu_true[f] = mu_true[f];
      s.mu_control[f] = pipeline.environment().mu[f];
      s.mu_estimate[f] = estimated ? fr.mu : std::nan("");
      s.slipping[f] = estimated && fr.slipping;
      if (estimated) settling.Observe(t, static_cast<int>(f), fr.loaded, mu_true[f], fr.mu, &r.settling);
      if (rs.joints.stance[f] && contacts[f].touching && mu_true[f] != base_mu[f]) {
        on_patch = true;
        patch_slip_cycle += contacts[f].slip_velocity_W.norm();
        ++patch_slip_feet;
      }
    }
    if (on_patch) {
      ++r.patch_cycles;
      patch_err += (rs.joints.q - q.tail<servo::kNumJoints>()).norm();
      patch_slip += patch_slip_cycle;
      patch_slip_n += patch_slip_feet;
    }
    s.disturbance = pipeline.disturbance().wrench();
    for (int f = 0; f < servo::kNumFeet; ++f) {
      s.contact_force_W[f] = contacts[f].force_W;
      s.touching[f] = contacts[f].touching;
      s.stance_ref[f] = rs.joints.stance[f];
      s.slip_speed[f] = contacts[f].touching ? contacts[f].slip_velocity_W.norm() : 0.0;
      if (contacts[f].touching && rs.joints.stance[f]) {
        slip_sum += s.slip_speed[f];
        ++slip_n;
      }
    }
    s.error_norm_rad = (s.q_ref - s.q).norm();
    s.base_height_m = q(2);
    s.control_time_us = std::chrono::duration<double, std::micro>(t1 - t0).count();
    s.qp_time_us = 1e6 * ((out.stage1.ran ? out.stage1.solve_time_s : 0.0) +
                          (out.stage2.ran ? out.stage2.solve_time_s : 0.0));
    if (!r.samples.empty()) r.torque_total_variation += (tau - r.samples.back().tau).norm();
    s.stage1_status = static_cast<std::uint8_t>(out.stage1.status);
    s.stage2_status = static_cast<std::uint8_t>(out.stage2.status);
    s.fallback = static_cast<std::uint8_t>(out.fallback);
    err_sum += s.error_norm_rad;
    r.max_error_rad = std::max(r.max_error_rad, s.error_norm_rad);
    r.samples.push_back(s);
    // fallen: the trunk low, or tilted past 45°
    const Eigen::Quaterniond quat(q(3), q(4), q(5), q(6));
    const double up = (quat.toRotationMatrix() * Eigen::Vector3d::UnitZ()).z();
    if (!r.fell && (q(2) < 0.3 || up < std::cos(M_PI / 4))) {
      r.fell = true;
      r.fell_at_s = t;
    }
    if (progress && k % 1000 == 0) progress(static_cast<double>(k) / steps);
  }
  r.mean_error_rad = err_sum / std::max<long>(steps, 1);
  r.mean_slip_speed = slip_n ? slip_sum / slip_n : 0.0;
  r.patch_mean_error_rad = r.patch_cycles ? patch_err / static_cast<double>(r.patch_cycles) : 0.0;
  r.patch_mean_slip_speed = patch_slip_n ? patch_slip / static_cast<double>(patch_slip_n) : 0.0;
  switch (cfg.controller.kind) {
    case servo::ControllerKind::kTwoStageId:
      r.fallbacks = pipeline.controller().two_stage_counters();
      break;
    case servo::ControllerKind::kStage1Id: r.fallbacks = pipeline.controller().stage1_counters(); break;
    case servo::ControllerKind::kNoSlipId: r.fallbacks = pipeline.controller().noslip_counters(); break;
    case servo::ControllerKind::kPid:
    case servo::ControllerKind::kPdGravity: break;
  }
  return r;
}

void WriteCsv(const ExperimentResult& r, const std::string& path) {
  std::ofstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot open for writing");
  f << "t";
  for (const char* col : {"q", "q_ref", "tau"})
    for (int j = 0; j < servo::kNumJoints; ++j) f << ',' << col << j;
  for (int leg = 0; leg < servo::kNumFeet; ++leg)
    f << ",f" << leg << "_x,f" << leg << "_y,f" << leg << "_z,slip" << leg << ",stance" << leg
      << ",touch" << leg;
  f << ",error_norm,base_height,control_us,qp_us,stage1,stage2,fallback";
  for (int leg = 0; leg < servo::kNumFeet; ++leg)
    f << ",mu_true" << leg << ",mu_control" << leg << ",mu_estimate" << leg << ",slipping" << leg;
  f << '\n';
  f.precision(9);
  for (const Sample& s : r.samples) {
    f << s.t;
    for (const auto* v : {&s.q, &s.q_ref, &s.tau})
      for (int j = 0; j < servo::kNumJoints; ++j) f << ',' << (*v)(j);
    for (int leg = 0; leg < servo::kNumFeet; ++leg)
      f << ',' << s.contact_force_W[leg].x() << ',' << s.contact_force_W[leg].y() << ','
        << s.contact_force_W[leg].z() << ',' << s.slip_speed[leg] << ',' << s.stance_ref[leg]
        << ',' << s.touching[leg];
    f << ',' << s.error_norm_rad << ',' << s.base_height_m << ',' << s.control_time_us << ','
      << s.qp_time_us << ','
      << int(s.stage1_status) << ',' << int(s.stage2_status) << ',' << int(s.fallback);
    for (std::size_t leg = 0; leg < servo::kNumFeet; ++leg)
      f << ',' << s.mu_true[leg] << ',' << s.mu_control[leg] << ',' << s.mu_estimate[leg] << ','
        << s.slipping[leg];
    f << '\n';
  }
}

}  // namespace hyq::experiment
