// What a fault leaves the daemon, and so how the robot stops (docs/servo.md, "Graded stops"):
// one const table, a row per fault reason, in the manner of hal/device_state_machine.cc, with
// the scope of what the reason loses; the lost inputs then decide the class (IEC 60204-1's stop
// categories 1 and 0; Boston Dynamics' Spot: SETTLE_THEN_CUT and CUT):
//
//   controlled  nothing lost (a deadline streak, a foreign master): the
//               sit-down with the full controller, then damping and 0 N·m
//   degraded    one device lost, a joint (its board silent, corrupt, faulted, its reading
//               non-finite, out of range or jumping) or the IMU: the sit-down without it (the
//               leg of a lost joint out of the stance set and limp, the base without the IMU),
//               then damping and 0 N·m
//   cut         the estimate invalid or the controller without a torque, a bus lost, joints of
//               two legs, a whole leg, or the IMU and a joint: damping at once
//               (safety.damping_Nms_per_rad)
//
// The lost inputs accumulate until the faults are acknowledged: a second device lost during a
// degraded sit-down cuts it when the two together are more than one device's worth (ScanLost
// finds a board that left OP on its own, StopClassOf ranks the set). Nothing here allocates.
#pragma once

#include <array>
#include <cstdint>

#include "hal/hal.h"
#include "servo/common/servo_types.h"
#include "servo/runtime/fault.h"

namespace hyq::servo {

/// What a fault reason loses.
enum class FaultScope : std::uint8_t {
  kNothing,   // the inputs and the actuators are intact
  kSource,    // the joint or the IMU the fault names (nothing when it names neither)
  kBus,       // every device on the bus the fault names
  kControl,   // control itself: the state estimate or the controller's torque
};
const char* ToString(FaultScope s) noexcept;

/// One row of the table: a fault reason, what it loses, and why.
struct StopClassRow {
  EventReason reason;
  FaultScope scope;
  const char* why;  // for docs/servo.md and the tests
};
/// The fault reasons' rows, in EventReason order (the others: kNothing, not a fault).
extern const std::array<StopClassRow, kNumEventReasons> kStopClassTable;
/// Whether `r` is a fault (a row of the table with a scope), i.e. stops the robot.
bool IsFaultReason(EventReason r) noexcept;

/// The class of a stop that must do without `lost`: controlled when nothing is lost, degraded
/// for one joint's leg or the IMU alone, cut otherwise (a whole leg, two legs, the IMU and a
/// joint, the estimate).
StopClass StopClassOf(const LostInputs& lost) noexcept;

/// Adds what `f` loses (its row's scope) to `*lost` and returns the stop class of the whole set.
/// `hal`: which devices a bus holds.
StopClass Classify(const Fault& f, const hal::Hal& hal, LostInputs* lost) noexcept;

/// Adds to `*lost` every joint and the IMU whose device has left OP or whose input is neither
/// fresh nor held (what a stop in progress must stop relying on); true when it added one.
bool ScanLost(const hal::Hal& hal, LostInputs* lost) noexcept;

}  // namespace hyq::servo
