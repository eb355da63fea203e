// A channel wrapper that lets a caller see whether the TPDOs answering the last SYNC have arrived
// before the HAL's Read takes them: Pump() moves pending frames into a fixed buffer and counts
// the TPDOs that carry the counter of the last SYNC sent through it (a late answer to an earlier
// SYNC is not an answer to this one); Receive() hands the HAL exactly the same frames, in order. Used by the daemon's
// lock-step clock (servo/runtime/servo_runner.h) and the virtual-bus test rig. Never allocates after
// construction. A simulated plant's clock frame (hal::PlantClock: the plant ran periods without
// the master) is the lock-step clock's, not the HAL's: both paths take it out and keep its count.
#pragma once

#include <bitset>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "hal/can_channel.h"

namespace hyq::hal {

class LockstepChannel : public CanChannel {
 public:
  static constexpr std::size_t kBufferFrames = 4096;

  explicit LockstepChannel(std::unique_ptr<CanChannel> inner);
  CanStatus Send(std::span<const CanFrame> frames, std::size_t* sent) noexcept override;
  CanStatus Receive(std::span<CanFrame> out, std::size_t* received) noexcept override;
  const CanCounters& counters() const noexcept override { return inner_->counters(); }
  bool fd_enabled() const noexcept override { return inner_->fd_enabled(); }
  std::string_view name() const noexcept override { return inner_->name(); }
  int poll_fd() const noexcept override { return inner_->poll_fd(); }
  bool frames_pending() const noexcept override { return inner_->frames_pending(); }
  bool tells_pending() const noexcept override { return inner_->tells_pending(); }
  void SetWaiterSpinning(bool on) noexcept override { inner_->SetWaiterSpinning(on); }
  CanChannel& inner() noexcept { return *inner_; }

  /// Moves pending frames into the buffer; returns the TPDOs buffered and not yet received that
  /// answer the last SYNC sent (all TPDOs before the first SYNC).
  int Pump() noexcept;
  /// Whether a TPDO from `node` is among them (per device, so that a stray TPDO of another
  /// node cannot stand in for a device's answer).
  bool has_tpdo_from(std::uint8_t node) const noexcept { return node < 128 && tpdo_nodes_[node]; }
  /// Frames buffered by Pump and not yet received.
  std::size_t buffered() const noexcept { return tail_ - head_; }
  /// The most steps the simulated plant on this bus says it took without the master (its
  /// PlantClock frames; 0 without any), whichever path read them.
  std::uint32_t plant_stalled_steps() const noexcept { return plant_stalled_steps_; }

 private:
  std::unique_ptr<CanChannel> inner_;
  std::vector<CanFrame> buffer_;
  std::size_t head_ = 0, tail_ = 0;
  int tpdos_ = 0;
  std::bitset<128> tpdo_nodes_;  // CANopen node ids with a buffered TPDO
  std::uint8_t sync_counter_ = 0;  // of the last SYNC sent; 0: none yet
  std::uint32_t plant_stalled_steps_ = 0;

  // removes the plant's clock frames from frames[0, n) (keeping its count); returns the rest's n
  std::size_t TakePlantClock(CanFrame* frames, std::size_t n) noexcept;
};

class Hal;

/// How long a lock-step waiter looks for frames on channels that can tell without a system call
/// (CanChannel::frames_pending, shared memory) before it sleeps in poll(): the other side's work
/// per hand-off is 20-50 µs, a sleep and a wake-up cost about as much again.
inline constexpr std::int64_t kLockstepSpinNs = 150'000;

/// Looks at `channels` (frames_pending) until one has frames or `budget_ns` has passed,
/// yielding the CPU between looks (on a machine with a core for each side the yield returns at
/// once; on a busy one the other side runs). Returns whether frames wait. Call it only when a
/// channel tells_pending(): others are not looked at.
bool SpinForFrames(std::span<CanChannel* const> channels, std::int64_t budget_ns) noexcept;

/// After a SYNC (ppoll on the channels' descriptors; lock-step, and the real-time cycle's answer
/// wait): waits until every device of `hal`
/// that owes an input has answered on its own bus (one channel per bus, in the HAL's order; a
/// stray TPDO of another node does not count), at most `timeout_ns` of wall time; when no device
/// owes one (all below SAFE-OP), `idle_ns` for NMT answers and heartbeats. Returns whether they
/// did (true when none was owed).
bool WaitForLockstepInputs(const Hal& hal, std::span<LockstepChannel* const> channels,
                           std::int64_t timeout_ns, std::int64_t idle_ns) noexcept;

}  // namespace hyq::hal
