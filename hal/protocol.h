// HyQ's device protocol on CANopen conventions (docs/can_protocol.md is the reference):
// COB-ID = function code + node id, little-endian payloads, SYNC with a 1..240 counter that every
// TPDO echoes so that a frame answering an older SYNC is recognised as stale.
//
// All encoders and decoders are noexcept and never read outside the frame: a decoder checks the
// identifier, the frame type and the exact length before it touches the payload and returns a
// PdoStatus; the caller counts what is not kOk.
#pragma once

#include <array>
#include <cstdint>

#include "hal/can_channel.h"

namespace hyq::hal {

/// CANopen function codes (CiA 301 predefined connection set).
namespace cob {
inline constexpr std::uint32_t kNmt = 0x000;
inline constexpr std::uint32_t kSync = 0x080;
inline constexpr std::uint32_t kEmcy = 0x080;  // + node (1..127)
inline constexpr std::uint32_t kTpdo1 = 0x180, kTpdo2 = 0x280, kTpdo3 = 0x380, kTpdo4 = 0x480;
inline constexpr std::uint32_t kRpdo1 = 0x200, kRpdo2 = 0x300, kRpdo3 = 0x400, kRpdo4 = 0x500;
inline constexpr std::uint32_t kSdoTx = 0x580, kSdoRx = 0x600;
inline constexpr std::uint32_t kHeartbeat = 0x700;
/// Lock-step simulation only: the plant's clock (PlantClock), on CiA 301's TIME identifier, which
/// HyQ's buses do not use otherwise.
inline constexpr std::uint32_t kPlantClock = 0x100;
}  // namespace cob

inline constexpr std::uint8_t kMinNodeId = 1;
inline constexpr std::uint8_t kMaxNodeId = 127;
/// The master's own node-id: its heartbeat is 0x700 + 127 = 0x77F (docs/can_protocol.md §2).
/// No device may use it.
inline constexpr std::uint8_t kMasterNodeId = 127;
inline constexpr std::uint8_t kSyncCounterMax = 240;  // CiA 301 synchronous counter overflow

// Payload lengths in bytes (FD lengths where the layout needs more than 8).
inline constexpr std::uint8_t kNmtLen = 2;
inline constexpr std::uint8_t kSyncLen = 1;
inline constexpr std::uint8_t kHeartbeatLen = 1;
inline constexpr std::uint8_t kEmcyLen = 8;
inline constexpr std::uint8_t kActuatorTpdoLen = 16;
inline constexpr std::uint8_t kActuatorRpdoLen = 8;
inline constexpr std::uint8_t kImuTpdoLen = 32;
inline constexpr std::uint8_t kPlantClockLen = 8;

enum class FrameKind : std::uint8_t {
  kNmt, kSync, kEmcy, kTpdo1, kTpdo2, kTpdo3, kTpdo4, kRpdo1, kRpdo2, kRpdo3, kRpdo4,
  kSdoTx, kSdoRx, kHeartbeat, kUnknown };

struct FrameAddress {
  FrameKind kind = FrameKind::kUnknown;
  std::uint8_t node = 0;  // 0 for NMT and SYNC
};

/// Splits an 11-bit identifier into function code and node id.
FrameAddress Classify(std::uint32_t id) noexcept;
const char* ToString(FrameKind k) noexcept;

enum class NmtCommand : std::uint8_t {
  kStart = 0x01, kStop = 0x02, kEnterPreOperational = 0x80, kResetNode = 0x81,
  kResetCommunication = 0x82 };

/// The state a heartbeat reports (CiA 301); kBootUp is the boot-up message.
enum class NmtState : std::uint8_t {
  kBootUp = 0x00, kStopped = 0x04, kOperational = 0x05, kPreOperational = 0x7F };

/// Actuator status word (TPDO1 bytes 12-13).
namespace status_bit {
inline constexpr std::uint16_t kReady = 1u << 0;          // powered, sensors valid
inline constexpr std::uint16_t kEnabled = 1u << 1;        // torque set-points are applied
inline constexpr std::uint16_t kFault = 1u << 3;          // latched fault, see the EMCY sent
inline constexpr std::uint16_t kEncoderFault = 1u << 4;
inline constexpr std::uint16_t kSensorFault = 1u << 5;    // load cell / torque sensor
inline constexpr std::uint16_t kRpdoWatchdog = 1u << 6;   // set-points stopped: outputs safe
inline constexpr std::uint16_t kSaturated = 1u << 7;      // set-point clamped to the limit
}  // namespace status_bit

/// Actuator control word (RPDO1 bytes 4-5).
namespace control_bit {
inline constexpr std::uint16_t kEnable = 1u << 0;      // apply the torque set-point
inline constexpr std::uint16_t kFaultReset = 1u << 7;  // rising edge clears a latched fault
}  // namespace control_bit

/// CiA 301 / 402 emergency error codes the boards use.
namespace emcy {
inline constexpr std::uint16_t kNoError = 0x0000;        // error reset
inline constexpr std::uint16_t kGeneric = 0x1000;
inline constexpr std::uint16_t kSupplyPressure = 0x3100;  // hydraulic supply out of range
inline constexpr std::uint16_t kTemperature = 0x4210;     // excess device temperature
inline constexpr std::uint16_t kHardware = 0x5000;
inline constexpr std::uint16_t kSoftware = 0x6100;
inline constexpr std::uint16_t kSensor = 0x7300;          // load cell / torque sensor
inline constexpr std::uint16_t kEncoder = 0x7305;         // position sensor
inline constexpr std::uint16_t kCanOverrun = 0x8110;
inline constexpr std::uint16_t kCanPassive = 0x8120;
inline constexpr std::uint16_t kHeartbeatLost = 0x8130;   // master heartbeat / life guard
inline constexpr std::uint16_t kBusOffRecovered = 0x8140;
inline constexpr std::uint16_t kPdoLength = 0x8210;       // RPDO not processed: length
inline constexpr std::uint16_t kRpdoTimeout = 0x8250;     // RPDO watchdog expired
inline constexpr std::uint16_t kFollowingError = 0x8611;
}  // namespace emcy

/// TPDO1 of an actuator board, sent once per SYNC (16 bytes, CAN FD).
struct ActuatorTpdo {
  std::int32_t position_counts = 0;     // 0..3  joint encoder, counts
  std::int32_t velocity_counts_s = 0;   // 4..7  counts/s
  std::int32_t effort_counts = 0;       // 8..11 load cell (HFE/KFE) or torque sensor (HAA)
  std::uint16_t status = 0;             // 12..13 status_bit
  std::uint8_t sync_counter = 0;        // 14 the SYNC counter this frame answers
  std::uint8_t error_register = 0;      // 15 CiA 301 object 0x1001
};

/// RPDO1 to an actuator board (8 bytes).
struct ActuatorRpdo {
  std::int32_t torque_mNm = 0;      // 0..3 joint torque set-point, mN·m
  std::uint16_t control = 0;        // 4..5 control_bit
  std::uint8_t sync_counter = 0;    // 6 the SYNC counter this set-point is for
  std::uint8_t reserved = 0;        // 7
};

/// TPDO1 of the IMU (32 bytes, CAN FD).
struct ImuTpdo {
  std::array<std::int32_t, 3> gyro_urad_s{};   // 0..11  angular velocity, µrad/s, IMU frame
  std::array<std::int32_t, 3> accel_um_s2{};   // 12..23 specific force, µm/s², IMU frame
  std::uint16_t status = 0;                    // 24..25 status_bit (kReady, kSensorFault)
  std::uint8_t sync_counter = 0;               // 26
  std::uint8_t error_register = 0;             // 27; 28..31 reserved, zero
};

struct EmcyMessage {
  std::uint16_t code = 0;
  std::uint8_t error_register = 0;
  std::array<std::uint8_t, 5> vendor{};
};

/// Lock-step simulation only: what the plant's simulator (hyq-sim) tells the master on every bus
/// after its plant ran periods without the master's SYNCs (an injected stall of the master), ahead
/// of its next answers. In lock-step the plant is the only clock, so a master that stalled learns
/// from it the periods it lost. Not a device's frame (no node id); the master's lock-step channel
/// (hal/lockstep_channel.h) takes it out before the HAL's Read. 8 bytes, little-endian.
struct PlantClock {
  std::uint32_t steps = 0;          // 0..3 the plant's steps so far
  std::uint32_t stalled_steps = 0;  // 4..7 of those, the steps taken without the master, so far
};

enum class [[nodiscard]] PdoStatus : std::uint8_t {
  kOk,
  kWrongId,      // not the identifier this decoder expects
  kNotData,      // remote or error frame
  kExtendedId,   // 29-bit id: never used by this protocol
  kWrongLength,  // payload length differs from the layout
  kBadValue,     // a field outside its defined set (NMT command, heartbeat state, counter)
};
const char* ToString(PdoStatus s) noexcept;

CanFrame EncodeNmt(NmtCommand cmd, std::uint8_t node) noexcept;  // node 0 = all nodes
CanFrame EncodeSync(std::uint8_t counter) noexcept;
CanFrame EncodeHeartbeat(std::uint8_t node, NmtState state) noexcept;
CanFrame EncodeEmcy(std::uint8_t node, const EmcyMessage& m) noexcept;
CanFrame EncodeActuatorTpdo(std::uint8_t node, const ActuatorTpdo& p) noexcept;
CanFrame EncodeActuatorRpdo(std::uint8_t node, const ActuatorRpdo& p) noexcept;
CanFrame EncodeImuTpdo(std::uint8_t node, const ImuTpdo& p) noexcept;
CanFrame EncodePlantClock(const PlantClock& c) noexcept;

PdoStatus DecodeNmt(const CanFrame& f, NmtCommand* cmd, std::uint8_t* node) noexcept;
PdoStatus DecodeSync(const CanFrame& f, std::uint8_t* counter) noexcept;
PdoStatus DecodeHeartbeat(const CanFrame& f, std::uint8_t node, NmtState* state) noexcept;
PdoStatus DecodeEmcy(const CanFrame& f, std::uint8_t node, EmcyMessage* m) noexcept;
PdoStatus DecodeActuatorTpdo(const CanFrame& f, std::uint8_t node, ActuatorTpdo* p) noexcept;
PdoStatus DecodeActuatorRpdo(const CanFrame& f, std::uint8_t node, ActuatorRpdo* p) noexcept;
PdoStatus DecodeImuTpdo(const CanFrame& f, std::uint8_t node, ImuTpdo* p) noexcept;
PdoStatus DecodePlantClock(const CanFrame& f, PlantClock* c) noexcept;

/// The SYNC counter a TPDO1 answers (ActuatorTpdo byte 14 or ImuTpdo byte 26, told apart by
/// length), without decoding the rest; 0 for a frame of neither layout.
std::uint8_t TpdoSyncCounter(const CanFrame& f) noexcept;

/// The counter after `c` on the SYNC counter's 1..240 cycle.
constexpr std::uint8_t NextSyncCounter(std::uint8_t c) noexcept {
  return static_cast<std::uint8_t>(c >= kSyncCounterMax ? 1 : c + 1);
}

/// True when `len` is a payload length a CAN FD frame can carry (0-8, 12, 16, 20, 24, 32, 48, 64).
bool IsValidFdLength(std::size_t len) noexcept;

}  // namespace hyq::hal
