#include "servo/telemetry/telemetry.h"

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

#include "servo/command/command_auth.h"
#include "servo/command/command_channel.h"
#include "servo/telemetry/lcm_mapping.h"
#include "servo/telemetry/lcm_url.h"
#include "hal/spsc_ring.h"

namespace hyq::servo {

namespace {

constexpr std::size_t kEventStringCapacity = 128;
// how long Stop waits before its final messages (see Telemetry::Impl::Run)
constexpr std::chrono::milliseconds kStopSettle(50);

bool Due(std::uint64_t cycle, std::uint32_t every) { return every != 0 && cycle % every == 0; }

void CheckCapacity(const char* name, std::size_t n) {
  if (n < 2 || (n & (n - 1)) != 0)
    throw std::invalid_argument(std::string("TelemetryConfig.") + name +
                                ": expected a power of two >= 2, found " + std::to_string(n));
}

// The command channel's authenticator: the key is read (and its file's owner and mode checked)
// only when the channel is enabled.
CommandAuthenticator MakeAuthenticator(const CommandChannelConfig& c) {
  CommandAuthConfig a;
  a.max_age = std::chrono::milliseconds(static_cast<std::int64_t>(c.max_age_ms));
  a.max_senders = c.max_senders;
  return CommandAuthenticator(c.enabled ? LoadCommandKey(c.key_file) : CommandKey{}, a);
}

// Queues `value`, counting it as pushed or, when the ring is full, as dropped.
template <class T>
bool PushCounted(hal::SpscRing<T>* ring, const T& value, std::atomic<std::uint64_t>* pushed,
                 std::atomic<std::uint64_t>* dropped) noexcept {
  const bool ok = ring->TryPush(value);
  (ok ? pushed : dropped)->fetch_add(1, std::memory_order_relaxed);
  return ok;
}

}  // namespace

struct Telemetry::Impl {
  Impl(const TelemetryConfig& c, const CommandChannelConfig& cc, PublishFn p)
      : config(c), validator(cc), auth(MakeAuthenticator(cc)), publish_override(std::move(p)),
        snapshots(c.snapshot_queue_capacity), events(c.event_queue_capacity),
        commands(c.command_queue_capacity) {}

  const TelemetryConfig config;
  CommandValidator validator;  // decode, validate and rate-limit (telemetry thread)
  CommandAuthenticator auth;   // MAC, freshness and sequence before anything is decoded
  PublishFn publish_override;
  std::unique_ptr<lcm::LCM> lcm;
  lcm::Subscription* subscription = nullptr;

  hal::SpscRing<TelemetrySnapshot> snapshots;  // servo -> telemetry thread
  hal::SpscRing<SafetyEvent> events;           // servo -> telemetry thread
  hal::SpscRing<ServoCommand> commands;        // telemetry thread -> servo

  std::atomic<std::uint64_t> snapshots_pushed{0}, snapshots_dropped{0}, snapshots_published{0};
  std::atomic<std::uint64_t> events_pushed{0}, events_dropped{0}, events_published{0};
  std::atomic<std::uint64_t> messages_published{0}, publish_failures{0};
  std::atomic<std::uint64_t> commands_received{0}, commands_accepted{0}, commands_rejected{0};
  std::atomic<std::uint64_t> commands_dropped{0}, commands_unauthenticated{0}, commands_replayed{0};
  // refusals of unauthenticated datagrams are evented at most every 100 ms (a flood of them must
  // not flood HYQ_EVENT); the ones in between are counted and the next event says "(+N more)"
  std::chrono::steady_clock::time_point last_auth_event{};
  std::uint64_t auth_events_suppressed = 0;

  std::thread thread;
  std::atomic<bool> stop{false};
  bool running = false;

  // telemetry thread only: channel names, messages and the encode buffer, all built up front
  std::string ch_joint_state, ch_joint_torque, ch_base_state, ch_contact, ch_friction, ch_disturbance, ch_timing,
      ch_health, ch_event;
  TelemetrySnapshot current;
  bool have_current = false;
  SafetyEvent event_in;
  hyq_lcm::lcmt_hyq_event event{};
  // UDP multicast is best effort and a busy subscriber (lcm-logger's receive ring) loses
  // datagrams in bursts: each event is published again kRepeatDelays after its first copy, in
  // wall time (a burst is a stretch of wall time, not of cycles), and every copy still owed
  // goes out once more at Stop (consumers deduplicate on cycle, reason and detail); fixed
  // capacity, the oldest repeats give way
  using Clock = std::chrono::steady_clock;
  static constexpr std::array<std::chrono::milliseconds, 3> kRepeatDelays{
      std::chrono::milliseconds(20), std::chrono::milliseconds(100),
      std::chrono::milliseconds(500)};
  struct Repeat {
    SafetyEvent event;
    Clock::time_point first;
    std::size_t next = 0;  // index into kRepeatDelays
  };
  static constexpr std::size_t kMaxRepeats = 64;
  std::array<Repeat, kMaxRepeats> repeats{};
  std::size_t num_repeats = 0;
  std::vector<std::uint8_t> buffer;

  void Run();
  void HandleOne() noexcept;
  bool DrainOnce();
  void PublishSnapshot(TelemetrySnapshot* s);
  void PublishHealth(TelemetrySnapshot* s);
  TelemetryStats Stats() const noexcept;
  void PublishEvent(const SafetyEvent& e, bool repeat = true);
  void PublishDueRepeats(bool all);
  template <class M>
  void Publish(const std::string& channel, const M& msg);
  void OnCommand(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  void Reject(std::int64_t sequence, const char* why);
  void RejectUnauthenticated(const char* why);
  void TellServoInvalid(std::int64_t sequence);
};

Telemetry::Telemetry(const TelemetryConfig& config, const CommandChannelConfig& commands,
                     PublishFn publish)
    : config_(config) {
  if (!config.enabled) return;
  CheckCapacity("snapshot_queue_capacity", config.snapshot_queue_capacity);
  CheckCapacity("event_queue_capacity", config.event_queue_capacity);
  CheckCapacity("command_queue_capacity", config.command_queue_capacity);
  impl_ = std::make_unique<Impl>(config, commands, std::move(publish));
  Impl& m = *impl_;
  m.lcm = std::make_unique<lcm::LCM>(config.lcm_url);
  if (!m.lcm->good())
    throw std::runtime_error("Telemetry: cannot create LCM on '" + config.lcm_url +
                             "' (for udpm, is there a multicast route, e.g. 224.0.0.0/4 dev lo?)");
  if (commands.enabled) {
    // liblcm joins the group on whatever interface the route picks: refuse to listen for
    // commands anywhere but where configured (the robot's LAN is not the operator's network)
    const LcmUrl url = ParseLcmUrl(config.lcm_url, "telemetry.lcm_url");
    if (url.provider == "udpm" && !commands.interface.empty()) {
      const std::string via = InterfaceForGroup(url.group, url.port);
      if (via != commands.interface)
        throw std::invalid_argument("commands.interface: expected the route to " + url.group +
                                    " to use '" + commands.interface + "', found '" + via +
                                    "' (e.g. ip route add 224.0.0.0/4 dev " + commands.interface +
                                    ", or set commands.interface)");
    }
    m.subscription = m.lcm->subscribe(commands.channel, &Impl::OnCommand, &m);
    if (m.subscription == nullptr)
      throw std::runtime_error("Telemetry: cannot subscribe to '" + commands.channel + "'");
  }

  m.ch_joint_state = channel("JOINT_STATE");
  m.ch_joint_torque = channel("JOINT_TORQUE");
  m.ch_base_state = channel("BASE_STATE");
  m.ch_contact = channel("CONTACT");
  m.ch_friction = channel("FRICTION");
  m.ch_disturbance = channel("DISTURBANCE");
  m.ch_timing = channel("TIMING");
  m.ch_health = channel("HEALTH");
  m.ch_event = channel("EVENT");
  for (std::string* s :
       {&m.event.from_name, &m.event.to_name, &m.event.reason, &m.event.detail, &m.event.stop})
    s->reserve(kEventStringCapacity);
  const TelemetrySnapshot& s = m.current;
  m.buffer.resize(static_cast<std::size_t>(std::max(
      {s.joint_state.getEncodedSize(), s.joint_torque.getEncodedSize(),
       s.base_state.getEncodedSize(), s.contact.getEncodedSize(), s.friction.getEncodedSize(),
       s.disturbance.getEncodedSize(), s.timing.getEncodedSize(), s.health.getEncodedSize(),
       m.event.getEncodedSize() + 4 * static_cast<int>(kEventStringCapacity)})));
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
  return impl_ && PushCounted(&impl_->snapshots, snapshot, &impl_->snapshots_pushed,
                              &impl_->snapshots_dropped);
}

bool Telemetry::PushEvent(const SafetyEvent& event) noexcept {
  return impl_ && PushCounted(&impl_->events, event, &impl_->events_pushed, &impl_->events_dropped);
}

bool Telemetry::PopCommand(ServoCommand* command) noexcept {
  return impl_ && impl_->commands.TryPop(command);
}

bool Telemetry::command_subscribed() const noexcept {
  return impl_ && impl_->subscription != nullptr;
}

TelemetryStats Telemetry::stats() const noexcept {
  return impl_ ? impl_->Stats() : TelemetryStats{};
}

TelemetryStats Telemetry::Impl::Stats() const noexcept {
  const auto load = [](const std::atomic<std::uint64_t>& a) {
    return a.load(std::memory_order_relaxed);
  };
  TelemetryStats s;
  s.snapshots_pushed = load(snapshots_pushed);
  s.snapshots_dropped = load(snapshots_dropped);
  s.snapshots_published = load(snapshots_published);
  s.events_pushed = load(events_pushed);
  s.events_dropped = load(events_dropped);
  s.events_published = load(events_published);
  s.messages_published = load(messages_published);
  s.publish_failures = load(publish_failures);
  s.commands_received = load(commands_received);
  s.commands_accepted = load(commands_accepted);
  s.commands_rejected = load(commands_rejected);
  s.commands_dropped = load(commands_dropped);
  s.commands_unauthenticated = load(commands_unauthenticated);
  s.commands_replayed = load(commands_replayed);
  return s;
}

// ---- telemetry thread ----

void Telemetry::Impl::Run() {
  const int fd = subscription != nullptr ? lcm->getFileno() : -1;
  while (!stop.load(std::memory_order_acquire)) {
    const bool busy = DrainOnce();
    PublishDueRepeats(false);
    // wait for a command (or just the idle period) only when the queues were empty
    pollfd p{fd, POLLIN, 0};
    const int ready = poll(fd >= 0 ? &p : nullptr, fd >= 0 ? 1 : 0, busy ? 0 : config.idle_wait_ms);
    if (ready > 0 && (p.revents & POLLIN) != 0) HandleOne();
  }
  // stop: publish what is still queued; then, after kStopSettle (a subscriber that fell behind
  // in the last burst drains its ring meanwhile), a final health message with the final counters
  // and every event copy still owed
  while (DrainOnce()) {
  }
  if (num_repeats > 0 || have_current) std::this_thread::sleep_for(kStopSettle);
  if (have_current) PublishHealth(&current);
  PublishDueRepeats(true);
}

// One lcm->handle(): a handler that throws (a decoder, an allocation) costs that message, never
// the thread (an exception escaping std::thread would terminate the daemon).
void Telemetry::Impl::HandleOne() noexcept {
  try {
    lcm->handle();
  } catch (...) {
    commands_received.fetch_add(1, std::memory_order_relaxed);
    TellServoInvalid(-1);
    Reject(-1, "message: an exception in the command handler (message dropped)");
  }
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
    PublishSnapshot(&current);
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

void Telemetry::Impl::PublishSnapshot(TelemetrySnapshot* s) {
  const auto publish = [&](std::uint32_t every, const std::string& channel, auto* msg) {
    if (!Due(s->cycle, every)) return;
    Stamp(*s, msg);
    Publish(channel, *msg);
  };
  publish(config.joint_state_every, ch_joint_state, &s->joint_state);
  publish(config.joint_torque_every, ch_joint_torque, &s->joint_torque);
  publish(config.base_state_every, ch_base_state, &s->base_state);
  publish(config.contact_every, ch_contact, &s->contact);
  publish(config.friction_every, ch_friction, &s->friction);
  publish(config.disturbance_every, ch_disturbance, &s->disturbance);
  publish(config.timing_every, ch_timing, &s->timing);
  if (Due(s->cycle, config.health_every)) PublishHealth(s);
}

void Telemetry::Impl::PublishHealth(TelemetrySnapshot* s) {
  Stamp(*s, &s->health);
  SetCounters(Stats(), &s->health);
  Publish(ch_health, s->health);
}

void Telemetry::Impl::PublishDueRepeats(bool all) {
  if (num_repeats == 0) return;
  const Clock::time_point now = Clock::now();
  std::size_t kept = 0;
  for (std::size_t i = 0; i < num_repeats; ++i) {
    Repeat& r = repeats[i];
    if (all || now - r.first >= kRepeatDelays[r.next]) {
      PublishEvent(r.event, false);
      ++r.next;
    }
    if (!all && r.next < kRepeatDelays.size()) repeats[kept++] = r;
  }
  num_repeats = kept;
}

void Telemetry::Impl::PublishEvent(const SafetyEvent& e, bool repeat) {
  if (repeat) {
    if (num_repeats == kMaxRepeats) {  // drop the oldest
      std::move(repeats.begin() + 1, repeats.end(), repeats.begin());
      --num_repeats;
    }
    repeats[num_repeats++] = {e, Clock::now(), 0};
  }
  hyq_lcm::lcmt_hyq_event& m = event;
  ToLcm(e, &m);
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
  e.from = e.to = have_current ? static_cast<ServoMode>(current.health.mode) : ServoMode::kInit;
  e.reason = EventReason::kCommandRejected;
  std::snprintf(e.detail.data(), e.detail.size(), "seq %lld: %s",
                static_cast<long long>(sequence), why);
  PublishEvent(e);
  events_published.fetch_add(1, std::memory_order_relaxed);
}

// Only an authentic, fresh command can reach the servo, even as a refusal: a datagram that is not
// (unsigned, wrong key, stale, replayed) is refused with an event and counted, and the servo never
// hears of it, so that nobody without the key can stop the robot either.
void Telemetry::Impl::RejectUnauthenticated(const char* why) {
  const auto now = std::chrono::steady_clock::now();
  if (last_auth_event != std::chrono::steady_clock::time_point{} &&
      now - last_auth_event < std::chrono::milliseconds(100)) {
    commands_rejected.fetch_add(1, std::memory_order_relaxed);
    ++auth_events_suppressed;
    return;
  }
  // the count goes last and must survive the event's fixed size ("seq -1: " comes first)
  char more[32] = "";
  if (auth_events_suppressed > 0)
    std::snprintf(more, sizeof more, " (+%llu more)",
                  static_cast<unsigned long long>(auth_events_suppressed));
  char detail[kEventDetailSize];
  const int room = static_cast<int>(kEventDetailSize) - 9 - static_cast<int>(std::strlen(more));
  std::snprintf(detail, sizeof detail, "%.*s%s", room, why, more);
  auth_events_suppressed = 0;
  last_auth_event = now;
  Reject(-1, detail);  // counts it
}

void Telemetry::Impl::OnCommand(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) {
  commands_received.fetch_add(1, std::memory_order_relaxed);
  char why[kEventDetailSize];
  hyq_lcm::lcmt_hyq_command msg;
  const std::int64_t now_us = std::chrono::duration_cast<std::chrono::microseconds>(
                                  std::chrono::system_clock::now().time_since_epoch())
                                  .count();
  switch (auth.Check(rbuf->data, rbuf->data_size, now_us, &msg, why, sizeof why)) {
    case AuthVerdict::kOk:
      break;
    case AuthVerdict::kUndecodable:  // the key holder sent garbage: that is a bad command
      TellServoInvalid(-1);
      Reject(-1, why);
      return;
    case AuthVerdict::kStale:
    case AuthVerdict::kReplayed:
      commands_replayed.fetch_add(1, std::memory_order_relaxed);
      RejectUnauthenticated(why);
      return;
    default:
      commands_unauthenticated.fetch_add(1, std::memory_order_relaxed);
      RejectUnauthenticated(why);
      return;
  }
  ServoCommand command;
  if (!validator.Validate(msg, &command, why, sizeof why)) {
    TellServoInvalid(msg.sequence);
    Reject(msg.sequence, why);
    return;
  }
  // rate limit: accepted commands at least 1 / max_rate_hz apart
  const CommandValidator::Clock::time_point now = CommandValidator::Clock::now();
  if (!validator.RateAllows(now, why, sizeof why)) {
    Reject(msg.sequence, why);
    return;
  }
  if (!commands.TryPush(command)) {
    commands_dropped.fetch_add(1, std::memory_order_relaxed);
    Reject(msg.sequence, "queue: the servo is not taking commands (command queue full)");
    return;
  }
  validator.Accepted(now);
  commands_accepted.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace hyq::servo
