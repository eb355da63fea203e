// The process image the Hal shares with the controller: the calibrated inputs of the last Read,
// flagged per joint and for the IMU, and the torque commands for the next Write (hal/hal.h).
#pragma once

#include <array>
#include <cstdint>
#include <limits>

#include "hal/device_state_machine.h"
#include "hal/hal_config.h"

namespace hyq::hal {

/// Per-joint / IMU input quality in the process image.
enum class InputStatus : std::uint8_t {
  kValid,           // exactly one TPDO answering the last SYNC arrived this cycle
  kHeld,            // not received this cycle, within the hold limit (timing.max_held_cycles):
                    // the values are the last valid ones, age_cycles old, a joint's angle
                    // extrapolated by its last velocity (docs/hal.md, "Late or missing answers")
  kMissing,         // expected but not received for more than max_held_cycles in a row (values
                    // still the last valid ones; the device has left OP)
  kDuplicate,       // more than one TPDO for the same SYNC (values not updated)
  kDeviceFault,     // received, but the status word reports a fault (values updated)
  kNotOperational,  // the device is not in SAFE-OP or OP
};
const char* ToString(InputStatus s) noexcept;

/// Values are NaN until the first valid frame, so that a consumer ignoring `status` cannot mistake
/// "never received" for a reading.
struct JointInput {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  double position_rad = kNaN;
  double velocity_rad_s = kNaN;
  double torque_Nm = kNaN;         // from the load cell through r(q) (HFE/KFE) or torque sensor
  double sensor_value = kNaN;      // cylinder force in N (HFE/KFE) or HAA torque in N·m
  std::int32_t position_counts = 0;
  std::int32_t velocity_counts_s = 0;
  std::int32_t effort_counts = 0;
  std::uint16_t status_word = 0;
  InputStatus status = InputStatus::kNotOperational;
  std::uint32_t age_cycles = 0;    // cycles since the values were last fresh (0 = this cycle)
  DeviceState device_state = DeviceState::kInit;
  bool valid() const noexcept { return status == InputStatus::kValid; }
};

struct ImuInput {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::array<double, 3> gyro_rad_s{kNaN, kNaN, kNaN};   // IMU frame
  std::array<double, 3> accel_m_s2{kNaN, kNaN, kNaN};   // specific force, IMU frame
  std::uint16_t status_word = 0;
  InputStatus status = InputStatus::kNotOperational;
  std::uint32_t age_cycles = 0;
  DeviceState device_state = DeviceState::kInit;
  bool valid() const noexcept { return status == InputStatus::kValid; }
};

struct JointCommand {
  double torque_Nm = 0.0;  // applied only while the joint's device is in OP; clamped to the limit
};

struct WorkingCounter {
  std::uint32_t expected = 0;
  std::uint32_t received = 0;
  bool ok() const noexcept { return expected == received; }
};

/// The process image: inputs of the last Read, outputs for the next Write. Joint order lf, rf,
/// lh, rh x haa, hfe, kfe.
struct ProcessImage {
  std::uint64_t cycle = 0;  // Read calls so far
  std::array<JointInput, kNumJoints> joints{};
  ImuInput imu;
  std::array<JointCommand, kNumJoints> commands{};
  WorkingCounter wkc;       // all buses, last Read
};

}  // namespace hyq::hal
