// Helpers shared by the socket drivers (internal to drivers/).
#pragma once

#include <sys/socket.h>
#include <sys/uio.h>

#include <cstddef>
#include <cstdint>
#include <span>

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
/// message slot `slot` and returns its length (0: this channel cannot carry the frame); up to
/// `batch` frames go out per SendPrepared; a frame that cannot be carried stops the send with
/// kBadFrame after the frames before it went out.
template <class Encode>
hal::CanStatus SendBatched(int fd, std::span<const hal::CanFrame> frames, std::size_t batch,
                           mmsghdr* msgs, iovec* iov, std::size_t* sent,
                           hal::CanCounters* counters, Encode&& encode) noexcept {
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
      iov[n].iov_len = bytes;
      ++n;
    }
    if (n > 0) {
      const hal::CanStatus st = SendPrepared(fd, msgs, n, frames.size(), sent, counters);
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
