#include "drivers/udp_multicast_channel.h"

#include <arpa/inet.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <string>

#include "drivers/channel_error.h"
#include "drivers/msgpack_frame.h"
#include "drivers/socket_util.h"

namespace hyq::drivers {
namespace {

using hal::CanFrame;
using hal::CanStatus;

// python-can reads up to 4096 bytes per datagram; anything longer is not one of its frames.
constexpr std::size_t kRxDatagramBytes = 4096;

in_addr ParseIpv4(const std::string& text, const char* what) {
  in_addr a{};
  if (inet_pton(AF_INET, text.c_str(), &a) != 1)
    throw ChannelError(std::string("udp channel: ") + what + ": expected an IPv4 address, found '" +
                       text + "'");
  return a;
}

}  // namespace

UdpMulticastChannel::UdpMulticastChannel(const UdpMulticastOptions& options) : options_(options) {
  if (options_.name.empty())
    options_.name = "udp:" + options_.group + ":" + std::to_string(options_.port);
  const in_addr group = ParseIpv4(options_.group, "group");
  if ((ntohl(group.s_addr) >> 28) != 0xE)
    throw ChannelError("udp channel: group: expected an IPv4 multicast address (224.0.0.0/4), "
                       "found '" + options_.group + "'");
  if (options_.ttl < 0 || options_.ttl > 255)
    throw ChannelError("udp channel: ttl: expected 0..255, found " + std::to_string(options_.ttl));
  if (options_.batch == 0 || options_.batch > 1024)
    throw ChannelError("udp channel: batch: expected 1..1024, found " +
                       std::to_string(options_.batch));
  in_addr iface{};
  iface.s_addr = htonl(INADDR_ANY);
  if (!options_.interface_address.empty())
    iface = ParseIpv4(options_.interface_address, "interface address");

  sockaddr_in dest{};
  dest.sin_family = AF_INET;
  dest.sin_port = htons(options_.port);
  dest.sin_addr = group;

  const auto fail = [this](const std::string& what, int err) {
    const std::string msg = SystemErrorText(options_.name + ": " + what, err);
    Close();
    throw ChannelError(msg);
  };

  // receiver: bound to group:port, joined, shared with every other member on this host
  rx_fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (rx_fd_ < 0) fail("socket(AF_INET, SOCK_DGRAM)", errno);
  try {
    internal::SetIntOption(rx_fd_, SOL_SOCKET, SO_REUSEADDR, 1, "SO_REUSEADDR");
    internal::EnableRxTimestampsAndDrops(rx_fd_, "udp receiver");
    if (options_.receive_buffer_bytes > 0)
      internal::SetIntOption(rx_fd_, SOL_SOCKET, SO_RCVBUF, options_.receive_buffer_bytes,
                             "SO_RCVBUF");
    // only this socket's groups, even when bound to the wildcard elsewhere on the port
    internal::SetIntOption(rx_fd_, IPPROTO_IP, IP_MULTICAST_ALL, 0, "IP_MULTICAST_ALL");
  } catch (const ChannelError& e) {
    const std::string msg = options_.name + ": " + e.what();
    Close();
    throw ChannelError(msg);
  }
  if (bind(rx_fd_, reinterpret_cast<const sockaddr*>(&dest), sizeof dest) != 0)
    fail("bind to " + options_.group + ":" + std::to_string(options_.port), errno);
  ip_mreq join{};
  join.imr_multiaddr = group;
  join.imr_interface = iface;
  if (setsockopt(rx_fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &join, sizeof join) != 0)
    fail("join multicast group " + options_.group +
             " (no multicast route? e.g. `ip route add 224.0.0.0/4 dev lo`, or give iface=)",
         errno);

  // sender: its own ephemeral port, connected to the group, loopback on so the host hears it
  tx_fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (tx_fd_ < 0) fail("socket(AF_INET, SOCK_DGRAM)", errno);
  const int ttl = options_.ttl;
  const int loop = 1;
  if (setsockopt(tx_fd_, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl) != 0)
    fail("IP_MULTICAST_TTL", errno);
  if (setsockopt(tx_fd_, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof loop) != 0)
    fail("IP_MULTICAST_LOOP", errno);
  // connect() picks an ephemeral port, and the bus ports (431xx) lie in Linux's ephemeral range:
  // a sender that drew another bus's port without SO_REUSEADDR made that bus's receiver fail
  // to bind ("Address already in use", the rare hyq-sim/hyq-servod start-up failure)
  const int reuse = 1;
  if (setsockopt(tx_fd_, SOL_SOCKET, SO_REUSEADDR, &reuse, sizeof reuse) != 0)
    fail("SO_REUSEADDR", errno);
  if (!options_.interface_address.empty() &&
      setsockopt(tx_fd_, IPPROTO_IP, IP_MULTICAST_IF, &iface, sizeof iface) != 0)
    fail("IP_MULTICAST_IF " + options_.interface_address, errno);
  if (connect(tx_fd_, reinterpret_cast<const sockaddr*>(&dest), sizeof dest) != 0)
    fail("connect sender to " + options_.group + ":" + std::to_string(options_.port) +
             " (no multicast route? e.g. `ip route add 224.0.0.0/4 dev lo`, or give iface=)",
         errno);
  socklen_t len = sizeof tx_local_;
  if (getsockname(tx_fd_, reinterpret_cast<sockaddr*>(&tx_local_), &len) != 0)
    fail("getsockname", errno);

  // every buffer the per-cycle calls use
  mmsg_.Allocate(options_.batch, kMaxDatagramBytes, kRxDatagramBytes,
                 /*rx_source_addresses=*/true);
}

UdpMulticastChannel::~UdpMulticastChannel() { Close(); }

void UdpMulticastChannel::Close() noexcept {
  if (rx_fd_ >= 0) close(rx_fd_);
  if (tx_fd_ >= 0) close(tx_fd_);
  rx_fd_ = tx_fd_ = -1;
}

std::uint16_t UdpMulticastChannel::sender_port() const noexcept {
  return ntohs(tx_local_.sin_port);
}

void UdpMulticastChannel::SetSimulatedBusOff(bool on) noexcept {
  if (on && !bus_off_) ++counters_.bus_off_events;
  bus_off_ = on;
  counters_.bus_state = on ? hal::BusState::kBusOff : hal::BusState::kErrorActive;
}

CanStatus UdpMulticastChannel::Send(std::span<const CanFrame> frames, std::size_t* sent) noexcept {
  *sent = 0;
  if (tx_fd_ < 0) return CanStatus::kClosed;
  if (bus_off_) return CanStatus::kBusOff;
  const double now_s = static_cast<double>(internal::RealtimeNs()) * 1e-9;
  return internal::SendBatched(
      tx_fd_, frames, &mmsg_, sent, &counters_,
      [this, now_s](const CanFrame& f, std::size_t slot) -> std::size_t {
        const std::span<std::uint8_t> buf(mmsg_.tx_slot(slot), kMaxDatagramBytes);
        return (f.is_fd() && !options_.fd) ? 0 : EncodeFrameDatagram(f, now_s, buf);
      });
}

CanStatus UdpMulticastChannel::Receive(std::span<CanFrame> out, std::size_t* received) noexcept {
  *received = 0;
  if (rx_fd_ < 0) return CanStatus::kClosed;
  while (*received < out.size()) {
    const std::size_t want = std::min(options_.batch, out.size() - *received);
    const int r = internal::ReceivePrepared(rx_fd_, &mmsg_, want, &counters_);
    if (r < 0) return CanStatus::kIoError;
    for (int i = 0; i < r; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const msghdr& h = mmsg_.rx_msgs[k].msg_hdr;
      const internal::RxAncillary anc = internal::ParseRxAncillary(h);
      if (anc.have_drops && anc.drops > counters_.rx_overflow) counters_.rx_overflow = anc.drops;
      const sockaddr_in& from = mmsg_.rx_from[k];
      const bool own = from.sin_port == tx_local_.sin_port &&
                       (tx_local_.sin_addr.s_addr == htonl(INADDR_ANY) ||
                        from.sin_addr.s_addr == tx_local_.sin_addr.s_addr);
      if (own) continue;
      CanFrame& f = out[*received];
      const std::size_t bytes = mmsg_.rx_msgs[k].msg_len;
      const bool truncated = (h.msg_flags & MSG_TRUNC) != 0;
      if (truncated || DecodeFrameDatagram({mmsg_.rx_slot(k), bytes}, &f) != MsgpackError::kOk ||
          (f.is_fd() && !options_.fd)) {
        ++counters_.bad_frames;
        continue;
      }
      f.timestamp_ns = anc.timestamp_ns != 0 ? anc.timestamp_ns : internal::RealtimeNs();
      if (f.is_error()) ++counters_.error_frames;
      ++counters_.rx_frames;
      ++*received;
    }
    if (static_cast<std::size_t>(r) < want) break;
  }
  return CanStatus::kOk;
}

}  // namespace hyq::drivers
