#include "hal/hal.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "hal/calibration.h"

namespace hyq::hal {
namespace {

constexpr double kMicro = 1e-6;

HalStatus Worse(HalStatus a, HalStatus b) noexcept {
  return static_cast<std::uint8_t>(a) >= static_cast<std::uint8_t>(b) ? a : b;
}

// Decodes device d's TPDO with `decode` and gives its SYNC counter and status word; the first
// one this cycle that answers the SYNC in flight (`sync_counter`) is kept in *in, for Publish.
template <class Tpdo, class Decode>
PdoStatus TakeTpdo(Decode decode, const CanFrame& f, const DeviceRuntime& d,
                   std::uint8_t sync_counter, Tpdo* in, std::uint8_t* counter,
                   std::uint16_t* status) noexcept {
  Tpdo p;
  const PdoStatus s = decode(f, d.node, &p);
  if (s != PdoStatus::kOk) return s;
  *counter = p.sync_counter;
  *status = p.status;
  if (p.sync_counter == sync_counter && d.rx_count == 0) *in = p;
  return s;
}

}  // namespace

const char* ToString(HalStatus s) noexcept {
  switch (s) {
    case HalStatus::kOk: return "ok";
    case HalStatus::kWorkingCounter: return "working_counter";
    case HalStatus::kBadCommand: return "bad_command";
    case HalStatus::kTxFailed: return "tx_failed";
    case HalStatus::kBusOff: return "bus_off";
  }
  return "unknown";
}

// ---------------------------------------------------------------------------------------------
// Bus

Bus::Bus(BusConfig config, const TimingConfig& timing,
         const std::array<JointCalibration, kNumJoints>* calibration, CanChannel* channel)
    : config_(std::move(config)),
      timing_(MakeStateMachineTiming(timing)),
      period_s_(timing.cycle_period_s),
      calibration_(calibration),
      channel_(channel),
      heartbeat_period_ns_(static_cast<std::int64_t>(timing.master_heartbeat_period_s * 1e9)) {
  if (channel_ == nullptr) throw ConfigError("bus '" + config_.name + "': no CAN channel given");
  if (config_.devices.size() > static_cast<std::size_t>(kMaxDevicesPerBus))
    throw ConfigError("bus '" + config_.name + "': at most " + std::to_string(kMaxDevicesPerBus) +
                      " devices, found " + std::to_string(config_.devices.size()));
  node_to_device_.fill(-1);
  devices_.resize(config_.devices.size());
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    const DeviceConfig& c = config_.devices[i];
    DeviceRuntime& d = devices_[i];
    d.kind = c.kind;
    d.node = c.node_id;
    d.joint = c.joint;
    d.config_index = static_cast<int>(i);
    node_to_device_.at(c.node_id) = static_cast<std::int8_t>(i);
  }
  // NMT commands (2 per device at most per cycle), RPDOs, SYNC, the master's heartbeat
  tx_storage_.resize(3 * devices_.size() + 5);
  tx_.frames = tx_storage_.data();
  tx_.capacity = tx_storage_.size();
}

StateMachineContext Bus::Context(std::int64_t now_ns) noexcept {
  StateMachineContext ctx;
  ctx.now_ns = now_ns;
  ctx.timing = &timing_;
  ctx.tx = &tx_;
  return ctx;
}

void Bus::HandleFrame(const CanFrame& f, StateMachineContext& ctx) noexcept {
  if (f.is_error()) {
    ++counters_.error_frames;
    return;
  }
  const FrameAddress a = f.is_extended() ? FrameAddress{} : Classify(f.id);
  switch (a.kind) {
    case FrameKind::kNmt:
    case FrameKind::kSync:
    case FrameKind::kRpdo1:
    case FrameKind::kRpdo2:
    case FrameKind::kRpdo3:
    case FrameKind::kRpdo4:
      // only the master sends these, and the master is us: another sender is on the bus
      ++counters_.foreign_master;
      counters_.last_foreign_id = f.id;
      return;
    case FrameKind::kHeartbeat:
      if (a.node != kMasterNodeId) break;
      ++counters_.foreign_master;  // our heartbeat, sent by someone else
      counters_.last_foreign_id = f.id;
      return;
    default:
      break;
  }
  const int index = a.node <= kMaxNodeId ? node_to_device_[a.node] : -1;
  if (a.kind == FrameKind::kUnknown || index < 0) {
    // a node we do not own: not ours, not a fault of ours
    ++counters_.unknown;
    return;
  }
  DeviceRuntime& d = devices_[static_cast<std::size_t>(index)];
  DeviceEvent e;
  PdoStatus s = PdoStatus::kOk;
  switch (a.kind) {
    case FrameKind::kHeartbeat: {
      NmtState nmt{};
      s = DecodeHeartbeat(f, d.node, &nmt);
      if (s != PdoStatus::kOk) break;
      e.kind = nmt == NmtState::kBootUp ? DeviceEventKind::kBootUp : DeviceEventKind::kHeartbeat;
      e.nmt = nmt;
      DispatchEvent(d, e, ctx);
      return;
    }
    case FrameKind::kEmcy: {
      EmcyMessage m;
      s = DecodeEmcy(f, d.node, &m);
      if (s != PdoStatus::kOk) break;
      ++counters_.emcy;
      counters_.last_emcy_code = m.code;
      counters_.last_emcy_node = d.node;
      e.kind = DeviceEventKind::kEmcy;
      e.emcy_code = m.code;
      DispatchEvent(d, e, ctx);
      return;
    }
    case FrameKind::kTpdo1: {
      std::uint8_t counter = 0;
      std::uint16_t status = 0;
      s = d.kind == DeviceKind::kActuator
              ? TakeTpdo(DecodeActuatorTpdo, f, d, sync_counter_, &d.actuator_in, &counter, &status)
              : TakeTpdo(DecodeImuTpdo, f, d, sync_counter_, &d.imu_in, &counter, &status);
      if (s != PdoStatus::kOk) break;
      if (counter != sync_counter_ || sync_counter_ == 0) {
        ++d.counters.late;  // answers an older SYNC: stale, never used
        ++counters_.late;
        counters_.last_fault_cycle = cycle_;
        counters_.last_fault_node = d.node;
        return;
      }
      if (++d.rx_count == 1) {
        e.kind = DeviceEventKind::kInputs;
        e.status = status;
        DispatchEvent(d, e, ctx);
      }
      return;
    }
    default:
      ++counters_.unknown;  // a kind this protocol does not use from devices (SDO, TPDO2..4)
      return;
  }
  (void)s;
  ++d.counters.malformed;
  ++counters_.malformed;
  counters_.last_fault_cycle = cycle_;
  counters_.last_fault_node = d.node;
}

void Bus::Publish(const DeviceRuntime& d, ProcessImage* image) noexcept {
  InputStatus st;
  const bool operational = d.state >= DeviceState::kSafeOp;
  if (!operational) st = InputStatus::kNotOperational;
  else if (d.rx_count == 1)
    st = (d.last_status & status_bit::kFault) != 0 ? InputStatus::kDeviceFault : InputStatus::kValid;
  else if (d.rx_count == 0) st = d.held ? InputStatus::kHeld : InputStatus::kMissing;
  else st = InputStatus::kDuplicate;
  const bool fresh = operational && d.rx_count == 1;

  if (d.kind == DeviceKind::kImu) {
    ImuInput& m = image->imu;
    m.status = st;
    m.device_state = d.state;
    if (!fresh) {
      ++m.age_cycles;
      return;
    }
    m.age_cycles = 0;
    m.status_word = d.imu_in.status;
    for (std::size_t i = 0; i < 3; ++i) {
      m.gyro_rad_s[i] = kMicro * d.imu_in.gyro_urad_s[i];
      m.accel_m_s2[i] = kMicro * d.imu_in.accel_um_s2[i];
    }
    return;
  }
  if (d.joint < 0 || d.joint >= kNumJoints) return;
  JointInput& j = image->joints[static_cast<std::size_t>(d.joint)];
  j.status = st;
  j.device_state = d.state;
  if (!fresh) {
    ++j.age_cycles;
    // held (docs/hal.md, "Late or missing answers"): the angle extrapolated by the last
    // velocity, which a hydraulic joint keeps within the hold's few milliseconds
    if (st == InputStatus::kHeld && std::isfinite(j.velocity_rad_s))
      j.position_rad += j.velocity_rad_s * period_s_;
    return;
  }
  const JointCalibration& c = (*calibration_)[static_cast<std::size_t>(d.joint)];
  const ActuatorTpdo& p = d.actuator_in;
  j.age_cycles = 0;
  j.position_counts = p.position_counts;
  j.velocity_counts_s = p.velocity_counts_s;
  j.effort_counts = p.effort_counts;
  j.status_word = p.status;
  j.position_rad = EncoderCountsToRad(c, p.position_counts);
  j.velocity_rad_s = EncoderRateToRadPerSec(c, p.velocity_counts_s);
  j.sensor_value = EffortCountsToSensorValue(c, p.effort_counts);
  j.torque_Nm = EffortCountsToTorque(c, p.effort_counts, j.position_rad);
}

HalStatus Bus::Read(std::int64_t now_ns, std::uint64_t cycle, ProcessImage* image) noexcept {
  cycle_ = cycle;
  ++counters_.cycles;
  StateMachineContext ctx = Context(now_ns);
  HalStatus status = HalStatus::kOk;
  for (DeviceRuntime& d : devices_) {
    d.rx_count = 0;
    d.held = false;
  }

  // drain RX (bounded per cycle), decode, dispatch
  std::size_t total = 0;
  bool more = true;
  saw_bus_off_ = false;
  while (more && total < kMaxRxPerCycle) {
    std::size_t n = 0;
    const CanStatus cs = channel_->Receive(rx_, &n);
    if (cs == CanStatus::kBusOff) saw_bus_off_ = true;
    else if (cs != CanStatus::kOk) ++counters_.rx_errors;
    for (std::size_t i = 0; i < n; ++i) HandleFrame(rx_[i], ctx);
    total += n;
    counters_.rx_frames += n;
    more = n == rx_.size();
  }
  if (more) ++counters_.rx_backlog;
  // what the driver dropped before a frame existed (a datagram that is no CAN frame): not a
  // device's fault, but visible (HYQ_HEALTH)
  counters_.driver_dropped = channel_->counters().bad_frames;
  if (saw_bus_off_ || channel_->counters().bus_state == BusState::kBusOff) {
    ++counters_.bus_off;
    status = HalStatus::kBusOff;
  }

  // working counter: every device that was in SAFE-OP/OP when the SYNC went out answers once
  wkc_ = {};
  const bool sync_answered = sync_since_read_;
  sync_since_read_ = false;
  for (DeviceRuntime& d : devices_) {
    if (!sync_answered) d.expect_inputs = false;
    if (d.expect_inputs) {
      ++wkc_.expected;
      wkc_.received += d.rx_count;
      if (d.rx_count == 0) {
        ++d.counters.missing;
        ++counters_.missing;
      } else if (d.rx_count > 1) {
        d.counters.duplicate += d.rx_count - 1u;
        counters_.duplicate += d.rx_count - 1u;
      }
      if (d.rx_count != 1) {
        counters_.last_fault_cycle = cycle_;
        counters_.last_fault_node = d.node;
      }
    }
    if (d.rx_count == 1) {
      ++d.counters.valid;
      ++d.consecutive_valid;
      d.consecutive_missed = 0;
    } else if (d.expect_inputs) {
      d.consecutive_valid = 0;
      ++d.consecutive_missed;
      // the one late-or-missing policy (docs/hal.md): hold the last valid input for up to
      // max_held_cycles in a row; the state machines below drop the device out of OP after that
      d.held = d.consecutive_missed <= timing_.max_held_cycles;
      if (d.held) {
        ++d.counters.held;
        ++counters_.held;
        d.counters.max_held_in_row = std::max(d.counters.max_held_in_row, d.consecutive_missed);
      }
    }
  }
  if (!wkc_.ok()) {
    ++counters_.wkc_faults;
    status = Worse(status, HalStatus::kWorkingCounter);
  }

  // state machines, then the process image
  for (DeviceRuntime& d : devices_) DispatchCycle(d, ctx);
  for (const DeviceRuntime& d : devices_) Publish(d, image);
  return status;
}

HalStatus Bus::Write(std::int64_t now_ns, const ProcessImage& image) noexcept {
  HalStatus status = HalStatus::kOk;
  // the master's heartbeat, which the boards consume (docs/can_protocol.md §2)
  if (next_heartbeat_ns_ < 0 || now_ns >= next_heartbeat_ns_) {
    tx_.Push(EncodeHeartbeat(kMasterNodeId, NmtState::kOperational));
    next_heartbeat_ns_ = now_ns + heartbeat_period_ns_;
  }
  const std::uint8_t next_sync = NextSyncCounter(sync_counter_);
  // outputs: set-points in OP, 0 N·m and disabled (or an enable request) in SAFE-OP
  for (DeviceRuntime& d : devices_) {
    if (d.kind != DeviceKind::kActuator || d.state < DeviceState::kSafeOp) continue;
    ActuatorRpdo out;
    out.sync_counter = next_sync;
    if (d.fault_reset_pending) {
      out.control |= control_bit::kFaultReset;
      d.fault_reset_pending = false;
    }
    if (d.state == DeviceState::kOp && d.joint >= 0) {
      const auto ji = static_cast<std::size_t>(d.joint);
      double tau = image.commands[ji].torque_Nm;
      if (!std::isfinite(tau)) {
        ++counters_.bad_commands;
        status = Worse(status, HalStatus::kBadCommand);
        tau = 0.0;
      }
      const double limit = (*calibration_)[ji].torque_limit_Nm;
      if (std::abs(tau) > limit) {
        ++counters_.saturated;
        tau = std::clamp(tau, -limit, limit);
      }
      out.torque_mNm = static_cast<std::int32_t>(std::lround(tau * 1000.0));
      out.control |= control_bit::kEnable;
    } else if (d.enable_requested) {
      out.control |= control_bit::kEnable;  // still 0 N·m until the device confirms
    }
    tx_.Push(EncodeActuatorRpdo(d.node, out));
  }
  tx_.Push(EncodeSync(next_sync));
  sync_counter_ = next_sync;
  sync_since_read_ = true;
  for (DeviceRuntime& d : devices_) d.expect_inputs = d.state >= DeviceState::kSafeOp;

  if (tx_.overflow != 0) {
    counters_.tx_queue_overflow += tx_.overflow;
    tx_.overflow = 0;
  }
  std::size_t sent = 0;
  const CanStatus cs = channel_->Send(std::span<const CanFrame>(tx_.frames, tx_.size), &sent);
  counters_.tx_frames += sent;
  if (sent < tx_.size) counters_.tx_failed += tx_.size - sent;
  tx_.size = 0;
  if (cs == CanStatus::kBusOff) {
    ++counters_.bus_off;
    status = Worse(status, HalStatus::kBusOff);
  } else if (cs != CanStatus::kOk) {
    status = Worse(status, HalStatus::kTxFailed);
  }
  return status;
}

void Bus::RequestState(DeviceState target, std::int64_t now_ns) noexcept {
  for (DeviceRuntime& d : devices_) {
    if (target > d.state && d.target <= d.state) d.state_entered_ns = now_ns;  // timer starts now
    hal::RequestState(d, target);
  }
}

void Bus::ReleaseJoint(int joint) noexcept {
  for (DeviceRuntime& d : devices_)
    if (d.kind == DeviceKind::kActuator && d.joint == joint && d.target > DeviceState::kSafeOp)
      hal::RequestState(d, DeviceState::kSafeOp);
}

void Bus::AcknowledgeFaults(std::int64_t now_ns) noexcept {
  for (DeviceRuntime& d : devices_) {
    if (d.error_latched) d.state_entered_ns = now_ns;
    AcknowledgeFault(d);
  }
}

bool Bus::AllIn(DeviceState s) const noexcept {
  return std::all_of(devices_.begin(), devices_.end(),
                     [s](const DeviceRuntime& d) { return d.state == s; });
}

// ---------------------------------------------------------------------------------------------
// Hal

Hal::Hal(HalConfig config, std::span<CanChannel* const> channels) : config_(std::move(config)) {
  ValidateHalConfig(config_);
  if (channels.size() != config_.buses.size())
    throw ConfigError("HAL: " + std::to_string(config_.buses.size()) +
                      " buses configured but " + std::to_string(channels.size()) +
                      " CAN channels given");
  for (std::size_t i = 0; i < channels.size(); ++i)
    buses_.push_back(std::make_unique<Bus>(config_.buses[i], config_.timing, &config_.joints,
                                           channels[i]));
}

HalStatus Hal::Read(std::int64_t now_ns) noexcept {
  HalStatus status = HalStatus::kOk;
  ++image_.cycle;
  image_.wkc = {};
  for (auto& b : buses_) {
    status = Worse(status, b->Read(now_ns, image_.cycle, &image_));
    image_.wkc.expected += b->wkc().expected;
    image_.wkc.received += b->wkc().received;
  }
  return status;
}

HalStatus Hal::Write(std::int64_t now_ns) noexcept {
  HalStatus status = HalStatus::kOk;
  for (auto& b : buses_) status = Worse(status, b->Write(now_ns, image_));
  return status;
}

void Hal::RequestState(DeviceState target, std::int64_t now_ns) noexcept {
  if (target > target_ || bringup_start_ns_ == 0) bringup_start_ns_ = now_ns;
  target_ = target;
  for (auto& b : buses_) b->RequestState(target, now_ns);
}

void Hal::ReleaseJoint(int joint) noexcept {
  for (auto& b : buses_) b->ReleaseJoint(joint);
}

void Hal::AcknowledgeFaults(std::int64_t now_ns) noexcept {
  for (auto& b : buses_) b->AcknowledgeFaults(now_ns);
}

bool Hal::AllIn(DeviceState s) const noexcept {
  return std::all_of(buses_.begin(), buses_.end(), [s](const auto& b) { return b->AllIn(s); });
}

BringUpStatus Hal::PollBringUp(std::int64_t now_ns) const noexcept {
  if (AllIn(target_)) return BringUpStatus::kComplete;
  const auto timeout_ns = static_cast<std::int64_t>(config_.timing.bringup_timeout_s * 1e9);
  return now_ns - bringup_start_ns_ > timeout_ns ? BringUpStatus::kTimedOut
                                                 : BringUpStatus::kInProgress;
}

std::string Hal::BringUpReport(std::int64_t now_ns) const {
  std::string out;
  int not_up = 0, total = 0;
  for (const auto& b : buses_) {
    for (const DeviceRuntime& d : b->devices()) {
      ++total;
      if (d.state == target_) continue;
      ++not_up;
      const DeviceConfig& c = b->config().devices[static_cast<std::size_t>(d.config_index)];
      char line[400];
      char hb[48];
      char first[80] = "";
      if (d.first_error != DeviceError::kNone && d.first_error != d.error)
        std::snprintf(first, sizeof first, " (first: %s)", ToString(d.first_error));
      if (d.last_heartbeat_ns < 0) std::snprintf(hb, sizeof hb, "no heartbeat since the reset");
      else std::snprintf(hb, sizeof hb, "last heartbeat %.0f ms ago",
                         1e-6 * static_cast<double>(now_ns - d.last_heartbeat_ns));
      std::snprintf(line, sizeof line,
                    "\n  bus '%s' (%s) node %u '%s'%s%s: in %s, wanted %s; last error: %s%s; %s; "
                    "%llu valid / %llu missing / %llu malformed frames",
                    b->config().name.c_str(), b->config().interface.c_str(),
                    static_cast<unsigned>(d.node), c.name.c_str(), d.joint >= 0 ? " joint " : "",
                    d.joint >= 0 ? std::string(JointName(d.joint)).c_str() : "",
                    ToString(d.state), ToString(target_), ToString(d.error), first, hb,
                    static_cast<unsigned long long>(d.counters.valid),
                    static_cast<unsigned long long>(d.counters.missing),
                    static_cast<unsigned long long>(d.counters.malformed));
      out += line;
    }
  }
  return std::to_string(not_up) + " of " + std::to_string(total) + " devices not in " +
         ToString(target_) + (not_up ? ":" : "") + out;
}

void RunBringUp(Hal& hal, DeviceState target, std::int64_t now_ns,
                const std::function<std::int64_t()>& next_cycle) {
  hal.RequestState(target, now_ns);
  for (;;) {
    (void)hal.Read(now_ns);
    (void)hal.Write(now_ns);
    const BringUpStatus s = hal.PollBringUp(now_ns);
    if (s == BringUpStatus::kComplete) return;
    if (s == BringUpStatus::kTimedOut)
      throw ConfigError("HAL bring-up to " + std::string(ToString(target)) + " timed out after " +
                        std::to_string(hal.config().timing.bringup_timeout_s) + " s: " +
                        hal.BringUpReport(now_ns));
    now_ns = next_cycle();
  }
}

}  // namespace hyq::hal
