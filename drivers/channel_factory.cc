#include "drivers/channel_factory.h"

#include <charconv>
#include <string>
#include <utility>

#include "drivers/channel_error.h"

namespace hyq::drivers {
namespace {

[[noreturn]] void Bad(std::string_view spec, const std::string& expected,
                      std::string_view found) {
  throw ChannelError("channel spec '" + std::string(spec) + "': expected " + expected +
                     ", found '" + std::string(found) + "'");
}

long ParseInt(std::string_view spec, std::string_view text, long lo, long hi,
              const std::string& what) {
  long v = 0;
  const char* end = text.data() + text.size();
  const auto r = std::from_chars(text.data(), end, v);
  if (text.empty() || r.ec != std::errc{} || r.ptr != end || v < lo || v > hi)
    Bad(spec, what + " (an integer " + std::to_string(lo) + ".." + std::to_string(hi) + ")",
        text);
  return v;
}

bool ParseBool(std::string_view spec, std::string_view text, const std::string& what) {
  if (text == "1" || text == "true" || text == "yes") return true;
  if (text == "0" || text == "false" || text == "no") return false;
  Bad(spec, what + " (0 or 1)", text);
}

// Splits "a,b=c,d=e" into the head "a" and calls on_opt(key, value) for the rest.
template <class F>
std::string_view SplitOptions(std::string_view spec, std::string_view body, F on_opt) {
  const std::size_t comma = body.find(',');
  const std::string_view head = body.substr(0, comma);
  std::string_view rest = comma == std::string_view::npos ? std::string_view{} : body.substr(comma);
  while (!rest.empty()) {
    rest.remove_prefix(1);  // ','
    const std::size_t next = rest.find(',');
    const std::string_view opt = rest.substr(0, next);
    rest = next == std::string_view::npos ? std::string_view{} : rest.substr(next);
    const std::size_t eq = opt.find('=');
    if (eq == std::string_view::npos || eq == 0) Bad(spec, "an option KEY=VALUE", opt);
    on_opt(opt.substr(0, eq), opt.substr(eq + 1));
  }
  return head;
}

}  // namespace

ChannelSpec ParseChannelSpec(std::string_view spec) {
  const std::size_t colon = spec.find(':');
  const std::size_t comma = spec.find(',');
  const std::size_t kind_end = std::min(colon, comma);
  const std::string_view kind = spec.substr(0, kind_end);
  const std::string_view body =
      kind_end == std::string_view::npos
          ? std::string_view{}
          : spec.substr(kind_end + (kind_end == colon ? 1 : 0));

  if (kind == "socketcan" || kind == "socketcan-fd" || kind == "socketcan-classic") {
    SocketCanOptions o;
    o.fd = kind == "socketcan" ? FdMode::kAuto
                               : (kind == "socketcan-fd" ? FdMode::kRequire : FdMode::kOff);
    if (colon == std::string_view::npos || kind_end != colon)
      Bad(spec, std::string(kind) + ":IFNAME", spec);
    const std::string_view ifname = SplitOptions(spec, body, [&](auto key, auto value) {
      if (key == "batch") {
        o.batch = static_cast<std::size_t>(ParseInt(spec, value, 1, 1024, "batch"));
      } else if (key == "rcvbuf") {
        o.receive_buffer_bytes = static_cast<int>(ParseInt(spec, value, 1, 1 << 30, "rcvbuf"));
      } else {
        Bad(spec, "a socketcan option (batch, rcvbuf)", key);
      }
    });
    if (ifname.empty() || ifname.size() > kMaxIfaceName)
      Bad(spec, "an interface name of 1..15 characters after '" + std::string(kind) + ":'",
          ifname);
    for (char c : ifname)
      if (c == ' ' || c == '/' || c == ':' || c == '\t') Bad(spec, "an interface name", ifname);
    o.interface = std::string(ifname);
    return o;
  }

  if (kind == "udp") {
    UdpMulticastOptions o;
    const std::string_view addr = SplitOptions(spec, body, [&](auto key, auto value) {
      if (key == "ttl") {
        o.ttl = static_cast<int>(ParseInt(spec, value, 0, 255, "ttl"));
      } else if (key == "iface") {
        o.interface_address = std::string(value);
      } else if (key == "fd") {
        o.fd = ParseBool(spec, value, "fd");
      } else if (key == "batch") {
        o.batch = static_cast<std::size_t>(ParseInt(spec, value, 1, 1024, "batch"));
      } else if (key == "rcvbuf") {
        o.receive_buffer_bytes = static_cast<int>(ParseInt(spec, value, 1, 1 << 30, "rcvbuf"));
      } else {
        Bad(spec, "a udp option (ttl, iface, fd, batch, rcvbuf)", key);
      }
    });
    if (kind_end == colon) {
      const std::size_t pc = addr.find(':');
      const std::string_view group = addr.substr(0, pc);
      if (!group.empty()) o.group = std::string(group);
      if (pc != std::string_view::npos)
        o.port = static_cast<std::uint16_t>(ParseInt(spec, addr.substr(pc + 1), 1, 65535, "port"));
    }
    return o;
  }

  if (kind == "replay") {
    ReplayOptions o;
    if (colon == std::string_view::npos || kind_end != colon) Bad(spec, "replay:PATH", spec);
    const std::string_view path = SplitOptions(spec, body, [&](auto key, auto value) {
      if (key == "iface") {
        o.iface = std::string(value);
      } else if (key == "timing") {
        if (value == "fast") {
          o.timing = ReplayTiming::kAsFast;
        } else if (value == "realtime") {
          o.timing = ReplayTiming::kRealTime;
        } else {
          Bad(spec, "timing=fast or timing=realtime", value);
        }
      } else if (key == "fd") {
        o.fd = ParseBool(spec, value, "fd");
      } else {
        Bad(spec, "a replay option (iface, timing, fd)", key);
      }
    });
    if (path.empty()) Bad(spec, "a log file path after 'replay:'", path);
    o.path = std::string(path);
    return o;
  }

  if (kind == "shm") {
    ShmOptions o;
    if (colon == std::string_view::npos || kind_end != colon) Bad(spec, "shm:GROUP:BUS", spec);
    const std::string_view where = SplitOptions(spec, body, [&](auto key, auto value) {
      if (key == "side") {
        if (value == "master") {
          o.side = ShmSide::kMaster;
        } else if (value == "devices") {
          o.side = ShmSide::kDevices;
        } else {
          Bad(spec, "side=master or side=devices", value);
        }
      } else if (key == "fd") {
        o.fd = ParseBool(spec, value, "fd");
      } else {
        Bad(spec, "an shm option (side, fd)", key);
      }
    });
    const std::size_t pc = where.find(':');
    if (pc == std::string_view::npos || pc == 0 || pc + 1 == where.size())
      Bad(spec, "shm:GROUP:BUS (a group and a bus name)", where);
    o.group = std::string(where.substr(0, pc));
    o.bus = std::string(where.substr(pc + 1));
    return o;
  }

  Bad(spec, "socketcan:IF, socketcan-fd:IF, socketcan-classic:IF, udp[:GROUP[:PORT]], "
            "shm:GROUP:BUS or replay:PATH",
      kind);
}

std::unique_ptr<hal::CanChannel> OpenChannel(const ChannelSpec& spec) {
  if (const auto* s = std::get_if<SocketCanOptions>(&spec))
    return std::make_unique<SocketCanChannel>(*s);
  if (const auto* u = std::get_if<UdpMulticastOptions>(&spec))
    return std::make_unique<UdpMulticastChannel>(*u);
  if (const auto* m = std::get_if<ShmOptions>(&spec)) return std::make_unique<ShmChannel>(*m);
  const auto& r = std::get<ReplayOptions>(spec);
  CandumpLog log = ReadCandumpFile(r.path, MalformedLines::kThrow);
  return std::make_unique<ReplayChannel>(std::move(log.records), r.iface, r.timing, r.fd,
                                         "replay:" + r.path);
}

std::unique_ptr<hal::CanChannel> OpenChannel(std::string_view spec) {
  const ChannelSpec parsed = ParseChannelSpec(spec);
  try {
    return OpenChannel(parsed);
  } catch (const ChannelError& e) {
    throw ChannelError("channel spec '" + std::string(spec) + "': " + e.what());
  }
}

}  // namespace hyq::drivers

namespace hyq::drivers {

std::string ChannelIdentity(const ChannelSpec& spec) {
  if (const auto* s = std::get_if<SocketCanOptions>(&spec)) return "socketcan:" + s->interface;
  if (const auto* u = std::get_if<UdpMulticastOptions>(&spec))
    return "udp:" + u->group + ":" + std::to_string(u->port);
  if (const auto* m = std::get_if<ShmOptions>(&spec)) return "shm:" + m->group + ":" + m->bus;
  return "replay:" + std::get<ReplayOptions>(spec).path;
}

void CheckBusInterfaces(const std::vector<std::pair<std::string, std::string>>& buses) {
  std::vector<std::string> ids;
  for (std::size_t i = 0; i < buses.size(); ++i) {
    const auto& [name, interface] = buses[i];
    try {
      ids.push_back(ChannelIdentity(ParseChannelSpec(SpecForInterface(interface))));
    } catch (const ChannelError& e) {
      throw ChannelError("bus '" + name + "': interface: " + e.what());
    }
    for (std::size_t k = 0; k < i; ++k)
      if (ids[k] == ids[i] && ids[i].rfind("replay:", 0) != 0)
        throw ChannelError("bus '" + name + "': expected a channel of its own, found '" + interface +
                           "' (" + ids[i] + "), the channel of bus '" + buses[k].first + "' too");
  }
}

std::string SpecForInterface(std::string_view interface) {
  for (std::string_view prefix : {"socketcan", "udp", "shm", "replay"})
    if (interface.substr(0, prefix.size()) == prefix) return std::string(interface);
  return "socketcan:" + std::string(interface);
}


}  // namespace hyq::drivers
