// Opening a channel from the short spec string config files use.
//
//   spec      := socketcan-spec | udp-spec | shm-spec | replay-spec
//   socketcan-spec := ("socketcan" | "socketcan-fd" | "socketcan-classic") ":" IFNAME opts
//                   socketcan: FD when the interface MTU allows it; -fd: FD required (throws
//                   otherwise); -classic: never FD
//   udp-spec  := "udp" [ ":" GROUP [ ":" PORT ] ] opts
//                   GROUP an IPv4 multicast address (default 239.74.163.2), PORT 1..65535
//                   (default 43113); "udp" alone, "udp::43114" and "udp:239.1.2.3" are valid
//   shm-spec  := "shm:" GROUP ":" BUS opts   shared memory, one master and one devices side
//                   (drivers/shm_channel.h; lock-step hardware-in-the-loop on one machine)
//   replay-spec := "replay:" PATH opts       (PATH may not contain ',')
//   opts      := { "," KEY "=" VALUE }
//     udp:       ttl=0..255 (default 0), iface=A.B.C.D, fd=0|1 (default 1), batch=N, rcvbuf=BYTES
//     socketcan: batch=N, rcvbuf=BYTES
//     shm:       side=master|devices (default master), fd=0|1 (default 1)
//     replay:    iface=NAME (only lines from that interface), timing=fast|realtime, fd=0|1
//
// Examples: "socketcan:vcan0", "socketcan-fd:can1,rcvbuf=262144", "udp:239.74.163.2:43113",
// "udp,ttl=1", "replay:logs/leg_lf.log,iface=can0,timing=realtime".
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "drivers/candump.h"
#include "drivers/shm_channel.h"
#include "drivers/socketcan_channel.h"
#include "drivers/udp_multicast_channel.h"
#include "hal/can_channel.h"

namespace hyq::drivers {

struct ReplayOptions {
  std::string path;
  std::string iface;  // empty: every line
  ReplayTiming timing = ReplayTiming::kAsFast;
  bool fd = true;
};

/// A parsed spec: the options of exactly one driver.
using ChannelSpec = std::variant<SocketCanOptions, UdpMulticastOptions, ShmOptions, ReplayOptions>;

/// Parses `spec`; throws ChannelError("channel spec '<spec>': expected ..., found ...").
ChannelSpec ParseChannelSpec(std::string_view spec);

/// Parses and opens. Throws ChannelError naming the spec when it is malformed or the channel
/// cannot be opened.
std::unique_ptr<hal::CanChannel> OpenChannel(std::string_view spec);
std::unique_ptr<hal::CanChannel> OpenChannel(const ChannelSpec& spec);

}  // namespace hyq::drivers

namespace hyq::drivers {

/// The spec for a bus interface as written in the HAL configuration: "can0" / "vcan1" (a bare
/// interface name) means "socketcan:can0"; anything with a driver prefix is used as it is.
std::string SpecForInterface(std::string_view interface);

/// What a spec talks to, whatever the spelling: "socketcan:can0", "udp:239.74.163.2:43113"
/// ("udp" and "udp::43113" are the same bus), "replay:PATH".
std::string ChannelIdentity(const ChannelSpec& spec);

/// Parses every bus's interface (what --check would otherwise pass and the start-up fail on) and
/// refuses two buses on one channel (one interface, one UDP group and port).
/// @throws ChannelError "bus 'NAME': ..." naming the bus, what was expected and what was found.
void CheckBusInterfaces(const std::vector<std::pair<std::string, std::string>>& name_and_interface);

}  // namespace hyq::drivers
