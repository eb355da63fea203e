#include "hal/protocol.h"

#include <cstring>

namespace hyq::hal {
namespace {

void PutU16(std::uint8_t* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
void PutI32(std::uint8_t* p, std::int32_t s) noexcept {
  const auto v = static_cast<std::uint32_t>(s);
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
  p[2] = static_cast<std::uint8_t>(v >> 16);
  p[3] = static_cast<std::uint8_t>(v >> 24);
}
std::uint16_t GetU16(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
std::int32_t GetI32(const std::uint8_t* p) noexcept {
  const std::uint32_t v = static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
                          (static_cast<std::uint32_t>(p[2]) << 16) |
                          (static_cast<std::uint32_t>(p[3]) << 24);
  return static_cast<std::int32_t>(v);
}

CanFrame MakeFrame(std::uint32_t id, std::uint8_t len) noexcept {
  CanFrame f;
  f.id = id;
  f.len = len;
  f.flags = CanFrame::kFd | CanFrame::kBitrateSwitch;  // every frame of the protocol is FD + BRS
  return f;
}

// checks shared by every decoder: a data frame, 11-bit id, the expected id and length
PdoStatus CheckFrame(const CanFrame& f, std::uint32_t id, std::uint8_t len) noexcept {
  if ((f.flags & (CanFrame::kRemote | CanFrame::kError)) != 0) return PdoStatus::kNotData;
  if (f.is_extended()) return PdoStatus::kExtendedId;
  if (f.id != id) return PdoStatus::kWrongId;
  if (f.len != len) return PdoStatus::kWrongLength;
  return PdoStatus::kOk;
}

bool IsNodeId(std::uint8_t n) noexcept { return n >= kMinNodeId && n <= kMaxNodeId; }

// CheckFrame for the frames a node sends or receives at cob_base + node
PdoStatus CheckNodeFrame(const CanFrame& f, std::uint32_t cob_base, std::uint8_t node,
                         std::uint8_t len) noexcept {
  if (!IsNodeId(node)) return PdoStatus::kWrongId;
  return CheckFrame(f, cob_base + node, len);
}

}  // namespace

bool IsValidFdLength(std::size_t len) noexcept {
  return len <= 8 || len == 12 || len == 16 || len == 20 || len == 24 || len == 32 ||
         len == 48 || len == 64;
}

FrameAddress Classify(std::uint32_t id) noexcept {
  if (id > 0x7FF) return {};
  if (id == cob::kNmt) return {FrameKind::kNmt, 0};
  if (id == cob::kSync) return {FrameKind::kSync, 0};
  const auto node = static_cast<std::uint8_t>(id & 0x7F);
  if (node == 0) return {};
  switch (id & 0x780) {
    case cob::kEmcy: return {FrameKind::kEmcy, node};
    case cob::kTpdo1: return {FrameKind::kTpdo1, node};
    case cob::kTpdo2: return {FrameKind::kTpdo2, node};
    case cob::kTpdo3: return {FrameKind::kTpdo3, node};
    case cob::kTpdo4: return {FrameKind::kTpdo4, node};
    case cob::kRpdo1: return {FrameKind::kRpdo1, node};
    case cob::kRpdo2: return {FrameKind::kRpdo2, node};
    case cob::kRpdo3: return {FrameKind::kRpdo3, node};
    case cob::kRpdo4: return {FrameKind::kRpdo4, node};
    case cob::kSdoTx: return {FrameKind::kSdoTx, node};
    case cob::kSdoRx: return {FrameKind::kSdoRx, node};
    case cob::kHeartbeat: return {FrameKind::kHeartbeat, node};
    default: return {};
  }
}

const char* ToString(FrameKind k) noexcept {
  switch (k) {
    case FrameKind::kNmt: return "NMT";
    case FrameKind::kSync: return "SYNC";
    case FrameKind::kEmcy: return "EMCY";
    case FrameKind::kTpdo1: return "TPDO1";
    case FrameKind::kTpdo2: return "TPDO2";
    case FrameKind::kTpdo3: return "TPDO3";
    case FrameKind::kTpdo4: return "TPDO4";
    case FrameKind::kRpdo1: return "RPDO1";
    case FrameKind::kRpdo2: return "RPDO2";
    case FrameKind::kRpdo3: return "RPDO3";
    case FrameKind::kRpdo4: return "RPDO4";
    case FrameKind::kSdoTx: return "SDO-tx";
    case FrameKind::kSdoRx: return "SDO-rx";
    case FrameKind::kHeartbeat: return "heartbeat";
    case FrameKind::kUnknown: return "unknown";
  }
  return "unknown";
}

const char* ToString(PdoStatus s) noexcept {
  switch (s) {
    case PdoStatus::kOk: return "ok";
    case PdoStatus::kWrongId: return "wrong_id";
    case PdoStatus::kNotData: return "not_data";
    case PdoStatus::kExtendedId: return "extended_id";
    case PdoStatus::kWrongLength: return "wrong_length";
    case PdoStatus::kBadValue: return "bad_value";
  }
  return "unknown";
}

CanFrame EncodeNmt(NmtCommand cmd, std::uint8_t node) noexcept {
  CanFrame f = MakeFrame(cob::kNmt, kNmtLen);
  f.data[0] = static_cast<std::uint8_t>(cmd);
  f.data[1] = node;
  return f;
}

CanFrame EncodeSync(std::uint8_t counter) noexcept {
  CanFrame f = MakeFrame(cob::kSync, kSyncLen);
  f.data[0] = counter;
  return f;
}

CanFrame EncodeHeartbeat(std::uint8_t node, NmtState state) noexcept {
  CanFrame f = MakeFrame(cob::kHeartbeat + node, kHeartbeatLen);
  f.data[0] = static_cast<std::uint8_t>(state);
  return f;
}

CanFrame EncodeEmcy(std::uint8_t node, const EmcyMessage& m) noexcept {
  CanFrame f = MakeFrame(cob::kEmcy + node, kEmcyLen);
  PutU16(&f.data[0], m.code);
  f.data[2] = m.error_register;
  std::memcpy(&f.data[3], m.vendor.data(), m.vendor.size());
  return f;
}

CanFrame EncodeActuatorTpdo(std::uint8_t node, const ActuatorTpdo& p) noexcept {
  CanFrame f = MakeFrame(cob::kTpdo1 + node, kActuatorTpdoLen);
  PutI32(&f.data[0], p.position_counts);
  PutI32(&f.data[4], p.velocity_counts_s);
  PutI32(&f.data[8], p.effort_counts);
  PutU16(&f.data[12], p.status);
  f.data[14] = p.sync_counter;
  f.data[15] = p.error_register;
  return f;
}

CanFrame EncodeActuatorRpdo(std::uint8_t node, const ActuatorRpdo& p) noexcept {
  CanFrame f = MakeFrame(cob::kRpdo1 + node, kActuatorRpdoLen);
  PutI32(&f.data[0], p.torque_mNm);
  PutU16(&f.data[4], p.control);
  f.data[6] = p.sync_counter;
  f.data[7] = p.reserved;
  return f;
}

CanFrame EncodeImuTpdo(std::uint8_t node, const ImuTpdo& p) noexcept {
  CanFrame f = MakeFrame(cob::kTpdo1 + node, kImuTpdoLen);
  for (int i = 0; i < 3; ++i) {
    PutI32(&f.data[static_cast<std::size_t>(4 * i)], p.gyro_urad_s[static_cast<std::size_t>(i)]);
    PutI32(&f.data[static_cast<std::size_t>(12 + 4 * i)],
           p.accel_um_s2[static_cast<std::size_t>(i)]);
  }
  PutU16(&f.data[24], p.status);
  f.data[26] = p.sync_counter;
  f.data[27] = p.error_register;
  return f;
}

CanFrame EncodePlantClock(const PlantClock& c) noexcept {
  CanFrame f = MakeFrame(cob::kPlantClock, kPlantClockLen);
  PutI32(&f.data[0], static_cast<std::int32_t>(c.steps));
  PutI32(&f.data[4], static_cast<std::int32_t>(c.stalled_steps));
  return f;
}

PdoStatus DecodeNmt(const CanFrame& f, NmtCommand* cmd, std::uint8_t* node) noexcept {
  if (const PdoStatus s = CheckFrame(f, cob::kNmt, kNmtLen); s != PdoStatus::kOk) return s;
  const std::uint8_t c = f.data[0];
  if (c != 0x01 && c != 0x02 && c != 0x80 && c != 0x81 && c != 0x82) return PdoStatus::kBadValue;
  if (f.data[1] > kMaxNodeId) return PdoStatus::kBadValue;
  *cmd = static_cast<NmtCommand>(c);
  *node = f.data[1];
  return PdoStatus::kOk;
}

PdoStatus DecodeSync(const CanFrame& f, std::uint8_t* counter) noexcept {
  if (const PdoStatus s = CheckFrame(f, cob::kSync, kSyncLen); s != PdoStatus::kOk) return s;
  if (f.data[0] < 1 || f.data[0] > kSyncCounterMax) return PdoStatus::kBadValue;
  *counter = f.data[0];
  return PdoStatus::kOk;
}

PdoStatus DecodeHeartbeat(const CanFrame& f, std::uint8_t node, NmtState* state) noexcept {
  const PdoStatus s = CheckNodeFrame(f, cob::kHeartbeat, node, kHeartbeatLen);
  if (s != PdoStatus::kOk) return s;
  const std::uint8_t v = f.data[0] & 0x7F;  // bit 7 is the CiA 301 toggle bit (node guarding)
  if (v != 0x00 && v != 0x04 && v != 0x05 && v != 0x7F) return PdoStatus::kBadValue;
  *state = static_cast<NmtState>(v);
  return PdoStatus::kOk;
}

PdoStatus DecodeEmcy(const CanFrame& f, std::uint8_t node, EmcyMessage* m) noexcept {
  const PdoStatus s = CheckNodeFrame(f, cob::kEmcy, node, kEmcyLen);
  if (s != PdoStatus::kOk) return s;
  m->code = GetU16(&f.data[0]);
  m->error_register = f.data[2];
  std::memcpy(m->vendor.data(), &f.data[3], m->vendor.size());
  return PdoStatus::kOk;
}

PdoStatus DecodePlantClock(const CanFrame& f, PlantClock* c) noexcept {
  if (const PdoStatus s = CheckFrame(f, cob::kPlantClock, kPlantClockLen); s != PdoStatus::kOk)
    return s;
  c->steps = static_cast<std::uint32_t>(GetI32(&f.data[0]));
  c->stalled_steps = static_cast<std::uint32_t>(GetI32(&f.data[4]));
  return PdoStatus::kOk;
}

std::uint8_t TpdoSyncCounter(const CanFrame& f) noexcept {
  if (f.len == kActuatorTpdoLen) return f.data[14];
  if (f.len == kImuTpdoLen) return f.data[26];
  return 0;
}

PdoStatus DecodeActuatorTpdo(const CanFrame& f, std::uint8_t node, ActuatorTpdo* p) noexcept {
  const PdoStatus s = CheckNodeFrame(f, cob::kTpdo1, node, kActuatorTpdoLen);
  if (s != PdoStatus::kOk) return s;
  if (f.data[14] < 1 || f.data[14] > kSyncCounterMax) return PdoStatus::kBadValue;
  p->position_counts = GetI32(&f.data[0]);
  p->velocity_counts_s = GetI32(&f.data[4]);
  p->effort_counts = GetI32(&f.data[8]);
  p->status = GetU16(&f.data[12]);
  p->sync_counter = f.data[14];
  p->error_register = f.data[15];
  return PdoStatus::kOk;
}

PdoStatus DecodeActuatorRpdo(const CanFrame& f, std::uint8_t node, ActuatorRpdo* p) noexcept {
  const PdoStatus s = CheckNodeFrame(f, cob::kRpdo1, node, kActuatorRpdoLen);
  if (s != PdoStatus::kOk) return s;
  if (f.data[6] > kSyncCounterMax) return PdoStatus::kBadValue;
  p->torque_mNm = GetI32(&f.data[0]);
  p->control = GetU16(&f.data[4]);
  p->sync_counter = f.data[6];
  p->reserved = f.data[7];
  return PdoStatus::kOk;
}

PdoStatus DecodeImuTpdo(const CanFrame& f, std::uint8_t node, ImuTpdo* p) noexcept {
  const PdoStatus s = CheckNodeFrame(f, cob::kTpdo1, node, kImuTpdoLen);
  if (s != PdoStatus::kOk) return s;
  if (f.data[26] < 1 || f.data[26] > kSyncCounterMax) return PdoStatus::kBadValue;
  for (std::size_t i = 0; i < 3; ++i) {
    p->gyro_urad_s[i] = GetI32(&f.data[4 * i]);
    p->accel_um_s2[i] = GetI32(&f.data[12 + 4 * i]);
  }
  p->status = GetU16(&f.data[24]);
  p->sync_counter = f.data[26];
  p->error_register = f.data[27];
  return PdoStatus::kOk;
}

}  // namespace hyq::hal
