#include "servo/estimation/contact_detector.h"

#include <algorithm>
#include <cmath>

namespace hyq::servo {

void ContactDetector::Reset() noexcept {
  probability_ = 0.0;
  since_touchdown_s_ = 0.0;
  noise_scale_ = 1.0;
}

void ContactDetector::Update(double load_N, const ContactDetectorConfig& config, double dt) noexcept {
  const bool was_in_contact = in_contact();
  const double x = (load_N - config.force_N) / std::max(config.width_N, 1e-9);
  probability_ = std::isfinite(x) ? 1.0 / (1.0 + std::exp(-std::clamp(x, -50.0, 50.0))) : 0.0;
  window_s_ = config.touchdown_window_s;
  if (in_contact() && !was_in_contact) {
    since_touchdown_s_ = 0.0;
    ++touchdowns_;
  } else {
    since_touchdown_s_ += dt;
  }
  const double left = window_s_ > 0.0 ? std::max(0.0, 1.0 - since_touchdown_s_ / window_s_) : 0.0;
  noise_scale_ = in_contact() ? 1.0 + (config.touchdown_noise_scale - 1.0) * left : 1.0;
}

}  // namespace hyq::servo
