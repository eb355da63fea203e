// Helpers shared by the socket drivers (internal to drivers/; the channel headers include it for
// MmsgBuffers, their per-call memory).
#pragma once

#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/uio.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "hal/can_channel.h"

namespace hyq::drivers::internal {

/// Control-message space per received datagram: SCM_TIMESTAMPNS plus SO_RXQ_OVFL.
std::size_t RxControlBytes() noexcept;

/// What the kernel attached to one received message.
struct RxAncillary {
  std::int64_t timestamp_ns = 0;  // 0 when no SCM_TIMESTAMPNS came
  bool have_drops = false;
  std::uint32_t drops = 0;        // SO_RXQ_OVFL: the socket's cumulative drop count
};
RxAncillary ParseRxAncillary(const msghdr& msg) noexcept;

/// The per-call memory of a socket channel, sized at open: `batch` TX and RX messages for
/// sendmmsg / recvmmsg, each with one iovec on its own fixed-size byte slot; the RX messages carry
/// the ancillary space of RxControlBytes() and, for datagram sockets, an IPv4 source address.
/// Holds pointers into itself: neither copied nor moved.
struct MmsgBuffers {
  MmsgBuffers() = default;
  MmsgBuffers(const MmsgBuffers&) = delete;
  MmsgBuffers& operator=(const MmsgBuffers&) = delete;

  /// Sizes every array and points each message at its slot (allocates: configuration time).
  /// With rx_source_addresses, rx_msgs[i] receives the sender's address into rx_from[i].
  void Allocate(std::size_t batch, std::size_t tx_slot_bytes, std::size_t rx_slot_bytes,
                bool rx_source_addresses);
  std::size_t batch() const noexcept { return tx_msgs.size(); }
  std::uint8_t* tx_slot(std::size_t i) noexcept { return tx_bytes.data() + i * tx_slot_bytes; }
  const std::uint8_t* rx_slot(std::size_t i) const noexcept {
    return rx_bytes.data() + i * rx_slot_bytes;
  }

  std::size_t tx_slot_bytes = 0;
  std::size_t rx_slot_bytes = 0;
  std::vector<std::uint8_t> tx_bytes, rx_bytes, rx_control;
  std::vector<iovec> tx_iov, rx_iov;
  std::vector<mmsghdr> tx_msgs, rx_msgs;
  std::vector<sockaddr_in> rx_from;  // empty without rx_source_addresses
};

/// One non-blocking recvmmsg (EINTR retried) into the first `want` (<= batch) RX messages of
/// `b`, after resetting their per-call fields (control and address lengths, flags). Returns the
/// messages received, 0 when none was waiting (EAGAIN), or -1 after an I/O error, which is
/// counted in io_errors with last_errno.
int ReceivePrepared(int fd, MmsgBuffers* b, std::size_t want, hal::CanCounters* counters) noexcept;

/// CLOCK_REALTIME now, ns.
std::int64_t RealtimeNs() noexcept;

/// Turns on SO_TIMESTAMPNS and SO_RXQ_OVFL; throws ChannelError naming `what`.
void EnableRxTimestampsAndDrops(int fd, const char* what);

/// Sends the n prepared messages with one non-blocking sendmmsg (EINTR retried) and does the
/// accounting both socket channels share: *sent and tx_frames grow by what went out; when the
/// kernel takes fewer than n (or EAGAIN / ENOBUFS), kWouldBlock and the frames left of `total`
/// are counted as tx_would_block; other errors give kIoError with last_errno. kOk: all n sent.
hal::CanStatus SendPrepared(int fd, mmsghdr* msgs, std::size_t n, std::size_t total,
                            std::size_t* sent, hal::CanCounters* counters) noexcept;

/// The batching Send both socket channels share: encode(frame, slot) writes one frame into
/// b->tx_slot(slot) and returns its length (0: this channel cannot carry the frame); up to
/// b->batch() frames go out per SendPrepared; a frame that cannot be carried stops the send with
/// kBadFrame after the frames before it went out.
template <class Encode>
hal::CanStatus SendBatched(int fd, std::span<const hal::CanFrame> frames, MmsgBuffers* b,
                           std::size_t* sent, hal::CanCounters* counters,
                           Encode&& encode) noexcept {
  const std::size_t batch = b->batch();
  std::size_t next = 0;
  while (next < frames.size()) {
    std::size_t n = 0;
    bool bad = false;
    while (n < batch && next + n < frames.size()) {
      const std::size_t bytes = encode(frames[next + n], n);
      if (bytes == 0) {
        bad = true;
        break;
      }
      b->tx_iov[n].iov_len = bytes;
      ++n;
    }
    if (n > 0) {
      const hal::CanStatus st =
          SendPrepared(fd, b->tx_msgs.data(), n, frames.size(), sent, counters);
      if (st != hal::CanStatus::kOk) return st;
      next += n;
    }
    if (bad) {
      ++counters->bad_frames;
      return hal::CanStatus::kBadFrame;
    }
  }
  return hal::CanStatus::kOk;
}

/// Sets a socket option to an int, throwing ChannelError with `what` on failure.
void SetIntOption(int fd, int level, int option, int value, const char* what);

}  // namespace hyq::drivers::internal
