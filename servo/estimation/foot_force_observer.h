// Each foot's ground force from its leg's rows of the floating-base dynamics, by a
// generalized-momentum observer (De Luca & Mattone, "Sensorless robot collision detection and
// hybrid force/motion control", ICRA 2005; the discrete form (1)–(3) of disturbance_observer.h):
//   leg rows:  p_L = M_L v,  ṗ_L = Ṁ_L v + τ_L − h_L + J_Lᵀ F            (M_L, h_L: the leg's 3 rows)
//   r_L = K (p_L − ∫ (τ_L − h_L + Ṁ_L v + r_L) dt)  follows J_Lᵀ F through K / (s + K),
//   F = J_L⁻ᵀ r_L             (J_L: the leg block of the Jacobian of the point under the foot's
//                              sphere on flat ground, where the ground pushes; world)
// A foot in the air has F = 0 whatever its leg's torque: the load read from the torques alone (a
// massless leg, the state estimator's contact detector) reads a leg pushing its foot down through
// the air as loaded, and the gait's contact-aware phases (servo/reference/reference.h) must not
// take such a foot for landed. An impact shows at once (no velocity differences: the momentum
// form), through the observer's pole. The contact probability is logistic in F_z, as the state
// estimator's (Bledt et al., "Contact Model Fusion for Event-Based Locomotion in Unstructured
// Terrains", ICRA 2018, fuse a momentum observer's force with the gait's schedule the same way).
// Never allocates or throws after construction.
#pragma once

#include <array>

#include <Eigen/Dense>

#include "dynamics/cycle_dynamics.h"
#include "dynamics/model.h"
#include "hal/config_key.h"

namespace hyq::servo {

struct FootForceObserverConfig {
  double bandwidth_hz = 40.0;  // K / 2π
  double force_N = 40.0;       // P(contact) = ½ at this vertical ground force ...
  double width_N = 8.0;        // ... logistic width

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("bandwidth_hz", &bandwidth_hz).In(1.0, 0.2).MaxTimesRate(1).Unit("Hz")
                 .Doc("K / 2π of the feet's momentum observer"));
    a->Visit(hal::Key("force_N", &force_N).In(1.0, 1000.0).Unit("N")
                 .Doc("P(contact) = ½ at this vertical ground force ..."));
    a->Visit(hal::Key("width_N", &width_N).In(0.1, 500.0).Unit("N").Doc("... logistic width"));
  }
};

class FootForceObserver {
 public:
  FootForceObserver(const dynamics::Model& model, const FootForceObserverConfig& config, double dt);

  /// Forgets everything: the next Update starts at that cycle's momentum with r = 0.
  void Reset() noexcept;
  /// One cycle at the measured state: `dyn` = ComputeCycleDynamics(q, v), the joint torques the
  /// load cells measured. A singular leg or a non-finite input holds that cycle's estimate.
  void Update(const dynamics::CycleDynamics& dyn, const dynamics::VectorV& v,
              const dynamics::VectorJ& tau_measured_Nm) noexcept;

  /// The ground's force on each foot, world frame, N.
  const std::array<Eigen::Vector3d, dynamics::kNumFeet>& force_W() const noexcept { return force_W_; }
  /// P(contact) per foot, logistic in the vertical force.
  const std::array<double, dynamics::kNumFeet>& probability() const noexcept { return probability_; }
  /// The residual r (the legs' 12 rows, J_Lᵀ F through K / (s + K)), N·m.
  const dynamics::VectorJ& residual() const noexcept { return r_; }

 private:
  using LegRows = Eigen::Matrix<double, dynamics::kNumJoints, dynamics::kNv>;
  const dynamics::Model& model_;
  FootForceObserverConfig config_;
  double dt_, gain_;  // K_d = (1 − e^{−K dt}) / dt
  bool anchored_ = false;
  LegRows A_prev_ = LegRows::Zero();
  dynamics::VectorJ w_prev_ = dynamics::VectorJ::Zero();
  dynamics::VectorV v_prev_ = dynamics::VectorV::Zero();
  dynamics::VectorJ s_ = dynamics::VectorJ::Zero();
  dynamics::VectorJ r_ = dynamics::VectorJ::Zero();
  std::array<Eigen::Vector3d, dynamics::kNumFeet> force_W_{};
  std::array<double, dynamics::kNumFeet> probability_{};
};

}  // namespace hyq::servo
