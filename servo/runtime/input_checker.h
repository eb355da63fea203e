// Plausibility of every cycle's inputs (docs/servo.md, "Safety"): bus-off and corrupted frames,
// devices out of OP, missing or stale joint and IMU inputs, non-finite, out-of-range and jumping
// readings. Returns the first fault found; never allocates or throws after construction.
#pragma once

#include <array>
#include <cstdint>

#include "hal/hal.h"
#include "servo/runtime/fault.h"
#include "servo/runtime/safety_limits.h"

namespace hyq::servo {

/// Plausibility of the process image and the buses, cycle by cycle.
class InputChecker {
 public:
  InputChecker(const SafetyLimits& limits, const hal::HalConfig& hal);

  /// Checks the inputs of the Read that just happened; the first fault found (none: reason
  /// kNone). `expect_op`: the devices should be in OP (after bring-up, outside FAULT).
  Fault Check(const hal::Hal& hal, hal::HalStatus read_status, bool expect_op) noexcept;

  /// Forget the previous positions and counter values (after a fault is acknowledged).
  void Reset(const hal::Hal& hal) noexcept;

 private:
  SafetyLimits limits_;
  std::uint32_t max_held_cycles_;  // the HAL's hold limit (timing.max_held_cycles): one policy
  std::array<double, hal::kNumJoints> q_min_{}, q_max_{};
  std::array<double, hal::kNumJoints> last_q_{};
  std::array<bool, hal::kNumJoints> have_last_{};
  std::array<std::uint64_t, hal::kMaxBuses> malformed_{}, bus_off_{}, error_frames_{},
      foreign_{};
};

}  // namespace hyq::servo
