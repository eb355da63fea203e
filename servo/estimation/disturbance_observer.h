// Disturbance observer on the trunk (docs/baselines.md): the wrench the model does not
// explain, measured from what HyQ senses (joint load cells, encoders, the base estimate), so that
// a model-based controller can add it to its dynamics. A payload, errors of the links' masses and
// centres of mass, and whatever else pushes on the trunk show up here.
//
// A generalized-momentum observer. The floating-base dynamics with the measured joint torques τ_m,
//   M(q) v̇ + h(q, v) = Sᵀ τ_m + τ_ext,   τ_ext = Σ_f J_fᵀ f_f + d   (contact forces, disturbance),
// give the generalized momentum p = M v the rate ṗ = Ṁ v + M v̇ = u + Ṁ v + τ_ext, u = Sᵀ τ_m − h,
// and the residual
//   r(t) = K (p(t) − p(0) − ∫₀ᵗ (u + Ṁ v + r) ds)                                             (1)
// obeys ṙ = K (τ_ext − r): r is τ_ext through K/(s + K), K = 2π bandwidth_hz, computed from the
// momentum and an integral, with no v̇. De Luca's form writes Ṁ v − h as Cᵀ v − g (Ṁ = C + Cᵀ);
// the dynamics library gives h = C v + g as one vector (RNEA, dynamics/rnea.h), not C, so Ṁ v
// comes from the difference of successive M, which depends on q only (the encoders and the
// estimated orientation), not on v.
// In continuous time r is the residual M v̇ + h − Sᵀ τ_m low-passed at K. The momentum form divides
// no velocity difference by dt and takes M v̇ and u over the same interval (below); it does not
// shield r from errors in v: noise on v reaches r scaled by K M (not a differentiator's M / dt,
// but as much as a low-passed one), and a velocity error δv moves r by K M δv, forgotten with
// time constant 1/K. r is as good as the base-velocity estimate within its bandwidth.
//
// Per cycle k of dt, with s_k = p(0) + the integral of (1) up to k:
//   s_k = s_{k−1} + (½ (u_k + u_{k−1}) + r_{k−1}) dt + (M_k − M_{k−1}) (v_k + v_{k−1}) / 2      (2)
//   r_k = K_d (p_k − s_k),   K_d = (1 − e^{−K dt}) / dt                                       (3)
// ∫ u dt by the trapezoid rule, ∫ Ṁ v dt by the midpoint rule. (2)–(3) make r_k = r_{k−1} +
// K_d dt (ē_k − r_{k−1}), ē_k = ½ (M_k + M_{k−1}) (v_k − v_{k−1}) / dt − ½ (u_k + u_{k−1}) the
// residual over the cycle, second-order accurate at its middle: a constant one reaches
// r_k = (1 − e^{−K k dt}) ē, the step response of K/(s + K) sampled exactly (K_d → K as dt → 0).
//
// The trunk's disturbance comes from the same observer run on a projection of the dynamics that
// removes the feet's forces. Every foot's force comes from its leg's rows (3 × 3, the leg's own
// disturbance taken as zero: it cannot be told apart from the foot's force), J_f the Jacobian of
// the contact point under the foot's sphere on flat ground (where the ground pushes):
//   f_f = J_f,legᵀ⁻¹ τ_ext,leg(f),  so  d_b = P τ_ext,
//   P(q) = [ I₆ | −J_0,bᵀ J_0,legᵀ⁻¹ | −J_1,bᵀ J_1,legᵀ⁻¹ | −J_2,bᵀ J_2,legᵀ⁻¹ | −J_3,bᵀ J_3,legᵀ⁻¹ ]
// (6 × 18; d_b is the disturbance in the six base rows, the generalized force of v's base part).
// The projected momentum p_b = P M v has ṗ_b = (P M)˙ v + P u + d_b, so (1)–(3) with P M for M
// and P u for u give r_b: d_b through K/(s + K), (P M)˙ v from successive P M as Ṁ v is.
// Projected before the filter, not after: the feet's forces switch at every touchdown and
// lift-off while the legs' Jacobians change with every step, and the filtered 18-row r split
// with the present Jacobians carries a lifted foot's decaying force through its swinging leg's
// Jacobian into d_b (docs/baselines.md: +10 % tracking error on the trot with the true velocity
// and the shipped gains, where projected it is +0.5 %).
// The controller's dynamics then use h − d_b in the base rows. All four legs, not only those a
// stance detector calls loaded: a leg in the air has τ_ext,leg ≈ 0 (its force estimate is ≈ 0,
// or its own model error), while a foot misclassified around touchdown or lift-off put its whole
// ground force into d_b (measured: ±300 N spikes in a trot with the state estimator's stance).
// The estimate is clamped to max_force_N / max_torque_Nm (a bound on what a failed sensor can
// inject) and held while a leg's Jacobian is singular (P undefined; r still runs) or an input is
// not finite (r held too). Either observer restarts its integral at the next cycle it can run,
// at that cycle's momentum and keeping its r, as Ṁ v and (P M)˙ v need two successive cycles.
// Sources: De Luca & Mattone, "Sensorless robot collision detection and hybrid force/motion
// control" (ICRA 2005), the generalized-momentum residual (1); De Luca, Albu-Schäffer, Haddadin &
// Hirzinger, "Collision detection and safe reaction with the DLR-III lightweight manipulator arm"
// (IROS 2006), the same residual as a first-order filter of τ_ext; for legged robots with the
// legs' rows giving the contact forces, e.g. Bledt et al., "Contact model fusion for event-based
// locomotion in unstructured terrains" (ICRA 2018).
//
// Never allocates or throws after construction.
#pragma once

#include <array>
#include <cmath>

#include <Eigen/Dense>

#include "dynamics/cycle_dynamics.h"
#include "dynamics/model.h"
#include "hal/config_key.h"

namespace hyq::servo {

/// K_d of (3) for a pole at bandwidth_hz: the step response of K/(s + K) sampled exactly.
inline double MomentumObserverGain(double bandwidth_hz, double dt) noexcept {
  return (1.0 - std::exp(-2.0 * M_PI * bandwidth_hz * dt)) / dt;
}

struct DisturbanceObserverConfig {
  bool enabled = false;        // off: the controller uses the nominal model
  double bandwidth_hz = 3.0;   // K / 2π: the estimate follows the disturbance through K / (s + K)
  double max_force_N = 300.0;  // clamp of the estimate's force part (per axis, base rows 0-2)
  double max_torque_Nm = 100.0;  // ... and of its moment part (rows 3-5)

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("enabled", &enabled).Doc("off: the controller uses the nominal model"));
    // the observer's pole must stay well below the loop's Nyquist rate
    a->Visit(hal::Key("bandwidth_hz", &bandwidth_hz).In(0.05, 0.1).MaxTimesRate(1).Unit("Hz")
                 .Doc("K / 2π of the momentum observer: the estimate follows the disturbance "
                      "through K / (s + K)"));
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

  /// Forgets everything (on each entry into ACTIVE): the next Update starts the observer with
  /// r = 0 at that cycle's momentum.
  void Reset() noexcept;

  /// d_b, the trunk's disturbance through K / (s + K), clamped.
  const Vector6d& wrench() const noexcept { return d_b_; }
  /// The residual r (all 18 rows, τ_ext through K / (s + K)), for telemetry and tests.
  const dynamics::VectorV& residual() const noexcept { return full_.r; }
  bool held() const noexcept { return held_; }
  const DisturbanceObserverConfig& config() const noexcept { return config_; }

 private:
  using Matrix6V = Eigen::Matrix<double, 6, dynamics::kNv>;

  // (2)–(3) for a momentum A v with the known force w on it: r is the rest of its rate but
  // (A)˙ v, through K/(s + K)
  template <int N>
  struct MomentumResidual {
    using Vector = Eigen::Matrix<double, N, 1>;
    using Matrix = Eigen::Matrix<double, N, dynamics::kNv>;
    Matrix A_prev = Matrix::Zero();
    Vector w_prev = Vector::Zero();
    Vector s = Vector::Zero();  // p(0) + the integral of (1)
    Vector r = Vector::Zero();
    bool anchored = false;  // A_prev and w_prev are the last cycle's
    // false: (re)started at this cycle's momentum, r kept
    bool Step(const Matrix& A, const dynamics::VectorV& v, const dynamics::VectorV& v_prev,
              const Vector& w, double gain, double dt) noexcept;
  };

  // P into P_; false for a singular J_leg
  bool Project(const dynamics::CycleDynamics& dyn) noexcept;

  const dynamics::Model& model_;
  DisturbanceObserverConfig config_;
  double dt_;
  double gain_;  // K_d of (3), 1/s
  bool held_ = true;
  dynamics::VectorV v_prev_ = dynamics::VectorV::Zero();
  MomentumResidual<dynamics::kNv> full_;  // r, all 18 rows
  MomentumResidual<6> base_;              // r_b, the projection's 6 rows
  Matrix6V P_ = Matrix6V::Zero();
  Matrix6V PM_ = Matrix6V::Zero();
  Vector6d d_b_ = Vector6d::Zero();
};

}  // namespace hyq::servo
