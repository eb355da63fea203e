// The faults the simulated HyQ injects at simulated times (SimulatedRobot::ScheduleFault), and
// their command-line form (hyq-sim --fault T:KIND:TARGET[:ARG]).
#pragma once

#include <cstdint>
#include <string>

#include "hal/hal_config.h"

namespace hyq::sim {

/// A board's boot time after a reset (FaultSpec::Kind::kReset without ARG): from the reset to its
/// CANopen boot-up message. An assumption of order, not a measurement of HyQ's boards: a
/// microcontroller leaves reset within a millisecond, but before its CANopen stack announces the
/// node the firmware starts its clocks and peripherals, initialises the encoder interface and the
/// load cell's ADC and often waits a moment in a bootloader for a firmware download on the bus;
/// small CANopen devices take tens of milliseconds for that. 50 ms is fifty of the servo's cycles:
/// longer than any hold of a missing input (the HAL's max_held_cycles) and far shorter than the
/// heartbeat consumer's timeout, so the master sees the board vanish and then announce itself.
inline constexpr double kDefaultBootTimeS = 0.05;

/// One injected fault. Targets: a joint (index 0..11) for silent, corrupt, drop, nan, emcy,
/// reset; the IMU (joint = kImuTarget) for silent, drop, corrupt, nan, reset; a bus (index) for
/// bus-off; the master (the daemon; neither joint nor bus) for stall.
///  - reset: the device resets (a power glitch, its watchdog) and boots again after duration_s
///    (hal::Emulator::ResetJointBoard).
///  - stall: lock-step only (SimulatedRobot::PollLockStep); the master stalls for duration_s: the
///    plant steps on without its SYNCs, the boards holding what they have (and their own timers
///    running), and then tells the master the periods it lost (hal::PlantClock).
struct FaultSpec {
  enum class Kind : std::uint8_t { kSilent, kCorrupt, kDrop, kNan, kBusOff, kEmcy, kReset, kStall };
  static constexpr int kImuTarget = -2;
  double t_s = 0.0;
  Kind kind = Kind::kSilent;
  int joint = -1;
  int bus = -1;
  std::uint32_t count = 1;        // corrupt / drop: frames
  double duration_s = 0.0;        // silent / bus-off: 0 = for good; reset: the boot time; stall
  std::uint16_t emcy_code = 0x1000;
  std::string text;               // as given (reports)
};
const char* ToString(FaultSpec::Kind k) noexcept;

/// Parses "T:KIND:TARGET[:ARG]": KIND silent|corrupt|drop|nan|bus-off|emcy|reset|stall; TARGET a
/// device name of the configuration ("lf_kfe", "imu") or a joint name ("lf_kfe_joint"), for
/// bus-off a bus name ("rh"), for stall "daemon"; ARG: frames for corrupt/drop (default 1),
/// seconds for silent/bus-off (default: for good), the EMCY code for emcy (default 0x1000, hex
/// with 0x), the boot time in seconds >= 0 for reset (default kDefaultBootTimeS), the stall in
/// seconds for stall (required, at least one cycle period of `config`). Throws
/// std::invalid_argument naming what was expected and what was found.
FaultSpec ParseFaultSpec(const std::string& text, const hal::HalConfig& config);

}  // namespace hyq::sim
