#include "drivers/socketcan_channel.h"

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "drivers/channel_error.h"
#include "drivers/msgpack_frame.h"
#include "drivers/socket_util.h"

namespace hyq::drivers {
namespace {

using hal::BusState;
using hal::CanFrame;
using hal::CanStatus;

constexpr std::size_t kSlotBytes = sizeof(canfd_frame);

// CanFrame -> struct can_frame / canfd_frame in `slot`; returns the MTU to write, 0 if invalid.
std::size_t ToKernel(const CanFrame& f, std::uint8_t* slot) noexcept {
  if (!IsValidFrame(f)) return 0;
  canfd_frame k{};
  k.can_id = f.id;
  if (f.is_error()) {
    k.can_id = (f.id & CAN_ERR_MASK) | CAN_ERR_FLAG;
  } else if (f.is_extended()) {
    k.can_id |= CAN_EFF_FLAG;
  }
  if ((f.flags & CanFrame::kRemote) != 0) k.can_id |= CAN_RTR_FLAG;
  k.len = f.len;
  if ((f.flags & CanFrame::kRemote) == 0) std::memcpy(k.data, f.data.data(), f.len);
  std::size_t mtu = CAN_MTU;
  if (f.is_fd()) {
    mtu = CANFD_MTU;
    k.flags = CANFD_FDF;
    if ((f.flags & CanFrame::kBitrateSwitch) != 0) k.flags |= CANFD_BRS;
    if ((f.flags & CanFrame::kErrorStateIndicator) != 0) k.flags |= CANFD_ESI;
  }
  std::memcpy(slot, &k, mtu);
  return mtu;
}

// kernel frame -> CanFrame; false for a length that is neither MTU or a bad payload length
bool FromKernel(const std::uint8_t* slot, std::size_t bytes, CanFrame* f) noexcept {
  canfd_frame k{};
  if (bytes != CAN_MTU && bytes != CANFD_MTU) return false;
  std::memcpy(&k, slot, bytes);
  *f = CanFrame{};
  if ((k.can_id & CAN_ERR_FLAG) != 0) {
    f->id = k.can_id & CAN_ERR_MASK;
    f->flags = CanFrame::kError;
  } else if ((k.can_id & CAN_EFF_FLAG) != 0) {
    f->id = k.can_id & CAN_EFF_MASK;
    f->flags = CanFrame::kExtendedId;
  } else {
    f->id = k.can_id & CAN_SFF_MASK;
  }
  if (bytes == CANFD_MTU) {
    f->flags |= CanFrame::kFd;
    if ((k.flags & CANFD_BRS) != 0) f->flags |= CanFrame::kBitrateSwitch;
    if ((k.flags & CANFD_ESI) != 0) f->flags |= CanFrame::kErrorStateIndicator;
    if (!IsValidFdLength(k.len)) return false;
  } else {
    if ((k.can_id & CAN_RTR_FLAG) != 0 && !f->is_error()) f->flags |= CanFrame::kRemote;
    if (k.len > CAN_MAX_DLEN) return false;
  }
  f->len = k.len;
  if ((f->flags & CanFrame::kRemote) == 0) std::memcpy(f->data.data(), k.data, k.len);
  return true;
}

}  // namespace

bool KernelHasSocketCan() noexcept {
  const int s = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (s < 0) return false;
  close(s);
  return true;
}

SocketCanChannel::SocketCanChannel(const SocketCanOptions& options) : options_(options) {
  if (options_.name.empty()) options_.name = "socketcan:" + options_.interface;
  const std::string& ifn = options_.interface;
  if (ifn.empty() || ifn.size() >= IFNAMSIZ)
    throw ChannelError("socketcan: interface: expected a name of 1.." +
                       std::to_string(IFNAMSIZ - 1) + " characters, found '" + ifn + "'");
  if (options_.batch == 0 || options_.batch > 1024)
    throw ChannelError("socketcan: batch: expected 1..1024, found " +
                       std::to_string(options_.batch));
  const auto fail = [this](const std::string& what, int err) {
    const std::string msg = SystemErrorText(options_.name + ": " + what, err);
    Close();
    throw ChannelError(msg);
  };

  sock_ = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (sock_ < 0)
    fail("socket(PF_CAN, SOCK_RAW, CAN_RAW) (does this kernel have CAN? modprobe can_raw)",
         errno);
  ifreq ifr{};
  std::memcpy(ifr.ifr_name, ifn.data(), ifn.size());
  if (ioctl(sock_, SIOCGIFINDEX, &ifr) != 0) fail("no such interface '" + ifn + "'", errno);
  const int ifindex = ifr.ifr_ifindex;
  if (ioctl(sock_, SIOCGIFMTU, &ifr) != 0) fail("SIOCGIFMTU", errno);
  const int mtu = ifr.ifr_mtu;
  if (mtu != CAN_MTU && mtu != CANFD_MTU) {
    const std::string msg = options_.name + ": expected a CAN interface (MTU " +
                            std::to_string(CAN_MTU) + " or " + std::to_string(CANFD_MTU) +
                            "), found MTU " + std::to_string(mtu);
    Close();
    throw ChannelError(msg);
  }
  if (options_.fd == FdMode::kRequire && mtu != CANFD_MTU) {
    const std::string msg = options_.name + ": expected an FD-capable interface (MTU " +
                            std::to_string(CANFD_MTU) + "), found MTU " + std::to_string(mtu) +
                            " (classic CAN only)";
    Close();
    throw ChannelError(msg);
  }
  fd_ = options_.fd != FdMode::kOff && mtu == CANFD_MTU;
  try {
    if (fd_) internal::SetIntOption(sock_, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, 1, "CAN_RAW_FD_FRAMES");
    const can_err_mask_t err_mask = CAN_ERR_MASK;
    if (setsockopt(sock_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask) != 0)
      throw ChannelError(SystemErrorText("setsockopt CAN_RAW_ERR_FILTER", errno));
    internal::EnableRxTimestampsAndDrops(sock_, "socketcan");
    if (options_.receive_buffer_bytes > 0)
      internal::SetIntOption(sock_, SOL_SOCKET, SO_RCVBUF, options_.receive_buffer_bytes,
                             "SO_RCVBUF");
  } catch (const ChannelError& e) {
    const std::string msg = options_.name + ": " + e.what();
    Close();
    throw ChannelError(msg);
  }
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifindex;
  if (bind(sock_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0)
    fail("bind to " + ifn, errno);

  mmsg_.Allocate(options_.batch, kSlotBytes, kSlotBytes, /*rx_source_addresses=*/false);
}

SocketCanChannel::~SocketCanChannel() { Close(); }

void SocketCanChannel::Close() noexcept {
  if (sock_ >= 0) close(sock_);
  sock_ = -1;
}

void SocketCanChannel::OnErrorFrame(const CanFrame& f) noexcept {
  ++counters_.error_frames;
  if ((f.id & CAN_ERR_BUSOFF) != 0) {
    if (counters_.bus_state != BusState::kBusOff) ++counters_.bus_off_events;
    counters_.bus_state = BusState::kBusOff;
    return;
  }
  if ((f.id & CAN_ERR_RESTARTED) != 0) counters_.bus_state = BusState::kErrorActive;
  if ((f.id & CAN_ERR_CRTL) != 0) {
    const std::uint8_t c = f.data[1];
    if ((c & CAN_ERR_CRTL_ACTIVE) != 0) counters_.bus_state = BusState::kErrorActive;
    if ((c & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0 &&
        counters_.bus_state != BusState::kBusOff)
      counters_.bus_state = BusState::kErrorWarning;
    if ((c & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0 &&
        counters_.bus_state != BusState::kBusOff)
      counters_.bus_state = BusState::kErrorPassive;
    if ((c & CAN_ERR_CRTL_RX_OVERFLOW) != 0) {
      ++controller_overflows_;
      counters_.rx_overflow = socket_drops_ + controller_overflows_;
    }
  }
}

CanStatus SocketCanChannel::Send(std::span<const CanFrame> frames, std::size_t* sent) noexcept {
  *sent = 0;
  if (sock_ < 0) return CanStatus::kClosed;
  if (counters_.bus_state == BusState::kBusOff) return CanStatus::kBusOff;
  return internal::SendBatched(sock_, frames, &mmsg_, sent, &counters_,
                               [this](const CanFrame& f, std::size_t slot) -> std::size_t {
                                 return (f.is_fd() && !fd_) ? 0 : ToKernel(f, mmsg_.tx_slot(slot));
                               });
}

CanStatus SocketCanChannel::Receive(std::span<CanFrame> out, std::size_t* received) noexcept {
  *received = 0;
  if (sock_ < 0) return CanStatus::kClosed;
  while (*received < out.size()) {
    const std::size_t want = std::min(options_.batch, out.size() - *received);
    const int r = internal::ReceivePrepared(sock_, &mmsg_, want, &counters_);
    if (r < 0) return CanStatus::kIoError;
    for (int i = 0; i < r; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const msghdr& h = mmsg_.rx_msgs[k].msg_hdr;
      const internal::RxAncillary anc = internal::ParseRxAncillary(h);
      if (anc.have_drops && anc.drops > socket_drops_) {
        socket_drops_ = anc.drops;
        counters_.rx_overflow = socket_drops_ + controller_overflows_;
      }
      CanFrame& f = out[*received];
      if (!FromKernel(mmsg_.rx_slot(k), mmsg_.rx_msgs[k].msg_len, &f)) {
        ++counters_.bad_frames;
        continue;
      }
      f.timestamp_ns = anc.timestamp_ns != 0 ? anc.timestamp_ns : internal::RealtimeNs();
      if (f.is_error()) OnErrorFrame(f);
      ++counters_.rx_frames;
      ++*received;
    }
    if (static_cast<std::size_t>(r) < want) break;
  }
  return CanStatus::kOk;
}

}  // namespace hyq::drivers
