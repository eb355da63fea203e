// Virtual CAN in shared memory, for a master and its devices on one machine (hyq-servod and
// hyq-sim in lock-step): frames cross through single-producer single-consumer rings in a segment
// under /dev/shm, without a system call per frame.
//
// A group (one segment, "/hyq-can.GROUP") holds up to kShmMaxBuses buses, each claimed by name
// by whichever side opens it first; each bus has a ring towards the devices and one towards the
// master. A reader that has drained its rings sleeps in poll() on the group's doorbell for its
// side (a FIFO beside the segment, poll_fd()), which a writer rings only on the doorbell's
// 0 → 1 edge: one byte per hand-off, shared by every bus of the group, so a cycle of four buses
// costs one write and one read each way, instead of a datagram per frame and per listener.
//
// The doorbell's rule (no lost wake-up): a writer publishes its frames, then, unless the reader
// says it is spinning (hal::SpinForFrames: looking without sleeping, and once more after it
// stops), sets the bell and, if it was clear, writes a byte. A reader that finds all its rings empty with the bell set
// first empties the FIFO, then clears the bell, then looks at the rings again and rings the bell
// itself if frames came in between. So whenever frames wait, the bell is set and either a byte
// is in the FIFO or the reader has not yet cleared it.
//
// Point to point: one master and one devices side per bus (a side's owner is its process id; a
// second live opener is refused). No listeners: python-can tools and hyq-candump use the UDP bus
// (udp_multicast_channel.h), which stays the interoperable transport. The devices side (the
// simulator) removes the segment and its FIFOs when it closes; the master side leaves them.
// Receive times are the reader's CLOCK_REALTIME when it takes the frame.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "hal/can_channel.h"

namespace hyq::drivers {

inline constexpr std::size_t kShmMaxBuses = 8;
inline constexpr std::size_t kShmRingFrames = 512;  // per direction and bus: 512 × 80 B

enum class ShmSide : std::uint8_t { kMaster, kDevices };

struct ShmOptions {
  std::string group;        // [A-Za-z0-9_.-], 1..48 characters: the segment /dev/shm/hyq-can.GROUP
  std::string bus;          // [A-Za-z0-9_.-], 1..31 characters
  ShmSide side = ShmSide::kMaster;
  bool fd = true;           // carry CAN FD frames
  std::string name;         // for logs; empty: "shm:GROUP:BUS"
};

namespace internal {
struct ShmSegment;
}

class ShmChannel final : public hal::CanChannel {
 public:
  /// Opens (or creates) the group's segment and FIFOs and claims the bus's side. Throws
  /// ChannelError naming the spec: a bad name, a segment of another layout, the side held by
  /// another live process, no free bus slot, or an OS call that failed.
  explicit ShmChannel(const ShmOptions& options);
  ~ShmChannel() override;
  ShmChannel(const ShmChannel&) = delete;
  ShmChannel& operator=(const ShmChannel&) = delete;

  hal::CanStatus Send(std::span<const hal::CanFrame> frames, std::size_t* sent) noexcept override;
  hal::CanStatus Receive(std::span<hal::CanFrame> out, std::size_t* received) noexcept override;
  const hal::CanCounters& counters() const noexcept override { return counters_; }
  bool fd_enabled() const noexcept override { return options_.fd; }
  std::string_view name() const noexcept override { return options_.name; }
  /// The group's doorbell for this side: readable while the bell is rung.
  int poll_fd() const noexcept override { return bell_rx_fd_; }
  /// Frames wait for this side on any bus of the group (no system call).
  bool frames_pending() const noexcept override { return segment_ != nullptr && !AllIncomingEmpty(); }
  bool tells_pending() const noexcept override { return true; }
  /// While on, writers to this side do not ring its bell (its reader is looking).
  void SetWaiterSpinning(bool on) noexcept override;

  const ShmOptions& options() const noexcept { return options_; }
  /// Doorbell bytes written and read by this channel (for the transport's accounting).
  std::uint64_t bells_rung() const noexcept { return bells_rung_; }
  std::uint64_t bells_taken() const noexcept { return bells_taken_; }

 private:
  ShmOptions options_;
  internal::ShmSegment* segment_ = nullptr;
  std::size_t slot_ = 0;
  int bell_rx_fd_ = -1;  // our side's FIFO (read)
  int bell_tx_fd_ = -1;  // the other side's FIFO (write)
  std::string segment_name_, bell_rx_path_, bell_tx_path_;
  hal::CanCounters counters_;
  std::uint64_t bells_rung_ = 0, bells_taken_ = 0;

  bool AllIncomingEmpty() const noexcept;
  /// Rings the other side's bell unless it is set or that side's reader spins.
  void Ring() noexcept;
  /// Empties our FIFO, clears our bell, and rings it again if frames came meanwhile (the rule
  /// above).
  void TakeBell() noexcept;
};

}  // namespace hyq::drivers
