// SocketCAN raw channel (Linux AF_CAN/CAN_RAW) on canN / vcanN.
//
// - FD: with FdMode::kAuto CAN_RAW_FD_FRAMES is switched on when the interface MTU is CANFD_MTU
//   (72); kRequire throws when it is not; kOff keeps the socket classic. A classic channel refuses
//   FD frames with kBadFrame.
// - Errors: CAN_RAW_ERR_FILTER = CAN_ERR_MASK, so every error frame the controller reports comes
//   up as a CanFrame with kError (id = error class bits, data = the 8 error bytes) and is counted
//   in error_frames. CAN_ERR_BUSOFF sets bus_state = kBusOff (counted in bus_off_events) and Send
//   returns kBusOff until CAN_ERR_RESTARTED or a controller "back to error active" report;
//   CAN_ERR_CRTL warning/passive reports set kErrorWarning / kErrorPassive.
// - Timestamps: SO_TIMESTAMPNS (kernel receive time, CLOCK_REALTIME).
// - Overflow: rx_overflow = the socket's cumulative drop count (SO_RXQ_OVFL) plus the
//   controller's CAN_ERR_CRTL_RX_OVERFLOW reports.
// - Batches: sendmmsg / recvmmsg, non-blocking. A full TX queue (EAGAIN/ENOBUFS) is kWouldBlock.
// We do not receive our own frames (CAN_RAW_RECV_OWN_MSGS stays off); other sockets on the host
// do (CAN_RAW_LOOPBACK stays on).
#pragma once

#include <string>

#include "drivers/socket_util.h"
#include "hal/can_channel.h"

namespace hyq::drivers {

enum class FdMode { kAuto, kRequire, kOff };

struct SocketCanOptions {
  std::string interface;          // can0, vcan1, ...
  FdMode fd = FdMode::kAuto;
  std::size_t batch = 64;         // frames per sendmmsg/recvmmsg call
  int receive_buffer_bytes = 0;   // SO_RCVBUF; 0 keeps the kernel default
  std::string name;               // empty: "socketcan:<interface>"
};

class SocketCanChannel final : public hal::CanChannel {
 public:
  /// Opens and binds the socket, allocates all buffers. Throws ChannelError naming the
  /// interface (no such interface, not a CAN interface, no FD, no AF_CAN in this kernel, ...).
  explicit SocketCanChannel(const SocketCanOptions& options);
  ~SocketCanChannel() override;
  SocketCanChannel(const SocketCanChannel&) = delete;
  SocketCanChannel& operator=(const SocketCanChannel&) = delete;

  hal::CanStatus Send(std::span<const hal::CanFrame> frames, std::size_t* sent) noexcept override;
  hal::CanStatus Receive(std::span<hal::CanFrame> out, std::size_t* received) noexcept override;
  const hal::CanCounters& counters() const noexcept override { return counters_; }
  bool fd_enabled() const noexcept override { return fd_; }
  std::string_view name() const noexcept override { return options_.name; }

  /// The socket, for poll()/epoll() by callers that want to sleep until frames arrive (tools,
  /// the device emulator); -1 when closed. Do not read from it directly.
  int poll_fd() const noexcept override { return sock_; }
  void Close() noexcept;

 private:
  void OnErrorFrame(const hal::CanFrame& f) noexcept;

  SocketCanOptions options_;
  int sock_ = -1;
  bool fd_ = false;
  hal::CanCounters counters_;
  std::uint64_t socket_drops_ = 0;          // SO_RXQ_OVFL, cumulative
  std::uint64_t controller_overflows_ = 0;  // CAN_ERR_CRTL_RX_OVERFLOW reports
  internal::MmsgBuffers mmsg_;              // all per-call memory, sized at open
};

/// True when this kernel can open AF_CAN raw sockets (false here: CONFIG_CAN is unset).
bool KernelHasSocketCan() noexcept;

}  // namespace hyq::drivers
