// One CAN channel: the interface every transport implements (drivers/socketcan, drivers/virtual)
// and the HAL uses, as lely puts io2/linux/can_chan.c and io2/vcan.c behind io2/can.h.
//
// The per-cycle calls are non-blocking and noexcept and return a status; opening a channel is
// configuration-time work done by each driver's constructor/factory, which may throw.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

namespace hyq::hal {

inline constexpr std::size_t kCanClassicMaxData = 8;
inline constexpr std::size_t kCanFdMaxData = 64;

/// A classic or FD frame. `len` is the payload length in bytes (0–8 classic; 0–8, 12, 16, 20,
/// 24, 32, 48, 64 FD), not the DLC code.
struct CanFrame {
  enum Flags : std::uint8_t {
    kExtendedId = 1u << 0,   // 29-bit identifier
    kRemote = 1u << 1,       // RTR (classic only)
    kError = 1u << 2,        // an error frame reported by the controller/driver
    kFd = 1u << 3,           // CAN FD frame
    kBitrateSwitch = 1u << 4,
    kErrorStateIndicator = 1u << 5,
  };
  std::uint32_t id = 0;
  std::uint8_t len = 0;
  std::uint8_t flags = 0;
  std::array<std::uint8_t, kCanFdMaxData> data{};
  std::int64_t timestamp_ns = 0;  // receive time, CLOCK_REALTIME ns (kernel timestamp when known)

  bool is_fd() const noexcept { return (flags & kFd) != 0; }
  bool is_error() const noexcept { return (flags & kError) != 0; }
  bool is_extended() const noexcept { return (flags & kExtendedId) != 0; }
};

enum class [[nodiscard]] CanStatus : std::uint8_t {
  kOk,
  kWouldBlock,   // TX queue full: nothing more could be queued this call
  kBusOff,       // the controller is bus-off
  kBadFrame,     // a frame the channel cannot carry (FD on a classic channel, bad length/id)
  kIoError,      // the OS call failed (see counters().last_errno)
  kClosed,
};

const char* ToString(CanStatus s) noexcept;

enum class BusState : std::uint8_t { kErrorActive, kErrorWarning, kErrorPassive, kBusOff };

/// Counters every channel keeps; monotonically increasing except `bus_state`.
struct CanCounters {
  std::uint64_t tx_frames = 0;
  std::uint64_t rx_frames = 0;
  std::uint64_t tx_would_block = 0;   // frames not queued because the TX queue was full
  std::uint64_t rx_overflow = 0;      // frames lost before we read them (kernel/socket drops)
  std::uint64_t error_frames = 0;
  std::uint64_t bus_off_events = 0;
  std::uint64_t bad_frames = 0;       // malformed input dropped (never passed up)
  std::uint64_t io_errors = 0;
  int last_errno = 0;
  BusState bus_state = BusState::kErrorActive;
};

class CanChannel {
 public:
  virtual ~CanChannel() = default;

  /// Queues up to frames.size() frames without blocking; *sent says how many were queued.
  virtual CanStatus Send(std::span<const CanFrame> frames, std::size_t* sent) noexcept = 0;

  /// Drains up to out.size() received frames without blocking; *received says how many.
  /// Returns kOk with *received == 0 when nothing is pending.
  virtual CanStatus Receive(std::span<CanFrame> out, std::size_t* received) noexcept = 0;

  virtual const CanCounters& counters() const noexcept = 0;
  /// A file descriptor that poll() reports readable when frames wait, or −1 when the channel
  /// has none (in-memory and replay channels): for set-up and non-real-time waiting loops.
  virtual int poll_fd() const noexcept { return -1; }
  /// Whether frames are known to wait, found without a system call (shared memory); false when
  /// the channel cannot tell that way (sockets: poll() their fd). Lets a lock-step waiter spin
  /// briefly instead of sleeping (SpinForFrames).
  virtual bool frames_pending() const noexcept { return false; }
  /// Whether frames_pending() can tell (true for shared memory).
  virtual bool tells_pending() const noexcept { return false; }
  /// A waiter looks at frames_pending() without sleeping while `on` (SpinForFrames): a writer
  /// need not wake it. After `on` = false the waiter looks once more before it sleeps.
  virtual void SetWaiterSpinning(bool /*on*/) noexcept {}
  virtual bool fd_enabled() const noexcept = 0;
  virtual std::string_view name() const noexcept = 0;
};

}  // namespace hyq::hal
