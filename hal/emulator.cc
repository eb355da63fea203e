#include "hal/emulator.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "hal/calibration.h"
#include "hal/config_error.h"

namespace hyq::hal {
namespace {

constexpr std::size_t kTxCapacity = 128;
constexpr std::size_t kRxCapacity = 256;
constexpr std::size_t kDelayedCapacity = 128;

// a device that neither sends nor hears: silenced by a fault, or booting after a reset
template <class D>
bool Deaf(const D& d) noexcept {
  return d.faults.silent || d.boot_at_ns >= 0;
}

std::int32_t Micro(double x) noexcept {
  const double v = std::clamp(x * 1e6, -2147483648.0, 2147483647.0);
  return std::isfinite(v) ? static_cast<std::int32_t>(std::lround(v)) : 0;
}

}  // namespace

Emulator::Emulator(const HalConfig& config, std::span<CanChannel* const> channels,
                   std::uint64_t seed)
    : config_(config),
      heartbeat_period_ns_(static_cast<std::int64_t>(config.timing.heartbeat_period_s * 1e9)),
      setpoint_timeout_ns_(static_cast<std::int64_t>(config.timing.device_setpoint_timeout_s * 1e9)),
      master_heartbeat_timeout_ns_(
          static_cast<std::int64_t>(config.timing.master_heartbeat_timeout_s * 1e9)),
      rng_(seed == 0 ? 0x9E3779B97F4A7C15ull : seed) {
  ValidateHalConfig(config_);
  if (channels.size() != config_.buses.size())
    throw ConfigError("emulator: " + std::to_string(config_.buses.size()) +
                      " buses configured but " + std::to_string(channels.size()) +
                      " CAN channels given");
  joint_to_device_.fill(-1);
  buses_.resize(channels.size());
  for (std::size_t bi = 0; bi < channels.size(); ++bi) {
    BusState& b = buses_[bi];
    b.channel = channels[bi];
    if (b.channel == nullptr)
      throw ConfigError("emulator: no CAN channel for bus '" + config_.buses[bi].name + "'");
    b.node_to_device.fill(-1);
    b.rx.resize(kRxCapacity);
    b.tx.resize(kTxCapacity);
    b.delayed.resize(kDelayedCapacity);
    for (const DeviceConfig& dc : config_.buses[bi].devices) {
      Device d;
      d.kind = dc.kind;
      d.node = dc.node_id;
      d.joint = dc.joint;
      d.bus = static_cast<int>(bi);
      const int index = static_cast<int>(devices_.size());
      if (dc.node_id > kMaxNodeId)
        throw ConfigError("emulator: bad node id on bus '" + config_.buses[bi].name + "'");
      b.node_to_device[dc.node_id] = static_cast<std::int8_t>(b.devices.size());
      b.devices.push_back(index);
      if (dc.kind == DeviceKind::kImu) imu_device_ = index;
      else if (dc.joint >= 0 && dc.joint < kNumJoints)
        joint_to_device_[static_cast<std::size_t>(dc.joint)] = index;
      devices_.push_back(d);
    }
  }
  for (int j = 0; j < kNumJoints; ++j) SetJointState(j, 0.0, 0.0, 0.0);
}

double Emulator::Uniform() noexcept {
  // xorshift64*
  rng_ ^= rng_ >> 12;
  rng_ ^= rng_ << 25;
  rng_ ^= rng_ >> 27;
  return static_cast<double>((rng_ * 2685821657736338717ull) >> 11) * 0x1.0p-53;
}

void Emulator::Queue(BusState& b, const CanFrame& f) noexcept {
  if (b.tx_size == b.tx.size()) Flush(b);
  if (b.tx_size < b.tx.size()) b.tx[b.tx_size++] = f;
}

void Emulator::Flush(BusState& b) noexcept {
  if (b.tx_size == 0) return;
  std::size_t sent = 0;
  (void)b.channel->Send(std::span<const CanFrame>(b.tx.data(), b.tx_size), &sent);
  b.counters.tx_frames += sent;
  b.counters.tx_failed += b.tx_size - sent;
  b.tx_size = 0;
}

void Emulator::Nmt(Device& d, NmtCommand cmd) noexcept {
  switch (cmd) {
    case NmtCommand::kStart:
      if (d.nmt != NmtState::kOperational) d.op_entered_ns = now_ns_;
      d.nmt = NmtState::kOperational;
      break;
    case NmtCommand::kStop: d.nmt = NmtState::kStopped; d.enabled = false; break;
    case NmtCommand::kEnterPreOperational:
      d.nmt = NmtState::kPreOperational;
      d.enabled = false;
      break;
    case NmtCommand::kResetNode:
    case NmtCommand::kResetCommunication:
      d.nmt = NmtState::kPreOperational;
      d.enabled = false;
      d.watchdog = false;
      d.torque_mNm = 0;
      d.boot_pending = true;
      break;
  }
  if (!d.enabled) d.torque_mNm = 0;
}

// The board's own timer (CANopen: the communication cycle period 0x1006 watched by the device,
// error behaviour 0x1029 = pre-operational): it runs on the board's clock, not on SYNCs, so a
// master that dies mid-cycle cannot leave a set-point applied.
void Emulator::CheckSetpointTimer(BusState& b, Device& d, std::int64_t now_ns) noexcept {
  if (setpoint_timeout_ns_ <= 0 || d.nmt != NmtState::kOperational) return;
  const std::int64_t since_sync =
      b.last_sync_ns >= 0 ? now_ns - std::max(b.last_sync_ns, d.op_entered_ns) : 0;
  const bool applying = d.kind == DeviceKind::kActuator && d.enabled;
  const std::int64_t since_setpoint =
      applying && d.last_setpoint_ns >= 0 ? now_ns - d.last_setpoint_ns : 0;
  if (since_sync <= setpoint_timeout_ns_ && since_setpoint <= setpoint_timeout_ns_) return;
  d.enabled = false;
  d.torque_mNm = 0;  // valve closed
  d.watchdog = true;
  d.nmt = NmtState::kPreOperational;
  d.emcy_pending = true;
  d.pending_emcy = emcy::kRpdoTimeout;
  d.trip_ns = now_ns;
  d.trip_delay_ns = std::max(since_sync, since_setpoint);
  ++b.counters.setpoint_timeouts;
}

// CiA 301 heartbeat consumer of the master: active from the first heartbeat on; when it stops
// for master_heartbeat_timeout_s, a board in OPERATIONAL reacts as to a lost set-point, with
// EMCY 0x8130 (heartbeat error).
void Emulator::CheckMasterHeartbeat(BusState& b, Device& d, std::int64_t now_ns) noexcept {
  if (b.last_master_heartbeat_ns < 0 || d.nmt != NmtState::kOperational) return;
  const std::int64_t since = now_ns - std::max(b.last_master_heartbeat_ns, d.op_entered_ns);
  if (since <= master_heartbeat_timeout_ns_) return;
  d.enabled = false;
  d.torque_mNm = 0;
  d.watchdog = true;
  d.nmt = NmtState::kPreOperational;
  d.emcy_pending = true;
  d.pending_emcy = emcy::kHeartbeatLost;
  d.trip_ns = now_ns;
  d.trip_delay_ns = since;
  ++b.counters.heartbeat_trips;
}

void Emulator::Answer(BusState& b, Device& d, std::uint8_t counter) noexcept {
  CanFrame f;
  if (d.kind == DeviceKind::kActuator) {
    ActuatorTpdo p;
    p.position_counts = d.position_counts;
    p.velocity_counts_s = d.velocity_counts_s;
    p.effort_counts = d.effort_counts;
    p.status = status_bit::kReady;
    if (d.enabled) p.status |= status_bit::kEnabled;
    if (d.fault) p.status |= status_bit::kFault;
    if (d.watchdog) p.status |= status_bit::kRpdoWatchdog;
    if (d.faults.sensor_fault) {
      p.effort_counts = kInvalidSensorCounts;
      p.status |= status_bit::kSensorFault;
    }
    p.sync_counter = counter;
    p.error_register = d.fault ? 0x01 : 0x00;
    f = EncodeActuatorTpdo(d.node, p);
  } else {
    ImuTpdo p;
    p.gyro_urad_s = d.gyro_urad_s;
    p.accel_um_s2 = d.accel_um_s2;
    p.status = status_bit::kReady;
    if (d.faults.sensor_fault) {
      p.gyro_urad_s.fill(kInvalidSensorCounts);
      p.accel_um_s2.fill(kInvalidSensorCounts);
      p.status = status_bit::kSensorFault;
    }
    p.sync_counter = counter;
    f = EncodeImuTpdo(d.node, p);
  }
  DeviceFaults& x = d.faults;
  if (x.drop_next > 0) {
    --x.drop_next;
    ++b.counters.dropped;
    return;
  }
  if (x.drop_probability > 0.0 && Uniform() < x.drop_probability) {
    ++b.counters.dropped;
    return;
  }
  if (x.corrupt_next > 0) {
    --x.corrupt_next;
    ++b.counters.corrupted;
    f.len = 12;  // a valid FD length, not the layout's
    for (std::size_t i = 0; i < f.len; ++i) f.data[i] = static_cast<std::uint8_t>(Uniform() * 256.0);
  }
  int copies = 1;
  if (x.duplicate_next > 0) {
    --x.duplicate_next;
    ++b.counters.duplicated;
    copies = 2;
  }
  for (int c = 0; c < copies; ++c) {
    if (x.delay_syncs > 0 && b.delayed_size < b.delayed.size()) {
      b.delayed[b.delayed_size++] = {f, x.delay_syncs};
      ++b.counters.delayed;
    } else {
      Queue(b, f);
    }
  }
}

void Emulator::OnSync(BusState& b, std::uint8_t counter, bool answer) noexcept {
  ++b.counters.syncs;
  b.last_sync_ns = now_ns_;
  // frames held back by an earlier SYNC go out first (they now answer an old counter)
  std::size_t keep = 0;
  for (std::size_t i = 0; i < b.delayed_size; ++i) {
    Delayed& x = b.delayed[i];
    if (--x.syncs_left == 0) Queue(b, x.frame);
    else b.delayed[keep++] = x;
  }
  b.delayed_size = keep;
  for (int index : b.devices) {
    Device& d = devices_[static_cast<std::size_t>(index)];
    if (Deaf(d) || d.nmt != NmtState::kOperational) continue;
    // RPDO watchdog: outputs off after kRpdoWatchdogSyncs SYNCs without a set-point
    if (d.kind == DeviceKind::kActuator && d.enabled) {
      d.rpdo_missed = d.rpdo_since_sync ? 0 : d.rpdo_missed + 1;
      if (d.rpdo_missed >= kRpdoWatchdogSyncs) {
        d.enabled = false;
        d.watchdog = true;
        d.torque_mNm = 0;
        d.emcy_pending = true;
        d.pending_emcy = emcy::kRpdoTimeout;
      }
    }
    d.rpdo_since_sync = false;
    if (answer) Answer(b, d, counter);
  }
  if (!answer) ++b.counters.superseded_syncs;
}

void Emulator::HandleFrame(BusState& b, const CanFrame& f, bool answer_sync) noexcept {
  if (f.is_error() || f.is_extended()) return;
  const FrameAddress a = Classify(f.id);
  switch (a.kind) {
    case FrameKind::kNmt: {
      NmtCommand cmd{};
      std::uint8_t node = 0;
      if (DecodeNmt(f, &cmd, &node) != PdoStatus::kOk) {
        ++b.counters.malformed_rx;
        return;
      }
      for (int index : b.devices) {
        Device& d = devices_[static_cast<std::size_t>(index)];
        if ((node == 0 || node == d.node) && !Deaf(d)) Nmt(d, cmd);
      }
      return;
    }
    case FrameKind::kSync: {
      std::uint8_t counter = 0;
      if (DecodeSync(f, &counter) != PdoStatus::kOk) {
        ++b.counters.malformed_rx;
        return;
      }
      OnSync(b, counter, answer_sync);
      return;
    }
    case FrameKind::kRpdo1: {
      const int local = b.node_to_device[a.node];
      if (local < 0) return;
      Device& d = devices_[static_cast<std::size_t>(b.devices[static_cast<std::size_t>(local)])];
      if (Deaf(d) || d.kind != DeviceKind::kActuator) return;
      ActuatorRpdo p;
      if (DecodeActuatorRpdo(f, d.node, &p) != PdoStatus::kOk) {
        ++b.counters.malformed_rx;
        d.emcy_pending = true;
        d.pending_emcy = emcy::kPdoLength;
        return;
      }
      ++b.counters.rpdos;
      ++d.rpdos;
      d.rpdo_since_sync = true;
      d.last_setpoint_ns = now_ns_;
      if ((p.control & control_bit::kFaultReset) != 0) {
        d.fault = false;
        d.watchdog = false;
      }
      const bool enable = (p.control & control_bit::kEnable) != 0 && !d.fault &&
                          !d.faults.refuse_enable && d.nmt == NmtState::kOperational;
      d.enabled = enable;
      if (enable) d.watchdog = false;
      d.torque_mNm = enable ? p.torque_mNm : 0;
      return;
    }
    case FrameKind::kHeartbeat:
      if (a.node == kMasterNodeId) {
        ++b.counters.master_heartbeats;
        b.last_master_heartbeat_ns = now_ns_;
      }
      return;  // other boards' heartbeats: not for us
    default: return;  // our own kind of traffic (TPDOs): not for us
  }
}

void Emulator::Poll(std::int64_t now_ns) noexcept {
  now_ns_ = now_ns;
  for (BusState& b : buses_) {
    for (;;) {
      // what has arrived (up to b.rx's capacity), then handled in order
      std::size_t n = 0;
      (void)b.channel->Receive(b.rx, &n);
      b.counters.rx_frames += n;
      // the newest SYNC among them (newest_sync_only_: the only one answered)
      std::size_t newest_sync = n;
      if (newest_sync_only_)
        for (std::size_t i = n; i-- > 0;)
          if (!b.rx[i].is_error() && !b.rx[i].is_extended() &&
              Classify(b.rx[i].id).kind == FrameKind::kSync) {
            newest_sync = i;
            break;
          }
      if (!b.off)
        for (std::size_t i = 0; i < n; ++i)
          HandleFrame(b, b.rx[i], !newest_sync_only_ || i == newest_sync);
      if (n < b.rx.size()) break;
    }
    if (b.off) {
      b.tx_size = 0;
      continue;
    }
    for (int index : b.devices) {
      Device& d = devices_[static_cast<std::size_t>(index)];
      if (d.boot_at_ns >= 0 && now_ns >= d.boot_at_ns) d.boot_at_ns = -1;  // booted: boot-up below
      // a silent board hears no SYNC and no set-point either (a cut cable): its own timer
      // still runs and takes its outputs off (the EMCY goes out once it can talk again)
      CheckSetpointTimer(b, d, now_ns);
      if (Deaf(d)) continue;
      CheckMasterHeartbeat(b, d, now_ns);
      if (b.recovered) {
        d.emcy_pending = true;
        d.pending_emcy = emcy::kBusOffRecovered;
      }
      if (d.boot_pending) {
        d.boot_pending = false;
        Queue(b, EncodeHeartbeat(d.node, NmtState::kBootUp));
        d.next_heartbeat_ns = now_ns + heartbeat_period_ns_;
      } else if (now_ns >= d.next_heartbeat_ns && !d.faults.no_heartbeat) {
        Queue(b, EncodeHeartbeat(d.node, d.nmt));
        d.next_heartbeat_ns = now_ns + heartbeat_period_ns_;
      }
      if (d.emcy_pending) {
        d.emcy_pending = false;
        EmcyMessage m;
        m.code = d.pending_emcy;
        m.error_register = m.code == emcy::kNoError ? 0x00 : 0x01;
        Queue(b, EncodeEmcy(d.node, m));
      }
    }
    b.recovered = false;
    Flush(b);
  }
}

const Emulator::Device* Emulator::JointDevice(int joint) const noexcept {
  if (joint < 0 || joint >= kNumJoints) return nullptr;
  const int index = joint_to_device_[static_cast<std::size_t>(joint)];
  return index < 0 ? nullptr : &devices_[static_cast<std::size_t>(index)];
}

Emulator::Device* Emulator::JointDevice(int joint) noexcept {
  return const_cast<Device*>(std::as_const(*this).JointDevice(joint));
}

template <class EffortCounts>
void Emulator::SetJointCounts(int joint, double position_rad, double velocity_rad_s,
                              const EffortCounts& effort_counts) noexcept {
  Device* d = JointDevice(joint);
  if (d == nullptr) return;
  const JointCalibration& c = config_.joints[static_cast<std::size_t>(joint)];
  d->position_counts = RadToEncoderCounts(c, position_rad);
  d->velocity_counts_s = RadPerSecToEncoderRate(c, velocity_rad_s);
  d->effort_counts = effort_counts(c);
}

void Emulator::SetJointState(int joint, double position_rad, double velocity_rad_s,
                             double torque_Nm) noexcept {
  SetJointCounts(joint, position_rad, velocity_rad_s, [&](const JointCalibration& c) {
    return TorqueToEffortCounts(c, torque_Nm, position_rad);
  });
}

void Emulator::SetJointSensor(int joint, double position_rad, double velocity_rad_s,
                              double sensor_value) noexcept {
  SetJointCounts(joint, position_rad, velocity_rad_s, [&](const JointCalibration& c) {
    return SensorValueToEffortCounts(c, sensor_value);
  });
}

void Emulator::SetImu(const std::array<double, 3>& gyro_rad_s,
                      const std::array<double, 3>& accel_m_s2) noexcept {
  if (imu_device_ < 0) return;
  Device& d = devices_[static_cast<std::size_t>(imu_device_)];
  for (std::size_t i = 0; i < 3; ++i) {
    d.gyro_urad_s[i] = Micro(gyro_rad_s[i]);
    d.accel_um_s2[i] = Micro(accel_m_s2[i]);
  }
}

double Emulator::torque_setpoint_Nm(int joint) const noexcept {
  const Device* d = JointDevice(joint);
  return d != nullptr && d->enabled ? 1e-3 * d->torque_mNm : 0.0;
}

std::int64_t Emulator::setpoint_trip_ns(int joint) const noexcept {
  const Device* d = JointDevice(joint);
  return d != nullptr ? d->trip_ns : -1;
}

std::int64_t Emulator::setpoint_trip_delay_ns(int joint) const noexcept {
  const Device* d = JointDevice(joint);
  return d != nullptr ? d->trip_delay_ns : 0;
}

bool Emulator::outputs_enabled(int joint) const noexcept {
  const Device* d = JointDevice(joint);
  return d != nullptr && d->enabled;
}

NmtState Emulator::nmt_state(int joint) const noexcept {
  const Device* d = JointDevice(joint);
  return d != nullptr ? d->nmt : NmtState::kStopped;
}

std::uint64_t Emulator::rpdos_received(int joint) const noexcept {
  const Device* d = JointDevice(joint);
  return d != nullptr ? d->rpdos : 0;
}

DeviceFaults& Emulator::joint_faults(int joint) noexcept {
  Device* d = JointDevice(joint);
  return d != nullptr ? d->faults : dummy_.faults;
}

DeviceFaults& Emulator::imu_faults() noexcept {
  return imu_device_ >= 0 ? devices_[static_cast<std::size_t>(imu_device_)].faults : dummy_.faults;
}

void Emulator::SendJointEmcy(int joint, std::uint16_t code) noexcept {
  Device* d = JointDevice(joint);
  if (d == nullptr) return;
  d->emcy_pending = true;
  d->pending_emcy = code;
  if (code != emcy::kNoError) {
    d->fault = true;
    d->enabled = false;
    d->torque_mNm = 0;
  }
}

void Emulator::SetBusOff(int bus, bool off) noexcept {
  if (bus < 0 || bus >= static_cast<int>(buses_.size())) return;
  BusState& b = buses_[static_cast<std::size_t>(bus)];
  if (off && !b.off) ++b.counters.bus_off_events;
  if (!off && b.off) b.recovered = true;
  b.off = off;
  if (off) {
    b.delayed_size = 0;
    for (int index : b.devices) {  // outputs off while the board cannot hear the master
      Device& d = devices_[static_cast<std::size_t>(index)];
      d.enabled = false;
      d.torque_mNm = 0;
    }
  }
}

bool Emulator::bus_off(int bus) const noexcept {
  return bus >= 0 && bus < static_cast<int>(buses_.size()) &&
         buses_[static_cast<std::size_t>(bus)].off;
}

void Emulator::ResetBus(int bus) noexcept {
  if (bus < 0 || bus >= static_cast<int>(buses_.size())) return;
  for (int index : buses_[static_cast<std::size_t>(bus)].devices)
    Nmt(devices_[static_cast<std::size_t>(index)], NmtCommand::kResetNode);
}

// A reset: the board as after power-on (Device's defaults: PRE-OPERATIONAL, boot-up owed, no
// set-point, not enabled, nothing latched), silent until its boot time has passed. What it keeps
// is not its state: its identity, the plant's values it reports, the injected faults, and the
// run's records (RPDOs received, its last trip). The frames it held back are gone with its CAN
// controller's state.
void Emulator::Reset(Device& d, std::int64_t boot_ns) noexcept {
  Device fresh;
  fresh.kind = d.kind;
  fresh.node = d.node;
  fresh.joint = d.joint;
  fresh.bus = d.bus;
  fresh.rpdos = d.rpdos;
  fresh.trip_ns = d.trip_ns;
  fresh.trip_delay_ns = d.trip_delay_ns;
  fresh.position_counts = d.position_counts;
  fresh.velocity_counts_s = d.velocity_counts_s;
  fresh.effort_counts = d.effort_counts;
  fresh.gyro_urad_s = d.gyro_urad_s;
  fresh.accel_um_s2 = d.accel_um_s2;
  fresh.faults = d.faults;
  fresh.boot_at_ns = now_ns_ + std::max<std::int64_t>(boot_ns, 0);
  d = fresh;
  BusState& b = buses_[static_cast<std::size_t>(d.bus)];
  std::size_t keep = 0;
  for (std::size_t i = 0; i < b.delayed_size; ++i)
    if ((b.delayed[i].frame.id & 0x7Fu) != d.node) b.delayed[keep++] = b.delayed[i];
  b.delayed_size = keep;
  ++b.counters.resets;
}

void Emulator::ResetJointBoard(int joint, std::int64_t boot_ns) noexcept {
  if (Device* d = JointDevice(joint)) Reset(*d, boot_ns);
}

void Emulator::ResetImu(std::int64_t boot_ns) noexcept {
  if (imu_device_ >= 0) Reset(devices_[static_cast<std::size_t>(imu_device_)], boot_ns);
}

bool Emulator::booting(int joint) const noexcept {
  const Device* d = JointDevice(joint);
  return d != nullptr && d->boot_at_ns >= 0;
}

const EmulatorCounters& Emulator::counters(int bus) const noexcept {
  static const EmulatorCounters kNone{};
  if (bus < 0 || bus >= static_cast<int>(buses_.size())) return kNone;
  return buses_[static_cast<std::size_t>(bus)].counters;
}

}  // namespace hyq::hal
