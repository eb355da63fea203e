#include "servo/telemetry.h"

#include <poll.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <utility>

#include <lcm/lcm-cpp.hpp>

#include "hyq_lcm/lcmt_hyq_base_state.hpp"
#include "hyq_lcm/lcmt_hyq_command.hpp"
#include "hyq_lcm/lcmt_hyq_contact_state.hpp"
#include "hyq_lcm/lcmt_hyq_event.hpp"
#include "hyq_lcm/lcmt_hyq_health.hpp"
#include "hyq_lcm/lcmt_hyq_joint_state.hpp"
#include "hyq_lcm/lcmt_hyq_joint_torque.hpp"
#include "hyq_lcm/lcmt_hyq_servo_timing.hpp"
#include "servo/controller.h"
#include "servo/spsc_ring.h"

namespace hyq::servo {

const char* ToString(ServoCommand::Kind k) noexcept {
  switch (k) {
    case ServoCommand::Kind::kEnable: return "enable";
    case ServoCommand::Kind::kDisable: return "disable";
    case ServoCommand::Kind::kDamp: return "damp";
    case ServoCommand::Kind::kAcknowledge: return "ack";
    case ServoCommand::Kind::kSetMu: return "mu";
    case ServoCommand::Kind::kSetController: return "controller";
    case ServoCommand::Kind::kSetGains: return "gains";
    case ServoCommand::Kind::kRejected: return "rejected";
  }
  return "unknown";
}

namespace {

using Clock = std::chrono::steady_clock;
constexpr std::size_t kEventStringCapacity = 128;

// std::array -> the generated C array of the same length (element types may differ)
template <class T, std::size_t N, class U>
void CopyArray(const std::array<T, N>& from, U (*to)[N]) {
  for (std::size_t i = 0; i < N; ++i) (*to)[i] = static_cast<U>(from[i]);
}

bool Due(std::uint64_t cycle, std::uint32_t every) { return every != 0 && cycle % every == 0; }

void CheckCapacity(const char* name, std::size_t n) {
  if (n < 2 || (n & (n - 1)) != 0)
    throw std::invalid_argument(std::string("TelemetryConfig.") + name +
                                ": expected a power of two >= 2, found " + std::to_string(n));
}

}  // namespace

struct Telemetry::Impl {
  Impl(const TelemetryConfig& c, const CommandChannelConfig& cc, PublishFn p)
      : config(c), commands_config(cc), publish_override(std::move(p)),
        snapshots(c.snapshot_queue_capacity), events(c.event_queue_capacity),
        commands(c.command_queue_capacity) {}

  const TelemetryConfig config;
  const CommandChannelConfig commands_config;
  PublishFn publish_override;
  std::unique_ptr<lcm::LCM> lcm;
  lcm::Subscription* subscription = nullptr;

  SpscRing<TelemetrySnapshot> snapshots;  // servo -> telemetry thread
  SpscRing<SafetyEvent> events;           // servo -> telemetry thread
  SpscRing<ServoCommand> commands;        // telemetry thread -> servo

  std::atomic<std::uint64_t> snapshots_pushed{0}, snapshots_dropped{0}, snapshots_published{0};
  std::atomic<std::uint64_t> events_pushed{0}, events_dropped{0}, events_published{0};
  std::atomic<std::uint64_t> messages_published{0}, publish_failures{0};
  std::atomic<std::uint64_t> commands_received{0}, commands_accepted{0}, commands_rejected{0};
  std::atomic<std::uint64_t> commands_dropped{0};

  std::thread thread;
  std::atomic<bool> stop{false};
  bool running = false;

  // telemetry thread only: channel names, messages and the encode buffer, all built up front
  std::string ch_joint_state, ch_joint_torque, ch_base_state, ch_contact, ch_timing, ch_health,
      ch_event;
  TelemetrySnapshot current;
  bool have_current = false;
  SafetyEvent event_in;
  hyq_lcm::lcmt_hyq_joint_state joint_state{};
  hyq_lcm::lcmt_hyq_joint_torque joint_torque{};
  hyq_lcm::lcmt_hyq_base_state base_state{};
  hyq_lcm::lcmt_hyq_contact_state contact{};
  hyq_lcm::lcmt_hyq_servo_timing timing{};
  hyq_lcm::lcmt_hyq_health health{};
  hyq_lcm::lcmt_hyq_event event{};
  // UDP multicast is best effort and a busy subscriber (lcm-logger's receive ring) drops
  // datagrams: each event is published again with the next two HEALTH messages (consumers
  // deduplicate on cycle and reason); fixed capacity, the oldest repeats give way
  struct Repeat {
    SafetyEvent event;
    int left = 0;
  };
  static constexpr std::size_t kMaxRepeats = 64;
  std::array<Repeat, kMaxRepeats> repeats{};
  std::size_t num_repeats = 0;
  std::vector<std::uint8_t> buffer;
  Clock::time_point last_accepted{};
  bool accepted_any = false;
  std::vector<std::uint8_t> allowed_controllers;  // ControllerKind values

  void Run();
  bool DrainOnce();
  void PublishSnapshot(const TelemetrySnapshot& s);
  void PublishHealth(const TelemetrySnapshot& s);
  void PublishEvent(const SafetyEvent& e, bool repeat = true);
  template <class M>
  void Publish(const std::string& channel, const M& msg);
  void OnCommand(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  bool Validate(const hyq_lcm::lcmt_hyq_command& msg, ServoCommand* out, char* why,
                std::size_t why_size) const;
  void Reject(std::int64_t sequence, const char* why);
  void TellServoInvalid(std::int64_t sequence);
};

Telemetry::Telemetry(const TelemetryConfig& config, const CommandChannelConfig& commands,
                     PublishFn publish)
    : config_(config) {
  if (!config.enabled) return;
  CheckCapacity("snapshot_queue_capacity", config.snapshot_queue_capacity);
  CheckCapacity("event_queue_capacity", config.event_queue_capacity);
  CheckCapacity("command_queue_capacity", config.command_queue_capacity);
  if (commands.enabled) {
    if (!(commands.max_rate_hz > 0.0))
      throw std::invalid_argument("CommandChannelConfig.max_rate_hz: expected > 0, found " +
                                  std::to_string(commands.max_rate_hz));
    if (!(commands.mu_min <= commands.mu_max) || !(commands.mu_min >= 0.0))
      throw std::invalid_argument("CommandChannelConfig mu range: expected 0 <= mu_min <= mu_max");
    if (!(commands.gain_scale_min <= commands.gain_scale_max) || !(commands.gain_scale_min > 0.0))
      throw std::invalid_argument(
          "CommandChannelConfig gain scale range: expected 0 < gain_scale_min <= gain_scale_max");
    if (commands.channel.empty())
      throw std::invalid_argument("CommandChannelConfig.channel: expected a name, found none");
  }
  impl_ = std::make_unique<Impl>(config, commands, std::move(publish));
  Impl& m = *impl_;
  for (const std::string& name : commands.allowed_controllers) {
    const auto kind = ParseControllerKind(name);
    if (!kind)
      throw std::invalid_argument("CommandChannelConfig.allowed_controllers: unknown controller '" +
                                  name + "' (expected pid, noslip, stage1 or two_stage)");
    m.allowed_controllers.push_back(static_cast<std::uint8_t>(*kind));
  }

  m.lcm = std::make_unique<lcm::LCM>(config.lcm_url);
  if (!m.lcm->good())
    throw std::runtime_error("Telemetry: cannot create LCM on '" + config.lcm_url +
                             "' (for udpm, is there a multicast route, e.g. 224.0.0.0/4 dev lo?)");
  if (commands.enabled) {
    m.subscription = m.lcm->subscribe(commands.channel, &Impl::OnCommand, &m);
    if (m.subscription == nullptr)
      throw std::runtime_error("Telemetry: cannot subscribe to '" + commands.channel + "'");
  }

  m.ch_joint_state = channel("JOINT_STATE");
  m.ch_joint_torque = channel("JOINT_TORQUE");
  m.ch_base_state = channel("BASE_STATE");
  m.ch_contact = channel("CONTACT");
  m.ch_timing = channel("TIMING");
  m.ch_health = channel("HEALTH");
  m.ch_event = channel("EVENT");
  for (std::string* s : {&m.event.from_name, &m.event.to_name, &m.event.reason, &m.event.detail})
    s->reserve(kEventStringCapacity);
  m.buffer.resize(std::max({m.joint_state.getEncodedSize(), m.joint_torque.getEncodedSize(),
                            m.base_state.getEncodedSize(), m.contact.getEncodedSize(),
                            m.timing.getEncodedSize(), m.health.getEncodedSize(),
                            m.event.getEncodedSize() + 4 * static_cast<int>(kEventStringCapacity)}));
}

Telemetry::~Telemetry() { Stop(); }

void Telemetry::Start() {
  if (!impl_ || impl_->running) return;
  impl_->stop.store(false);
  impl_->thread = std::thread([m = impl_.get()] { m->Run(); });
  impl_->running = true;
}

void Telemetry::Stop() {
  if (!impl_ || !impl_->running) return;
  impl_->stop.store(true, std::memory_order_release);
  impl_->thread.join();
  impl_->running = false;
}

bool Telemetry::Push(const TelemetrySnapshot& snapshot) noexcept {
  if (!impl_) return false;
  if (!impl_->snapshots.TryPush(snapshot)) {
    impl_->snapshots_dropped.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  impl_->snapshots_pushed.fetch_add(1, std::memory_order_relaxed);
  return true;
}

bool Telemetry::PushEvent(const SafetyEvent& event) noexcept {
  if (!impl_) return false;
  if (!impl_->events.TryPush(event)) {
    impl_->events_dropped.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  impl_->events_pushed.fetch_add(1, std::memory_order_relaxed);
  return true;
}

bool Telemetry::PopCommand(ServoCommand* command) noexcept {
  return impl_ && impl_->commands.TryPop(command);
}

bool Telemetry::command_subscribed() const noexcept {
  return impl_ && impl_->subscription != nullptr;
}

TelemetryStats Telemetry::stats() const noexcept {
  TelemetryStats s;
  if (!impl_) return s;
  const Impl& m = *impl_;
  s.snapshots_pushed = m.snapshots_pushed.load();
  s.snapshots_dropped = m.snapshots_dropped.load();
  s.snapshots_published = m.snapshots_published.load();
  s.events_pushed = m.events_pushed.load();
  s.events_dropped = m.events_dropped.load();
  s.events_published = m.events_published.load();
  s.messages_published = m.messages_published.load();
  s.publish_failures = m.publish_failures.load();
  s.commands_received = m.commands_received.load();
  s.commands_accepted = m.commands_accepted.load();
  s.commands_rejected = m.commands_rejected.load();
  s.commands_dropped = m.commands_dropped.load();
  return s;
}

// ---- telemetry thread ----

void Telemetry::Impl::Run() {
  const int fd = subscription != nullptr ? lcm->getFileno() : -1;
  while (!stop.load(std::memory_order_acquire)) {
    const bool busy = DrainOnce();
    // wait for a command (or just the idle period) only when the queues were empty
    pollfd p{fd, POLLIN, 0};
    const int ready = poll(fd >= 0 ? &p : nullptr, fd >= 0 ? 1 : 0, busy ? 0 : config.idle_wait_ms);
    if (ready > 0 && (p.revents & POLLIN) != 0) lcm->handle();
  }
  // stop: publish what is still queued, then a final health message with the final counters
  while (DrainOnce()) {
  }
  if (have_current) PublishHealth(current);
}

bool Telemetry::Impl::DrainOnce() {
  bool any = false;
  while (events.TryPop(&event_in)) {
    PublishEvent(event_in);
    events_published.fetch_add(1, std::memory_order_relaxed);
    any = true;
  }
  while (snapshots.TryPop(&current)) {
    have_current = true;
    PublishSnapshot(current);
    snapshots_published.fetch_add(1, std::memory_order_relaxed);
    any = true;
    // events raised meanwhile go out before the next snapshot
    while (events.TryPop(&event_in)) {
      PublishEvent(event_in);
      events_published.fetch_add(1, std::memory_order_relaxed);
    }
  }
  return any;
}

template <class M>
void Telemetry::Impl::Publish(const std::string& channel, const M& msg) {
  const int size = msg.getEncodedSize();
  if (static_cast<std::size_t>(size) > buffer.size()) buffer.resize(static_cast<std::size_t>(size));
  const int n = msg.encode(buffer.data(), 0, size);
  bool ok = n >= 0;
  if (ok) {
    ok = publish_override ? publish_override(channel, buffer.data(), static_cast<std::size_t>(n))
                          : lcm->publish(channel, buffer.data(), static_cast<unsigned>(n)) == 0;
  }
  (ok ? messages_published : publish_failures).fetch_add(1, std::memory_order_relaxed);
}

void Telemetry::Impl::PublishSnapshot(const TelemetrySnapshot& s) {
  const std::int64_t utime = s.time_ns / 1000;
  const auto cycle = static_cast<std::int64_t>(s.cycle);
  const auto mode = static_cast<std::int8_t>(s.mode);
  if (Due(s.cycle, config.joint_state_every)) {
    hyq_lcm::lcmt_hyq_joint_state& m = joint_state;
    m.utime = utime;
    m.cycle = cycle;
    m.mode = mode;
    m.reference_time_s = s.reference_time_s;
    CopyArray(s.q_rad, &m.q_rad);
    CopyArray(s.qd_rad_s, &m.qd_rad_s);
    CopyArray(s.tau_measured_Nm, &m.tau_measured_Nm);
    CopyArray(s.q_ref_rad, &m.q_ref_rad);
    CopyArray(s.qd_ref_rad_s, &m.qd_ref_rad_s);
    CopyArray(s.input_status, &m.input_status);
    m.tracking_error_rad = s.tracking_error_rad;
    Publish(ch_joint_state, m);
  }
  if (Due(s.cycle, config.joint_torque_every)) {
    hyq_lcm::lcmt_hyq_joint_torque& m = joint_torque;
    m.utime = utime;
    m.cycle = cycle;
    m.mode = mode;
    m.controller = static_cast<std::int8_t>(s.controller);
    CopyArray(s.tau_command_Nm, &m.tau_command_Nm);
    Publish(ch_joint_torque, m);
  }
  if (Due(s.cycle, config.base_state_every)) {
    hyq_lcm::lcmt_hyq_base_state& m = base_state;
    m.utime = utime;
    m.cycle = cycle;
    CopyArray(s.base_position_m, &m.position_m);
    CopyArray(s.base_orientation_wxyz, &m.orientation_wxyz);
    CopyArray(s.base_velocity_m_s, &m.velocity_m_s);
    CopyArray(s.base_angular_velocity_rad_s, &m.angular_velocity_rad_s);
    Publish(ch_base_state, m);
  }
  if (Due(s.cycle, config.contact_every)) {
    hyq_lcm::lcmt_hyq_contact_state& m = contact;
    m.utime = utime;
    m.cycle = cycle;
    m.controller = static_cast<std::int8_t>(s.controller);
    for (int f = 0; f < kTelemetryFeet; ++f) {
      m.stance_reference[f] = s.stance_reference[f] != 0;
      m.stance_estimated[f] = s.stance_estimated[f] != 0;
      m.mu[f] = s.mu[f];
      CopyArray(s.contact_force_N[f], &m.contact_force_N[f]);
    }
    m.stage1_status = static_cast<std::int8_t>(s.stage1_status);
    m.stage2_status = static_cast<std::int8_t>(s.stage2_status);
    m.fallback = static_cast<std::int8_t>(s.fallback);
    m.stage1_iterations = s.stage1_iterations;
    m.stage2_iterations = s.stage2_iterations;
    m.stage1_solve_us = s.stage1_solve_us;
    m.stage2_solve_us = s.stage2_solve_us;
    Publish(ch_contact, m);
  }
  if (Due(s.cycle, config.timing_every)) {
    hyq_lcm::lcmt_hyq_servo_timing& m = timing;
    m.utime = utime;
    m.cycle = cycle;
    m.wakeup_latency_ns = s.timing.wakeup_latency_ns;
    m.read_ns = s.timing.read_ns;
    m.estimate_ns = s.timing.estimate_ns;
    m.reference_ns = s.timing.reference_ns;
    m.control_ns = s.timing.control_ns;
    m.safety_ns = s.timing.safety_ns;
    m.write_ns = s.timing.write_ns;
    m.total_ns = s.timing.total_ns;
    m.deadline_misses = static_cast<std::int64_t>(s.deadline_misses);
    m.consecutive_misses = static_cast<std::int32_t>(s.consecutive_misses);
    m.skipped_cycles = static_cast<std::int64_t>(s.skipped_cycles);
    Publish(ch_timing, m);
  }
  if (Due(s.cycle, config.health_every)) PublishHealth(s);
}

void Telemetry::Impl::PublishHealth(const TelemetrySnapshot& s) {
  hyq_lcm::lcmt_hyq_health& m = health;
  m.utime = s.time_ns / 1000;
  m.cycle = static_cast<std::int64_t>(s.cycle);
  m.mode = static_cast<std::int8_t>(s.mode);
  m.hal_read_status = static_cast<std::int8_t>(s.hal_read_status);
  m.hal_write_status = static_cast<std::int8_t>(s.hal_write_status);
  m.num_buses = static_cast<std::int8_t>(std::min<int>(s.num_buses, kTelemetryBuses));
  for (int b = 0; b < kTelemetryBuses; ++b) {
    const BusHealth& in = s.buses[b];
    hyq_lcm::lcmt_hyq_bus_health& out = m.buses[b];
    out.rx_frames = static_cast<std::int64_t>(in.rx_frames);
    out.tx_frames = static_cast<std::int64_t>(in.tx_frames);
    out.wkc_faults = static_cast<std::int64_t>(in.wkc_faults);
    out.missing = static_cast<std::int64_t>(in.missing);
    out.malformed = static_cast<std::int64_t>(in.malformed);
    out.error_frames = static_cast<std::int64_t>(in.error_frames);
    out.emcy = static_cast<std::int64_t>(in.emcy);
    out.bus_off = static_cast<std::int64_t>(in.bus_off);
    out.tx_failed = static_cast<std::int64_t>(in.tx_failed);
    out.wkc_expected = static_cast<std::int32_t>(in.wkc_expected);
    out.wkc_received = static_cast<std::int32_t>(in.wkc_received);
  }
  m.num_devices = static_cast<std::int8_t>(std::min<int>(s.num_devices, kTelemetryDevices));
  CopyArray(s.device_state, &m.device_state);
  m.safety_events = static_cast<std::int64_t>(s.events);
  const auto load = [](const std::atomic<std::uint64_t>& a) {
    return static_cast<std::int64_t>(a.load(std::memory_order_relaxed));
  };
  m.snapshots_dropped = load(snapshots_dropped);
  m.events_dropped = load(events_dropped);
  m.snapshots_published = load(snapshots_published);
  m.publish_failures = load(publish_failures);
  m.commands_received = load(commands_received);
  m.commands_accepted = load(commands_accepted);
  m.commands_rejected = load(commands_rejected);
  m.commands_dropped = load(commands_dropped);
  Publish(ch_health, m);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < num_repeats; ++i) {
    PublishEvent(repeats[i].event, false);
    if (--repeats[i].left > 0) repeats[kept++] = repeats[i];
  }
  num_repeats = kept;
}

void Telemetry::Impl::PublishEvent(const SafetyEvent& e, bool repeat) {
  if (repeat) {
    if (num_repeats == kMaxRepeats) {  // drop the oldest
      std::move(repeats.begin() + 1, repeats.end(), repeats.begin());
      --num_repeats;
    }
    repeats[num_repeats++] = {e, 2};
  }
  hyq_lcm::lcmt_hyq_event& m = event;
  m.utime = e.time_ns / 1000;
  m.cycle = static_cast<std::int64_t>(e.cycle);
  m.from_mode = static_cast<std::int8_t>(e.from);
  m.to_mode = static_cast<std::int8_t>(e.to);
  m.from_name = ToString(e.from);
  m.to_name = ToString(e.to);
  m.reason_code = static_cast<std::int16_t>(e.reason);
  m.reason = ToString(e.reason);
  m.joint = e.joint;
  m.bus = e.bus;
  m.detail.assign(e.detail.data(), strnlen(e.detail.data(), e.detail.size()));
  Publish(ch_event, m);
}

// ---- command channel (telemetry thread) ----

// An invalid command (not one refused for its rate or a full queue) also reaches the servo
// thread as kRejected: a sender that emits garbage is a fault (safety.damp_on_bad_command).
void Telemetry::Impl::TellServoInvalid(std::int64_t sequence) {
  ServoCommand c;
  c.kind = ServoCommand::Kind::kRejected;
  c.sequence = static_cast<std::uint64_t>(sequence < 0 ? 0 : sequence);
  (void)commands.TryPush(c);
}

void Telemetry::Impl::Reject(std::int64_t sequence, const char* why) {
  commands_rejected.fetch_add(1, std::memory_order_relaxed);
  SafetyEvent e;
  e.cycle = have_current ? current.cycle : 0;
  e.time_ns = have_current ? current.time_ns : 0;
  e.from = e.to = have_current ? current.mode : ServoMode::kInit;
  e.reason = EventReason::kCommandRejected;
  std::snprintf(e.detail.data(), e.detail.size(), "seq %lld: %s",
                static_cast<long long>(sequence), why);
  PublishEvent(e);
  events_published.fetch_add(1, std::memory_order_relaxed);
}

bool Telemetry::Impl::Validate(const hyq_lcm::lcmt_hyq_command& msg, ServoCommand* out, char* why,
                               std::size_t n) const {
  const CommandChannelConfig& c = commands_config;
  using K = hyq_lcm::lcmt_hyq_command;
  if (msg.kind < K::KIND_ENABLE || msg.kind > K::KIND_SET_GAINS) {
    std::snprintf(why, n, "kind: expected 0..6, found %d", msg.kind);
    return false;
  }
  out->kind = static_cast<ServoCommand::Kind>(msg.kind);
  out->sequence = static_cast<std::uint64_t>(msg.sequence);
  switch (msg.kind) {
    case K::KIND_SET_MU:
      if (msg.num_feet != kTelemetryFeet) {
        std::snprintf(why, n, "mu: expected %d feet, found %d", kTelemetryFeet, msg.num_feet);
        return false;
      }
      for (int f = 0; f < kTelemetryFeet; ++f) {
        const double mu = msg.mu[static_cast<std::size_t>(f)];
        if (!std::isfinite(mu) || mu < c.mu_min || mu > c.mu_max) {
          std::snprintf(why, n, "mu[%d]: expected [%g, %g], found %g", f, c.mu_min, c.mu_max, mu);
          return false;
        }
        out->mu[static_cast<std::size_t>(f)] = mu;
      }
      break;
    case K::KIND_SET_CONTROLLER: {
      const auto kind = ParseControllerKind(msg.controller);
      const bool allowed =
          kind && std::find(allowed_controllers.begin(), allowed_controllers.end(),
                            static_cast<std::uint8_t>(*kind)) != allowed_controllers.end();
      if (!allowed) {
        std::string list;
        for (const std::string& a : c.allowed_controllers) list += (list.empty() ? "" : ",") + a;
        std::snprintf(why, n, "controller: expected one of %s, found '%.24s'", list.c_str(),
                      msg.controller.c_str());
        return false;
      }
      out->controller = static_cast<std::uint8_t>(*kind);
      break;
    }
    case K::KIND_SET_GAINS:
      for (const auto& [name, v] : {std::pair{"kp_scale", msg.kp_scale}, {"kd_scale", msg.kd_scale}}) {
        if (!std::isfinite(v) || v < c.gain_scale_min || v > c.gain_scale_max) {
          std::snprintf(why, n, "%s: expected [%g, %g], found %g", name, c.gain_scale_min,
                        c.gain_scale_max, v);
          return false;
        }
      }
      out->kp_scale = msg.kp_scale;
      out->kd_scale = msg.kd_scale;
      break;
    default:
      break;
  }
  return true;
}

void Telemetry::Impl::OnCommand(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) {
  commands_received.fetch_add(1, std::memory_order_relaxed);
  char why[80];
  hyq_lcm::lcmt_hyq_command msg;
  if (msg.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) {
    std::snprintf(why, sizeof why, "message: expected lcmt_hyq_command, found %u undecodable bytes",
                  rbuf->data_size);
    TellServoInvalid(-1);  // first: whoever sees the refusal event finds the servo told already
    Reject(-1, why);
    return;
  }
  ServoCommand command;
  if (!Validate(msg, &command, why, sizeof why)) {
    TellServoInvalid(msg.sequence);
    Reject(msg.sequence, why);
    return;
  }
  // rate limit: accepted commands at least 1 / max_rate_hz apart
  const Clock::time_point now = Clock::now();
  if (accepted_any) {
    const double dt_s = std::chrono::duration<double>(now - last_accepted).count();
    if (dt_s * commands_config.max_rate_hz < 1.0) {
      std::snprintf(why, sizeof why, "rate: expected <= %g Hz, found %.0f Hz",
                    commands_config.max_rate_hz, dt_s > 0.0 ? 1.0 / dt_s : 1e9);
      Reject(msg.sequence, why);
      return;
    }
  }
  if (!commands.TryPush(command)) {
    commands_dropped.fetch_add(1, std::memory_order_relaxed);
    Reject(msg.sequence, "queue: the servo is not taking commands (command queue full)");
    return;
  }
  accepted_any = true;
  last_accepted = now;
  commands_accepted.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace hyq::servo
