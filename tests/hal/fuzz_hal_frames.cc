// libFuzzer target: arbitrary CAN frames into every decoder, into the HAL's receive path and into
// the device emulator. Malformed frames must be counted and never crash, hang or be used; a frame
// a decoder accepts must re-encode to the same bytes.
//
// Input format (so that most inputs are frames of this protocol): repeated records
//   [kind] [node/flags] [len index] [payload ...]
// kind selects a function code (or a raw 11/29-bit id), node/flags the node id and rare
// remote/error/extended flags, len index one of the FD lengths; the payload is taken from the
// input. A kind byte >= 0xF0 runs one HAL cycle and lets the emulator answer.
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "hal/hal.h"
#include "hal/protocol.h"
#include "tests/hal/hal_fixture.h"

namespace {

using namespace hyq::hal;

void Require(bool ok) {
  if (!ok) __builtin_trap();
}

void CheckDecoders(const CanFrame& f) {
  const FrameAddress a = Classify(f.id);
  const std::uint8_t node = a.node;
  ActuatorTpdo tp;
  if (DecodeActuatorTpdo(f, node, &tp) == PdoStatus::kOk)
    Require(std::memcmp(EncodeActuatorTpdo(node, tp).data.data(), f.data.data(), kActuatorTpdoLen) == 0);
  ActuatorRpdo rp;
  if (DecodeActuatorRpdo(f, node, &rp) == PdoStatus::kOk)
    Require(std::memcmp(EncodeActuatorRpdo(node, rp).data.data(), f.data.data(), kActuatorRpdoLen) == 0);
  ImuTpdo ip;
  if (DecodeImuTpdo(f, node, &ip) == PdoStatus::kOk)
    Require(std::memcmp(EncodeImuTpdo(node, ip).data.data(), f.data.data(), 28) == 0);
  EmcyMessage em;
  if (DecodeEmcy(f, node, &em) == PdoStatus::kOk)
    Require(std::memcmp(EncodeEmcy(node, em).data.data(), f.data.data(), kEmcyLen) == 0);
  NmtState st{};
  if (DecodeHeartbeat(f, node, &st) == PdoStatus::kOk) Require((f.data[0] & 0x7F) == static_cast<std::uint8_t>(st));
  NmtCommand cmd{};
  std::uint8_t target = 0;
  if (DecodeNmt(f, &cmd, &target) == PdoStatus::kOk)
    Require(std::memcmp(EncodeNmt(cmd, target).data.data(), f.data.data(), kNmtLen) == 0);
  std::uint8_t counter = 0;
  if (DecodeSync(f, &counter) == PdoStatus::kOk) Require(counter >= 1 && counter <= kSyncCounterMax);
}

// the HAL rig with a third endpoint per bus, where the fuzzer's frames come from
struct Rig : hyq::hal::testing::HalRig {
  Rig() : HalRig(DefaultHalConfig(), 7, 3, 64) { hal->RequestState(DeviceState::kOp, now_ns); }
  void Cycle() {
    (void)hal->Read(now_ns);
    for (auto& c : hal->image().commands) c.torque_Nm = 1.0;
    (void)hal->Write(now_ns);
    emu->Poll(now_ns);
    now_ns += 1'000'000;
  }
};

constexpr std::uint8_t kLengths[] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64};
constexpr std::uint32_t kCodes[] = {cob::kNmt, cob::kSync, cob::kEmcy, cob::kTpdo1, cob::kRpdo1,
                                    cob::kHeartbeat, cob::kTpdo2, cob::kSdoTx};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Rig rig;
  rig.Cycle();
  std::size_t i = 0;
  while (i + 3 <= size) {
    const std::uint8_t kind = data[i], nf = data[i + 1], li = data[i + 2];
    i += 3;
    if (kind >= 0xF0) {
      rig.Cycle();
      continue;
    }
    CanFrame f;
    const std::uint8_t node = static_cast<std::uint8_t>(nf % 20);
    if (kind < 0xC0) {
      const std::uint32_t code = kCodes[kind % 8];
      f.id = (code == cob::kNmt || code == cob::kSync) && (kind & 0x08) == 0 ? code : code + node;
    } else {
      f.id = (static_cast<std::uint32_t>(kind) << 8 | nf) & 0x7FF;
    }
    if ((nf & 0xE0) == 0xE0) f.flags |= CanFrame::kRemote;
    if ((nf & 0xE0) == 0xC0) f.flags |= CanFrame::kError;
    if ((nf & 0xE0) == 0xA0) f.flags |= CanFrame::kExtendedId;
    f.len = kLengths[li % 16];
    if (f.len > 8 || (li & 0x10) != 0) f.flags |= CanFrame::kFd | CanFrame::kBitrateSwitch;
    const std::size_t take = size - i < f.len ? size - i : f.len;
    std::memcpy(f.data.data(), data + i, take);
    i += take;
    CheckDecoders(f);
    std::size_t sent = 0;
    // both the HAL and the emulator hear it
    (void)rig.wires[(li >> 5) % rig.wires.size()]->endpoint(2).Send({&f, 1}, &sent);
  }
  rig.Cycle();
  // whatever arrived, the process image only holds data from frames that decoded
  for (const JointInput& j : rig.hal->image().joints)
    Require(j.status != InputStatus::kValid || j.age_cycles == 0);
  return 0;
}
