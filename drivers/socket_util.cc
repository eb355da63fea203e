#include "drivers/socket_util.h"

#include <sys/socket.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <string>

#include "drivers/channel_error.h"

namespace hyq::drivers {

std::string SystemErrorText(const std::string& what, int err) {
  return what + ": " + std::strerror(err);
}

namespace internal {

std::size_t RxControlBytes() noexcept {
  return CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t));
}

RxAncillary ParseRxAncillary(const msghdr& msg) noexcept {
  RxAncillary a;
  if ((msg.msg_flags & MSG_CTRUNC) != 0 && msg.msg_controllen == 0) return a;
  // CMSG_FIRSTHDR/CMSG_NXTHDR take a non-const msghdr and use C casts inside
  msghdr* m = const_cast<msghdr*>(&msg);
  for (cmsghdr* c = CMSG_FIRSTHDR(m); c != nullptr; c = CMSG_NXTHDR(m, c)) {
    if (c->cmsg_level != SOL_SOCKET) continue;
    if (c->cmsg_type == SCM_TIMESTAMPNS && c->cmsg_len >= CMSG_LEN(sizeof(timespec))) {
      timespec ts;
      std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
      a.timestamp_ns = std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
    } else if (c->cmsg_type == SO_RXQ_OVFL && c->cmsg_len >= CMSG_LEN(sizeof(std::uint32_t))) {
      std::memcpy(&a.drops, CMSG_DATA(c), sizeof a.drops);
      a.have_drops = true;
    }
  }
  return a;
}

void MmsgBuffers::Allocate(std::size_t batch, std::size_t tx_slot, std::size_t rx_slot,
                           bool rx_source_addresses) {
  tx_slot_bytes = tx_slot;
  rx_slot_bytes = rx_slot;
  tx_bytes.assign(batch * tx_slot, 0);
  rx_bytes.assign(batch * rx_slot, 0);
  rx_control.assign(batch * RxControlBytes(), 0);
  tx_iov.assign(batch, iovec{});
  rx_iov.assign(batch, iovec{});
  tx_msgs.assign(batch, mmsghdr{});
  rx_msgs.assign(batch, mmsghdr{});
  rx_from.assign(rx_source_addresses ? batch : 0, sockaddr_in{});
  for (std::size_t i = 0; i < batch; ++i) {
    tx_iov[i].iov_base = tx_bytes.data() + i * tx_slot;
    tx_msgs[i].msg_hdr.msg_iov = &tx_iov[i];
    tx_msgs[i].msg_hdr.msg_iovlen = 1;
    rx_iov[i].iov_base = rx_bytes.data() + i * rx_slot;
    rx_iov[i].iov_len = rx_slot;
    rx_msgs[i].msg_hdr.msg_iov = &rx_iov[i];
    rx_msgs[i].msg_hdr.msg_iovlen = 1;
    if (rx_source_addresses) rx_msgs[i].msg_hdr.msg_name = &rx_from[i];
    rx_msgs[i].msg_hdr.msg_control = rx_control.data() + i * RxControlBytes();
  }
}

int ReceivePrepared(int fd, MmsgBuffers* b, std::size_t want, hal::CanCounters* counters) noexcept {
  const socklen_t name_bytes = b->rx_from.empty() ? 0 : socklen_t{sizeof(sockaddr_in)};
  for (std::size_t i = 0; i < want; ++i) {
    msghdr& h = b->rx_msgs[i].msg_hdr;
    h.msg_namelen = name_bytes;
    h.msg_controllen = RxControlBytes();
    h.msg_flags = 0;
  }
  int r;
  do {
    r = recvmmsg(fd, b->rx_msgs.data(), static_cast<unsigned>(want), MSG_DONTWAIT, nullptr);
  } while (r < 0 && errno == EINTR);
  if (r >= 0) return r;
  if (errno == EAGAIN || errno == EWOULDBLOCK) return 0;
  counters->last_errno = errno;
  ++counters->io_errors;
  return -1;
}

std::int64_t RealtimeNs() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

void SetIntOption(int fd, int level, int option, int value, const char* what) {
  if (setsockopt(fd, level, option, &value, sizeof value) != 0)
    throw ChannelError(SystemErrorText(std::string("setsockopt ") + what, errno));
}

void EnableRxTimestampsAndDrops(int fd, const char* what) {
  SetIntOption(fd, SOL_SOCKET, SO_TIMESTAMPNS, 1, (std::string(what) + " SO_TIMESTAMPNS").c_str());
  SetIntOption(fd, SOL_SOCKET, SO_RXQ_OVFL, 1, (std::string(what) + " SO_RXQ_OVFL").c_str());
}

hal::CanStatus SendPrepared(int fd, mmsghdr* msgs, std::size_t n, std::size_t total,
                            std::size_t* sent, hal::CanCounters* counters) noexcept {
  int r;
  do {
    r = sendmmsg(fd, msgs, static_cast<unsigned>(n), MSG_DONTWAIT);
  } while (r < 0 && errno == EINTR);
  if (r < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS) {
      counters->tx_would_block += total - *sent;
      return hal::CanStatus::kWouldBlock;
    }
    counters->last_errno = errno;
    ++counters->io_errors;
    return hal::CanStatus::kIoError;
  }
  const auto done = static_cast<std::size_t>(r);
  *sent += done;
  counters->tx_frames += done;
  if (done < n) {
    counters->tx_would_block += total - *sent;
    return hal::CanStatus::kWouldBlock;
  }
  return hal::CanStatus::kOk;
}

}  // namespace internal
}  // namespace hyq::drivers
