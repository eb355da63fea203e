// The minimum-jerk profile the references move along: s(x) = 10x³ − 15x⁴ + 6x⁵ on [0, 1] (0 and 1
// at the ends with zero first and second derivatives), and its derivatives in x.
#pragma once

namespace hyq::servo {

struct Smooth {
  double s, ds, dds;
};

inline Smooth MinJerk(double x) noexcept {
  if (x <= 0.0) return {0.0, 0.0, 0.0};
  if (x >= 1.0) return {1.0, 0.0, 0.0};
  const double x2 = x * x, x3 = x2 * x;
  return {x3 * (10 - 15 * x + 6 * x2), 30 * x2 * (1 - 2 * x + x2), 60 * x * (1 - 3 * x + 2 * x2)};
}

}  // namespace hyq::servo
