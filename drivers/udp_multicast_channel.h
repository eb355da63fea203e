// Virtual CAN over IPv4 UDP multicast, wire-compatible with python-can's `udp_multicast`
// interface: one datagram per frame, the msgpack map of drivers/msgpack_frame.h. Every channel on
// the same group and port is on the same bus; different groups or ports are independent buses.
//
// Two sockets per channel: a receiver bound to group:port and joined to the group (as python-can
// does, SO_REUSEADDR so any number of processes share the bus), and a sender connected to
// group:port from its own ephemeral port. Multicast loopback delivers our own datagrams back to
// us; the receiver drops those whose source address and port are the sender's, so python-can (and
// any other channel, in this process or another) still hears them and we do not.
//
// Receive times are kernel timestamps (SO_TIMESTAMPNS, CLOCK_REALTIME); datagrams the kernel
// dropped because our receive queue was full are counted from SO_RXQ_OVFL into rx_overflow.
// Datagrams that do not decode, or FD frames on a channel opened with fd = false, are counted in
// bad_frames and never passed up. Error frames (python-can's is_error_frame) are passed up with
// CanFrame::kError and counted in error_frames.
#pragma once

#include <netinet/in.h>

#include <cstdint>
#include <string>

#include "drivers/socket_util.h"
#include "hal/can_channel.h"

namespace hyq::drivers {

inline constexpr const char* kDefaultUdpGroup = "239.74.163.2";
inline constexpr std::uint16_t kDefaultUdpPort = 43113;

struct UdpMulticastOptions {
  std::string group = kDefaultUdpGroup;  // IPv4 multicast address, 224.0.0.0/4
  std::uint16_t port = kDefaultUdpPort;
  int ttl = 0;                  // IP_MULTICAST_TTL: 0 keeps the bus on this host
  std::string interface_address;  // IPv4 address of the interface to use; empty: the route's
  bool fd = true;               // carry CAN FD frames (python-can's `fd` argument)
  std::size_t batch = 64;       // frames per sendmmsg/recvmmsg call
  int receive_buffer_bytes = 0; // SO_RCVBUF; 0 keeps the kernel default
  std::string name;             // for logs; empty: "udp:<group>:<port>"
};

class UdpMulticastChannel final : public hal::CanChannel {
 public:
  /// Opens both sockets and allocates every buffer. Throws ChannelError naming the option.
  explicit UdpMulticastChannel(const UdpMulticastOptions& options);
  ~UdpMulticastChannel() override;
  UdpMulticastChannel(const UdpMulticastChannel&) = delete;
  UdpMulticastChannel& operator=(const UdpMulticastChannel&) = delete;

  hal::CanStatus Send(std::span<const hal::CanFrame> frames, std::size_t* sent) noexcept override;
  hal::CanStatus Receive(std::span<hal::CanFrame> out, std::size_t* received) noexcept override;
  const hal::CanCounters& counters() const noexcept override { return counters_; }
  bool fd_enabled() const noexcept override { return options_.fd; }
  std::string_view name() const noexcept override { return options_.name; }

  /// Fault injection for tests and the device emulator: while on, Send refuses with kBusOff and
  /// bus_state reads kBusOff (bus_off_events counts each entry); received frames still arrive.
  void SetSimulatedBusOff(bool on) noexcept;

  /// The sender's source port (what our echoes carry); the receiver's port is options().port.
  std::uint16_t sender_port() const noexcept;
  const UdpMulticastOptions& options() const noexcept { return options_; }

  /// The receiving socket, for poll()/epoll() by callers that want to sleep until datagrams
  /// arrive; -1 when closed. Readable also for our own echoes, which Receive() drops.
  int poll_fd() const noexcept override { return rx_fd_; }

  /// Closes both sockets; later calls return kClosed.
  void Close() noexcept;

 private:
  UdpMulticastOptions options_;
  int rx_fd_ = -1;
  int tx_fd_ = -1;
  sockaddr_in tx_local_{};  // where our own datagrams come from
  bool bus_off_ = false;
  hal::CanCounters counters_;

  internal::MmsgBuffers mmsg_;  // all per-call memory, sized at open
};

}  // namespace hyq::drivers
