#include "servo/telemetry/lcm_url.h"

#include <arpa/inet.h>
#include <linux/netlink.h>
#include <linux/rtnetlink.h>
#include <net/if.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace hyq::servo {
namespace {

[[noreturn]] void Bad(const std::string& what, const std::string& expected, const std::string& found) {
  throw std::invalid_argument(what + ": expected " + expected + ", found '" + found + "'");
}

bool ParseInt(const std::string& s, long lo, long hi, long* out) {
  if (s.empty() || s.size() > 9) return false;
  for (char c : s)
    if (c < '0' || c > '9') return false;
  *out = std::strtol(s.c_str(), nullptr, 10);
  return *out >= lo && *out <= hi;
}

}  // namespace

LcmUrl ParseLcmUrl(const std::string& url, const std::string& what) {
  const std::size_t sep = url.find("://");
  if (sep == std::string::npos)
    Bad(what, "an LCM URL (udpm://GROUP:PORT?ttl=N, memq:// or file://PATH)", url);
  LcmUrl u;
  u.provider = url.substr(0, sep);
  std::string rest = url.substr(sep + 3), query;
  if (const std::size_t q = rest.find('?'); q != std::string::npos) {
    query = rest.substr(q + 1);
    rest.resize(q);
  }
  if (u.provider == "memq") {
    if (!rest.empty() || !query.empty()) Bad(what, "memq:// with nothing after it", url);
    return u;
  }
  if (u.provider == "file") {
    if (rest.empty()) Bad(what, "file://PATH", url);
    u.target = rest;
    return u;
  }
  if (u.provider != "udpm")
    Bad(what, "the provider udpm, memq or file (udpm://GROUP:PORT?ttl=N, memq://, file://PATH)", url);
  if (rest.empty()) {  // liblcm's default group
    u.group = "239.255.76.67";
    u.port = 7667;
  } else {
    const std::size_t colon = rest.rfind(':');
    u.group = rest.substr(0, colon);
    in_addr a{};
    if (inet_pton(AF_INET, u.group.c_str(), &a) != 1)
      Bad(what + " (group)", "a dotted IPv4 multicast address", u.group);
    if ((ntohl(a.s_addr) >> 28) != 0xE)
      Bad(what + " (group)", "a multicast address in 224.0.0.0/4", u.group);
    long port = 7667;
    if (colon != std::string::npos && !ParseInt(rest.substr(colon + 1), 1, 65535, &port))
      Bad(what + " (port)", "1..65535", rest.substr(colon + 1));
    u.port = static_cast<std::uint16_t>(port);
  }
  while (!query.empty()) {
    const std::size_t amp = query.find('&');
    const std::string kv = query.substr(0, amp);
    query = amp == std::string::npos ? "" : query.substr(amp + 1);
    const std::size_t eq = kv.find('=');
    const std::string key = kv.substr(0, eq), value = eq == std::string::npos ? "" : kv.substr(eq + 1);
    long v = 0;
    if (key == "ttl") {
      if (!ParseInt(value, 0, 255, &v)) Bad(what + " (ttl)", "0..255", value);
      u.ttl = static_cast<int>(v);
    } else if (key == "recv_buf_size") {
      if (!ParseInt(value, 1, 1L << 28, &v)) Bad(what + " (recv_buf_size)", "1..268435456 bytes", value);
    } else {
      Bad(what + " (option)", "ttl or recv_buf_size", kv);
    }
  }
  return u;
}

// the netlink macros (NLMSG_DATA, RTA_NEXT, ...) are C casts
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wcast-align"
std::string InterfaceForGroup(const std::string& group, std::uint16_t /*port*/) {
  // ask the kernel's routing table, as ip route get GROUP does (RTM_GETROUTE -> RTA_OIF): the
  // source address of a connected socket is not enough (0.0.0.0 for a route on lo)
  in_addr dst{};
  if (inet_pton(AF_INET, group.c_str(), &dst) != 1)
    throw std::runtime_error("not an IPv4 address: '" + group + "'");
  const int fd = ::socket(AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC, NETLINK_ROUTE);
  if (fd < 0) throw std::runtime_error(std::string("netlink socket: ") + std::strerror(errno));
  struct {
    nlmsghdr h;
    rtmsg r;
    char attrs[64];
  } req{};
  req.h.nlmsg_len = NLMSG_LENGTH(sizeof(rtmsg));
  req.h.nlmsg_type = RTM_GETROUTE;
  req.h.nlmsg_flags = NLM_F_REQUEST;
  req.h.nlmsg_seq = 1;
  req.r.rtm_family = AF_INET;
  req.r.rtm_dst_len = 32;
  auto* rta = reinterpret_cast<rtattr*>(reinterpret_cast<char*>(&req) + NLMSG_ALIGN(req.h.nlmsg_len));
  rta->rta_type = RTA_DST;
  rta->rta_len = RTA_LENGTH(sizeof dst);
  std::memcpy(RTA_DATA(rta), &dst, sizeof dst);
  req.h.nlmsg_len = NLMSG_ALIGN(req.h.nlmsg_len) + RTA_ALIGN(rta->rta_len);
  char buf[4096];
  ssize_t n = -1;
  if (::send(fd, &req, req.h.nlmsg_len, 0) >= 0) n = ::recv(fd, buf, sizeof buf, 0);
  const int err = errno;
  ::close(fd);
  if (n < 0) throw std::runtime_error(std::string("netlink route query: ") + std::strerror(err));
  int oif = -1;
  for (auto* h = reinterpret_cast<nlmsghdr*>(buf); NLMSG_OK(h, static_cast<unsigned>(n));
       h = NLMSG_NEXT(h, n)) {
    if (h->nlmsg_type == NLMSG_ERROR) {
      const int code = -reinterpret_cast<nlmsgerr*>(NLMSG_DATA(h))->error;
      throw std::runtime_error("no route to the multicast group " + group + " (" + std::strerror(code) +
                               "; e.g. ip route add 224.0.0.0/4 dev lo)");
    }
    if (h->nlmsg_type != RTM_NEWROUTE) continue;
    auto* r = reinterpret_cast<rtmsg*>(NLMSG_DATA(h));
    int len = static_cast<int>(RTM_PAYLOAD(h));
    for (auto* a = RTM_RTA(r); RTA_OK(a, len); a = RTA_NEXT(a, len))
      if (a->rta_type == RTA_OIF) std::memcpy(&oif, RTA_DATA(a), sizeof oif);
  }
  char name[IF_NAMESIZE] = {};
  if (oif < 0 || if_indextoname(static_cast<unsigned>(oif), name) == nullptr)
    throw std::runtime_error("the route to " + group + " names no interface");
  return name;
}
#pragma GCC diagnostic pop

}  // namespace hyq::servo
