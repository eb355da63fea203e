// LCM URLs checked before liblcm sees them (liblcm 1.3 accepts "udp::99999" or "udpm://[[[::"
// and fails later, or not at all), and the interface a udpm group is joined on.
#pragma once

#include <cstdint>
#include <string>

namespace hyq::servo {

struct LcmUrl {
  std::string provider;            // udpm, memq or file
  std::string group;               // udpm: dotted IPv4 multicast group (224.0.0.0/4)
  std::uint16_t port = 0;          // udpm: 1..65535
  int ttl = 0;                     // udpm: 0..255 (0: nothing leaves the host)
  std::string target;              // file: the path
};

/// Parses udpm://GROUP:PORT?ttl=N[&recv_buf_size=N], memq:// or file://PATH[?mode=r|w|a...].
/// @throws std::invalid_argument "<what>: expected ..., found ..." naming the part that is wrong.
LcmUrl ParseLcmUrl(const std::string& url, const std::string& what);

/// The network interface the kernel picks for `group` (what liblcm joins the group on, as it
/// leaves the choice to the routing table): a UDP socket connected to the group, its source
/// address, and the interface holding that address.
/// @throws std::runtime_error when there is no route or no interface holds the source address.
std::string InterfaceForGroup(const std::string& group, std::uint16_t port);

}  // namespace hyq::servo
