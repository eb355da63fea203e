#include "servo/runtime/stop_class.h"

namespace hyq::servo {
namespace {

using R = EventReason;
using S = FaultScope;

constexpr std::array<StopClassRow, kNumEventReasons> MakeTable() {
  std::array<StopClassRow, kNumEventReasons> t{};
  for (std::size_t i = 0; i < t.size(); ++i)
    t[i] = {static_cast<R>(i), S::kNothing, nullptr};  // not a fault
  // clang-format off
  const StopClassRow rows[] = {
    {R::kDeviceFault,       S::kSource,   "a board reports a fault or left OP: its joint (or the IMU) is lost"},
    {R::kInputMissing,      S::kSource,   "a joint's or the IMU's input is older than the hold: it is lost"},
    {R::kBusOff,            S::kBus,      "a bus is off: every board on it (a leg, with the IMU on lf) is lost"},
    {R::kCorruptFrames,     S::kSource,   "malformed frames from a board: its joint (or the IMU) is not trusted"},
    {R::kNonFiniteInput,    S::kSource,   "a NaN or Inf reading: that joint (or the IMU) is lost"},
    {R::kOutOfRange,        S::kSource,   "a reading outside what the joint (or the IMU) can do: not trusted"},
    {R::kInputJump,         S::kSource,   "a position jump no joint can make: that encoder is not trusted"},
    {R::kControllerFailure, S::kControl, "no torque (bad input, failed IK): nothing to sit down with"},
    {R::kDeadlineMiss,      S::kNothing,  "late cycles, inputs and actuators intact"},
    {R::kEstimatorFailure,  S::kControl, "the base estimate is invalid: nothing to sit down with"},
    {R::kForeignMaster,     S::kNothing,  "frames of another master: the daemon's own control is intact"},
  };
  // clang-format on
  for (const StopClassRow& r : rows) t[static_cast<std::size_t>(r.reason)] = r;
  return t;
}

// a lost device's joint (or the IMU)
void LoseDevice(const hal::DeviceRuntime& d, LostInputs* lost) noexcept {
  if (d.kind == hal::DeviceKind::kImu) lost->imu = true;
  else if (d.joint >= 0 && d.joint < kNumJoints) lost->joint[static_cast<std::size_t>(d.joint)] = true;
}

}  // namespace

const std::array<StopClassRow, kNumEventReasons> kStopClassTable = MakeTable();

const char* ToString(FaultScope s) noexcept {
  switch (s) {
    case FaultScope::kNothing: return "nothing";
    case FaultScope::kSource: return "the device";
    case FaultScope::kBus: return "the bus";
    case FaultScope::kControl: return "control";
  }
  return "?";
}

bool IsFaultReason(EventReason r) noexcept {
  const auto i = static_cast<std::size_t>(r);
  return i < kStopClassTable.size() && kStopClassTable[i].why != nullptr;
}

StopClass StopClassOf(const LostInputs& lost) noexcept {
  if (lost.control || lost.legs() > 1 || (lost.imu && lost.legs() > 0)) return StopClass::kCut;
  for (int l = 0; l < hal::kNumLegs; ++l) {
    int n = 0;
    for (int k = 0; k < hal::kJointsPerLeg; ++k)
      n += lost.joint[static_cast<std::size_t>(hal::kJointsPerLeg * l + k)] ? 1 : 0;
    if (n == hal::kJointsPerLeg) return StopClass::kCut;  // the whole leg: its bus, in effect
  }
  return lost.any() ? StopClass::kDegraded : StopClass::kControlled;
}

StopClass Classify(const Fault& f, const hal::Hal& hal, LostInputs* lost) noexcept {
  const auto i = static_cast<std::size_t>(f.reason);
  if (!f || i >= kStopClassTable.size()) return StopClassOf(*lost);
  switch (kStopClassTable[i].scope) {
    case FaultScope::kNothing: break;
    case FaultScope::kSource:
      if (f.imu) lost->imu = true;
      else if (f.joint >= 0 && f.joint < kNumJoints) lost->joint[static_cast<std::size_t>(f.joint)] = true;
      break;
    case FaultScope::kBus:
      if (f.bus >= 0 && static_cast<std::size_t>(f.bus) < hal.num_buses()) {
        for (const auto& d : hal.bus(static_cast<std::size_t>(f.bus)).devices()) LoseDevice(d, lost);
      } else {
        lost->control = true;  // a bus the fault cannot name: nothing is known to be left
      }
      break;
    case FaultScope::kControl: lost->control = true; break;
  }
  return StopClassOf(*lost);
}

bool ScanLost(const hal::Hal& hal, LostInputs* lost) noexcept {
  const LostInputs before = *lost;
  const auto gone = [](hal::InputStatus s) {
    return s != hal::InputStatus::kValid && s != hal::InputStatus::kHeld;
  };
  for (std::size_t b = 0; b < hal.num_buses(); ++b)
    for (const auto& d : hal.bus(b).devices())
      if (d.state != hal::DeviceState::kOp) LoseDevice(d, lost);
  const auto& image = hal.image();
  for (std::size_t j = 0; j < image.joints.size(); ++j)
    if (gone(image.joints[j].status)) lost->joint[j] = true;
  if (gone(image.imu.status)) lost->imu = true;
  return lost->joint != before.joint || lost->imu != before.imu;
}

}  // namespace hyq::servo
