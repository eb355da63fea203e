// Disturbance observer on the trunk (docs/baselines.md): the wrench the model does not
// explain, measured from what HyQ senses (joint load cells, encoders, the base estimate), so that
// a model-based controller can add it to its dynamics. A payload, errors of the links' masses and
// centres of mass, and whatever else pushes on the trunk show up here.
//
// The residual of the floating-base dynamics with the measured joint torques τ_m,
//   e = M v̇ + h − Sᵀ τ_m   (= Σ_stance J_fᵀ f_f + d: contact forces plus the disturbance),
// low-passed (first order at bandwidth_hz; v̇ by the difference of successive v inside the filter,
// which is the generalized-momentum observer's transfer function K/(s + K) of e with M taken as
// constant over a cycle). Every foot's force comes from its leg's rows (3 × 3, the leg's own
// disturbance taken as zero: it cannot be told apart from the foot's force), J_f the Jacobian of
// the contact point under the foot's sphere on flat ground (where the ground pushes):
//   f_f = J_f,legᵀ⁻¹ e_leg(f),   d_b = e_b − Σ_f J_f,bᵀ f_f,
// d_b being the disturbance in the six base rows (the generalized force of v's base part). The
// controller's dynamics then use h − d_b in those rows. All four legs, not only those a stance
// detector calls loaded: a leg in the air has e_leg ≈ 0 (its force estimate is ≈ 0, or its own
// model error), while a foot misclassified around touchdown or lift-off put its whole ground
// force into d_b (measured: ±300 N spikes in a trot with the state estimator's stance). The
// estimate is clamped to max_force_N / max_torque_Nm (a bound on what a failed sensor can
// inject) and frozen (held) while a leg's Jacobian is singular or the residual is not finite.
// Source: De Luca & Mattone, "Sensorless robot collision detection and hybrid force/motion
// control" (ICRA 2005), the generalized-momentum residual; for legged robots with the stance
// legs' rows giving the contact forces, e.g. Bledt et al., "Contact model fusion for event-based
// locomotion in unstructured terrains" (ICRA 2018).
//
// Never allocates or throws after construction.
#pragma once

#include <array>

#include <Eigen/Dense>

#include "dynamics/cycle_dynamics.h"
#include "dynamics/model.h"
#include "hal/config_key.h"

namespace hyq::servo {

struct DisturbanceObserverConfig {
  bool enabled = false;        // off: the controller uses the nominal model
  double bandwidth_hz = 3.0;   // of the residual's low-pass
  double max_force_N = 300.0;  // clamp of the estimate's force part (per axis, base rows 0-2)
  double max_torque_Nm = 100.0;  // ... and of its moment part (rows 3-5)

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("enabled", &enabled).Doc("off: the controller uses the nominal model"));
    // the low-pass must stay well below the loop's Nyquist rate
    a->Visit(hal::Key("bandwidth_hz", &bandwidth_hz).In(0.05, 0.1).MaxTimesRate(1).Unit("Hz")
                 .Doc("of the residual's low-pass"));
    a->Visit(hal::Key("max_force_N", &max_force_N).In(0.0, 2000.0).Unit("N")
                 .Doc("clamp of the estimate's force, per axis (world)"));
    a->Visit(hal::Key("max_torque_Nm", &max_torque_Nm).In(0.0, 1000.0).Unit("N·m")
                 .Doc("clamp of its moment, per axis (base frame)"));
  }
};

class DisturbanceObserver {
 public:
  using Vector6d = Eigen::Matrix<double, 6, 1>;

  DisturbanceObserver(const dynamics::Model& model, const DisturbanceObserverConfig& config, double dt);

  /// One cycle at the measured state: `dyn` = ComputeCycleDynamics(q, v), the joint torques the
  /// load cells measured. Returns the current estimate d_b.
  const Vector6d& Update(const dynamics::CycleDynamics& dyn, const dynamics::VectorV& v,
                         const dynamics::VectorJ& tau_measured_Nm) noexcept;

  /// Forgets everything (on each entry into ACTIVE): the next Update starts the filter.
  void Reset() noexcept;

  const Vector6d& wrench() const noexcept { return d_b_; }
  /// The filtered residual e (all 18 rows), for telemetry and tests.
  const dynamics::VectorV& residual() const noexcept { return e_; }
  bool held() const noexcept { return held_; }
  const DisturbanceObserverConfig& config() const noexcept { return config_; }

 private:
  const dynamics::Model& model_;
  DisturbanceObserverConfig config_;
  double dt_;
  double alpha_;  // the low-pass's weight per cycle, 1 − exp(−2π f dt)
  bool started_ = false;
  bool held_ = true;
  dynamics::VectorV v_prev_ = dynamics::VectorV::Zero();
  dynamics::VectorV e_ = dynamics::VectorV::Zero();
  Vector6d d_b_ = Vector6d::Zero();
};

}  // namespace hyq::servo
