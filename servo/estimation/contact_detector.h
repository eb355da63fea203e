// Contact of one foot from its load, not from the gait schedule (docs/estimation.md): a foot
// that lands early or lifts late is seen as it is.
//
// The probability that the foot carries weight is a logistic function of its estimated vertical
// load F_z (the leg's measured joint torques through its Jacobian):
//   P(contact) = 1 / (1 + exp(−(F_z − F_c) / w)),
// F_c the load at which contact is as likely as not, w the width of the uncertain band (the load
// estimate's noise in swing: the leg's own inertia and gravity, which the massless-leg estimate
// leaves out). A touchdown is the first cycle with P ≥ ½ after a cycle below it; for a window
// after it the foot's kinematic measurement is distrusted by a factor that falls linearly from
// `touchdown_noise_scale` to 1: the foot may still move (an impact's bounce, a foot sliding
// into place), which is what a still-foot measurement cannot express. The same approach
// (a contact probability on a force estimate, with a variance that grows on impact) is that of
// Camurri et al., "Probabilistic contact estimation and impact detection for state estimation
// of quadruped robots" (RA-L 2017), on HyQ.
#pragma once

#include <cstdint>

namespace hyq::servo {

struct ContactDetectorConfig {
  double force_N = 60.0;            // P(contact) = ½ at this vertical load
  double width_N = 10.0;            // logistic width
  double touchdown_window_s = 0.04; // distrust after a touchdown lasts this long ...
  double touchdown_noise_scale = 5.0;  // ... starting at this factor on the foot's noise σ
};

class ContactDetector {
 public:
  /// One cycle with the foot's vertical load. Never allocates or throws.
  void Update(double load_N, const ContactDetectorConfig& config, double dt) noexcept;
  void Reset() noexcept;

  double probability() const noexcept { return probability_; }
  bool in_contact() const noexcept { return probability_ >= 0.5; }
  /// Within the window after a touchdown.
  bool settling() const noexcept { return in_contact() && since_touchdown_s_ < window_s_; }
  /// Factor on the foot's measurement σ: touchdown_noise_scale at touchdown, 1 after the window.
  double noise_scale() const noexcept { return noise_scale_; }
  std::int64_t touchdowns() const noexcept { return touchdowns_; }

 private:
  double probability_ = 0.0;
  double since_touchdown_s_ = 0.0;
  double window_s_ = 0.0;
  double noise_scale_ = 1.0;
  std::int64_t touchdowns_ = 0;
};

}  // namespace hyq::servo
