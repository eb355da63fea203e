#include "sim/fault_spec.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <vector>

namespace hyq::sim {

const char* ToString(FaultSpec::Kind k) noexcept {
  switch (k) {
    case FaultSpec::Kind::kSilent: return "silent";
    case FaultSpec::Kind::kCorrupt: return "corrupt";
    case FaultSpec::Kind::kDrop: return "drop";
    case FaultSpec::Kind::kNan: return "nan";
    case FaultSpec::Kind::kBusOff: return "bus-off";
    case FaultSpec::Kind::kEmcy: return "emcy";
    case FaultSpec::Kind::kReset: return "reset";
    case FaultSpec::Kind::kStall: return "stall";
  }
  return "?";
}

FaultSpec ParseFaultSpec(const std::string& text, const hal::HalConfig& config) {
  auto fail = [&](const std::string& what) {
    throw std::invalid_argument("fault '" + text + "': " + what);
  };
  std::vector<std::string> part;
  std::size_t start = 0;
  for (;;) {
    const std::size_t colon = text.find(':', start);
    part.push_back(text.substr(start, colon - start));
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  if (part.size() < 3 || part.size() > 4)
    fail("expected T:KIND:TARGET[:ARG], found " + std::to_string(part.size()) + " field(s)");
  FaultSpec f;
  f.text = text;
  char* end = nullptr;
  f.t_s = std::strtod(part[0].c_str(), &end);
  if (part[0].empty() || *end != '\0' || !std::isfinite(f.t_s) || f.t_s < 0)
    fail("expected a time in simulated seconds >= 0, found '" + part[0] + "'");
  const std::string& kind = part[1];
  if (kind == "silent") f.kind = FaultSpec::Kind::kSilent;
  else if (kind == "corrupt") f.kind = FaultSpec::Kind::kCorrupt;
  else if (kind == "drop") f.kind = FaultSpec::Kind::kDrop;
  else if (kind == "nan") f.kind = FaultSpec::Kind::kNan;
  else if (kind == "bus-off") f.kind = FaultSpec::Kind::kBusOff;
  else if (kind == "emcy") f.kind = FaultSpec::Kind::kEmcy;
  else if (kind == "reset") f.kind = FaultSpec::Kind::kReset;
  else if (kind == "stall") f.kind = FaultSpec::Kind::kStall;
  else fail("expected a kind silent|corrupt|drop|nan|bus-off|emcy|reset|stall, found '" + kind + "'");
  const std::string& target = part[2];
  if (f.kind == FaultSpec::Kind::kStall) {
    if (target != "daemon") fail("expected the target daemon for stall, found '" + target + "'");
    if (part.size() != 4)
      fail("expected a stall in seconds (T:stall:daemon:S), found no duration");
  } else if (f.kind == FaultSpec::Kind::kBusOff) {
    std::string names;
    for (std::size_t b = 0; b < config.buses.size(); ++b) {
      if (config.buses[b].name == target) f.bus = static_cast<int>(b);
      names += (b ? "|" : "") + config.buses[b].name;
    }
    if (f.bus < 0) fail("expected a bus " + names + ", found '" + target + "'");
  } else {
    f.joint = hal::JointIndex(target);
    for (const hal::BusConfig& b : config.buses)
      for (const hal::DeviceConfig& d : b.devices)
        if (d.name == target) f.joint = d.kind == hal::DeviceKind::kImu ? FaultSpec::kImuTarget : d.joint;
    if (f.joint == -1)
      fail("expected a device (lf_haa, ..., imu) or joint (lf_haa_joint, ...), found '" + target +
           "'");
    if (f.joint == FaultSpec::kImuTarget && f.kind == FaultSpec::Kind::kEmcy)
      fail("expected an actuator board for emcy, found the IMU");
  }
  if (f.kind == FaultSpec::Kind::kReset) f.duration_s = kDefaultBootTimeS;
  if (part.size() == 4) {
    const std::string& a = part[3];
    switch (f.kind) {
      case FaultSpec::Kind::kCorrupt:
      case FaultSpec::Kind::kDrop: {
        const long n = std::strtol(a.c_str(), &end, 10);
        if (a.empty() || *end != '\0' || n < 1 || n > 1'000'000'000)
          fail("expected a frame count >= 1, found '" + a + "'");
        f.count = static_cast<std::uint32_t>(n);
        break;
      }
      case FaultSpec::Kind::kSilent:
      case FaultSpec::Kind::kBusOff:
        f.duration_s = std::strtod(a.c_str(), &end);
        if (a.empty() || *end != '\0' || !(f.duration_s > 0) || !std::isfinite(f.duration_s))
          fail("expected a duration in seconds > 0, found '" + a + "'");
        break;
      case FaultSpec::Kind::kEmcy: {
        const long c = std::strtol(a.c_str(), &end, 0);
        if (a.empty() || *end != '\0' || c < 0 || c > 0xFFFF)
          fail("expected an EMCY code 0..0xFFFF, found '" + a + "'");
        f.emcy_code = static_cast<std::uint16_t>(c);
        break;
      }
      case FaultSpec::Kind::kReset:
        f.duration_s = std::strtod(a.c_str(), &end);
        if (a.empty() || *end != '\0' || !(f.duration_s >= 0) || !std::isfinite(f.duration_s))
          fail("expected a boot time in seconds >= 0, found '" + a + "'");
        break;
      case FaultSpec::Kind::kStall: {
        // whole cycles: the plant steps once per period
        const double period_s = config.timing.cycle_period_s;
        char period[32];
        std::snprintf(period, sizeof period, "%g", period_s);
        f.duration_s = std::strtod(a.c_str(), &end);
        if (a.empty() || *end != '\0' || !std::isfinite(f.duration_s) ||
            !(f.duration_s >= period_s - 1e-12) || f.duration_s > 60.0)
          fail(std::string("expected a stall in seconds from the cycle period (") + period +
               ") to 60, found '" + a + "'");
        break;
      }
      case FaultSpec::Kind::kNan: fail("expected no argument for nan, found '" + a + "'");
    }
  }
  return f;
}

}  // namespace hyq::sim
