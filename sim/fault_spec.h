// The faults the simulated HyQ injects at simulated times (SimulatedRobot::ScheduleFault), and
// their command-line form (hyq-sim --fault T:KIND:TARGET[:ARG]).
#pragma once

#include <cstdint>
#include <string>

#include "hal/hal_config.h"

namespace hyq::sim {

/// One injected fault. Targets: a joint (index 0..11) for silent, corrupt, drop, nan, emcy; the
/// IMU (joint = kImuTarget) for silent, drop, corrupt, nan; a bus (index) for bus-off.
struct FaultSpec {
  enum class Kind : std::uint8_t { kSilent, kCorrupt, kDrop, kNan, kBusOff, kEmcy };
  static constexpr int kImuTarget = -2;
  double t_s = 0.0;
  Kind kind = Kind::kSilent;
  int joint = -1;
  int bus = -1;
  std::uint32_t count = 1;        // corrupt / drop: frames
  double duration_s = 0.0;        // silent / bus-off: 0 = for good
  std::uint16_t emcy_code = 0x1000;
  std::string text;               // as given (reports)
};
const char* ToString(FaultSpec::Kind k) noexcept;

/// Parses "T:KIND:TARGET[:ARG]": KIND silent|corrupt|drop|nan|bus-off|emcy; TARGET a device name
/// of the configuration ("lf_kfe", "imu"), a joint name ("lf_kfe_joint") or, for bus-off, a bus
/// name ("rh"); ARG: frames for corrupt/drop (default 1), seconds for silent/bus-off (default:
/// for good), the EMCY code for emcy (default 0x1000, hex with 0x). Throws std::invalid_argument
/// naming what was expected and what was found.
FaultSpec ParseFaultSpec(const std::string& text, const hal::HalConfig& config);

}  // namespace hyq::sim
