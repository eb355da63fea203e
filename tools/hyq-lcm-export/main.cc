// hyq-lcm-export: an lcm-logger file -> one CSV per channel, decoded with the hyq_lcm types
// (recognised by their fingerprint, so any channel name works), header row with units.
#include <unistd.h>

#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "hyq_lcm/lcmt_hyq_base_state.hpp"
#include "hyq_lcm/lcmt_hyq_command.hpp"
#include "hyq_lcm/lcmt_hyq_contact_state.hpp"
#include "hyq_lcm/lcmt_hyq_event.hpp"
#include "hyq_lcm/lcmt_hyq_health.hpp"
#include "hyq_lcm/lcmt_hyq_joint_state.hpp"
#include "hyq_lcm/lcmt_hyq_joint_torque.hpp"
#include "hyq_lcm/lcmt_hyq_servo_timing.hpp"

namespace fs = std::filesystem;

namespace {

constexpr const char* kUsage = R"TXT(usage: hyq-lcm-export [options] LOG OUT_DIR

Decodes every message of an lcm-logger file with the hyq_lcm types and writes one CSV per channel
to OUT_DIR/<CHANNEL>.csv: a header row "field (unit)" (array elements as field.lf_haa, field.x,
...), then one row per message, first column log_utime (µs, when lcm-logger received it).
Messages are recognised by their type fingerprint, whatever the channel is called.

options:
  --allow-undecodable    exit 0 even if some messages could not be decoded (they are counted)
  --plot                 then run the plot script on OUT_DIR (PNG figures: joint tracking,
                         torques, timing histogram, events timeline); needs python3-matplotlib
  --quiet                no progress output
  -h, --help             this text

exit status: 0 ok, 1 undecodable messages (without --allow-undecodable) or plot failed,
             2 bad arguments or unreadable log
)TXT";

constexpr const char* kJoints[] = {"lf_haa", "lf_hfe", "lf_kfe", "rf_haa", "rf_hfe", "rf_kfe",
                                   "lh_haa", "lh_hfe", "lh_kfe", "rh_haa", "rh_hfe", "rh_kfe"};
constexpr const char* kFeet[] = {"lf", "rf", "lh", "rh"};
constexpr const char* kXyz[] = {"x", "y", "z"};
constexpr const char* kWxyz[] = {"w", "x", "y", "z"};

// Writes either the header cells or one row's cells of a message, in the same order.
class Csv {
 public:
  Csv(bool header, std::string* line) : header_(header), line_(line) {}

  template <class T>
  void Field(const std::string& name, const char* unit, const T& value) {
    Sep();
    if (header_) {
      *line_ += name + " (" + unit + ")";
    } else {
      Value(value);
    }
  }
  template <class T, std::size_t N>
  void Array(const std::string& name, const char* unit, const T (&values)[N],
             const char* const (&labels)[N]) {
    for (std::size_t i = 0; i < N; ++i) Field(name + "." + labels[i], unit, values[i]);
  }

 private:
  void Sep() {
    if (!line_->empty()) *line_ += ',';
  }
  void Value(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.17g", v);
    *line_ += b;
  }
  void Value(std::int64_t v) { *line_ += std::to_string(v); }
  void Value(std::int32_t v) { *line_ += std::to_string(v); }
  void Value(std::int16_t v) { *line_ += std::to_string(v); }
  void Value(std::int8_t v) { *line_ += std::to_string(static_cast<int>(v)); }
  void Value(bool v) { *line_ += v ? '1' : '0'; }
  void Value(const std::string& s) {
    *line_ += '"';
    for (char c : s) {
      if (c == '"') *line_ += '"';
      *line_ += (c == '\n' || c == '\r') ? ' ' : c;
    }
    *line_ += '"';
  }

  bool header_;
  std::string* line_;
};

void Visit(const hyq_lcm::lcmt_hyq_joint_state& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("mode", "enum", m.mode);
  c.Field("reference_time_s", "s", m.reference_time_s);
  c.Array("q_rad", "rad", m.q_rad, kJoints);
  c.Array("qd_rad_s", "rad/s", m.qd_rad_s, kJoints);
  c.Array("tau_measured_Nm", "N.m", m.tau_measured_Nm, kJoints);
  c.Array("q_ref_rad", "rad", m.q_ref_rad, kJoints);
  c.Array("qd_ref_rad_s", "rad/s", m.qd_ref_rad_s, kJoints);
  c.Array("input_status", "enum", m.input_status, kJoints);
  c.Field("tracking_error_rad", "rad", m.tracking_error_rad);
}
void Visit(const hyq_lcm::lcmt_hyq_joint_torque& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("mode", "enum", m.mode);
  c.Field("controller", "enum", m.controller);
  c.Array("tau_command_Nm", "N.m", m.tau_command_Nm, kJoints);
}
void Visit(const hyq_lcm::lcmt_hyq_base_state& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Array("position_m", "m", m.position_m, kXyz);
  c.Array("orientation_wxyz", "1", m.orientation_wxyz, kWxyz);
  c.Array("velocity_m_s", "m/s", m.velocity_m_s, kXyz);
  c.Array("angular_velocity_rad_s", "rad/s", m.angular_velocity_rad_s, kXyz);
}
void Visit(const hyq_lcm::lcmt_hyq_contact_state& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("controller", "enum", m.controller);
  for (int f = 0; f < 4; ++f) c.Field(std::string("stance_reference.") + kFeet[f], "bool", m.stance_reference[f] != 0);
  for (int f = 0; f < 4; ++f) c.Field(std::string("stance_estimated.") + kFeet[f], "bool", m.stance_estimated[f] != 0);
  c.Array("mu", "1", m.mu, kFeet);
  for (int f = 0; f < 4; ++f)
    c.Array(std::string("contact_force_N.") + kFeet[f], "N", m.contact_force_N[f], kXyz);
  c.Field("stage1_status", "enum", m.stage1_status);
  c.Field("stage2_status", "enum", m.stage2_status);
  c.Field("fallback", "enum", m.fallback);
  c.Field("stage1_iterations", "count", m.stage1_iterations);
  c.Field("stage2_iterations", "count", m.stage2_iterations);
  c.Field("stage1_solve_us", "us", m.stage1_solve_us);
  c.Field("stage2_solve_us", "us", m.stage2_solve_us);
}
void Visit(const hyq_lcm::lcmt_hyq_servo_timing& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("wakeup_latency_ns", "ns", m.wakeup_latency_ns);
  c.Field("read_ns", "ns", m.read_ns);
  c.Field("estimate_ns", "ns", m.estimate_ns);
  c.Field("reference_ns", "ns", m.reference_ns);
  c.Field("control_ns", "ns", m.control_ns);
  c.Field("safety_ns", "ns", m.safety_ns);
  c.Field("write_ns", "ns", m.write_ns);
  c.Field("total_ns", "ns", m.total_ns);
  c.Field("deadline_misses", "count", m.deadline_misses);
  c.Field("consecutive_misses", "count", m.consecutive_misses);
  c.Field("skipped_cycles", "count", m.skipped_cycles);
}
void Visit(const hyq_lcm::lcmt_hyq_health& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("mode", "enum", m.mode);
  c.Field("hal_read_status", "enum", m.hal_read_status);
  c.Field("hal_write_status", "enum", m.hal_write_status);
  c.Field("num_buses", "count", m.num_buses);
  for (int b = 0; b < 8; ++b) {
    const auto& h = m.buses[b];
    const std::string p = "bus" + std::to_string(b) + ".";
    c.Field(p + "rx_frames", "count", h.rx_frames);
    c.Field(p + "tx_frames", "count", h.tx_frames);
    c.Field(p + "wkc_faults", "count", h.wkc_faults);
    c.Field(p + "missing", "count", h.missing);
    c.Field(p + "malformed", "count", h.malformed);
    c.Field(p + "error_frames", "count", h.error_frames);
    c.Field(p + "emcy", "count", h.emcy);
    c.Field(p + "bus_off", "count", h.bus_off);
    c.Field(p + "tx_failed", "count", h.tx_failed);
    c.Field(p + "wkc_expected", "count", h.wkc_expected);
    c.Field(p + "wkc_received", "count", h.wkc_received);
  }
  c.Field("num_devices", "count", m.num_devices);
  for (int d = 0; d < 16; ++d)
    c.Field("device_state." + std::to_string(d), "enum", m.device_state[d]);
  c.Field("safety_events", "count", m.safety_events);
  c.Field("snapshots_dropped", "count", m.snapshots_dropped);
  c.Field("events_dropped", "count", m.events_dropped);
  c.Field("snapshots_published", "count", m.snapshots_published);
  c.Field("publish_failures", "count", m.publish_failures);
  c.Field("commands_received", "count", m.commands_received);
  c.Field("commands_accepted", "count", m.commands_accepted);
  c.Field("commands_rejected", "count", m.commands_rejected);
  c.Field("commands_dropped", "count", m.commands_dropped);
}
void Visit(const hyq_lcm::lcmt_hyq_event& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("from_mode", "enum", m.from_mode);
  c.Field("to_mode", "enum", m.to_mode);
  c.Field("from_name", "text", m.from_name);
  c.Field("to_name", "text", m.to_name);
  c.Field("reason_code", "enum", m.reason_code);
  c.Field("reason", "text", m.reason);
  c.Field("joint", "index", m.joint);
  c.Field("bus", "index", m.bus);
  c.Field("detail", "text", m.detail);
}
void Visit(const hyq_lcm::lcmt_hyq_command& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("sequence", "count", m.sequence);
  c.Field("kind", "enum", m.kind);
  c.Field("num_feet", "count", m.num_feet);
  for (int f = 0; f < 4; ++f)
    c.Field(std::string("mu.") + kFeet[f], "1",
            f < static_cast<int>(m.mu.size()) ? m.mu[static_cast<std::size_t>(f)] : 0.0);
  c.Field("controller", "text", m.controller);
  c.Field("kp_scale", "1", m.kp_scale);
  c.Field("kd_scale", "1", m.kd_scale);
}

// One decoder per type, keyed by fingerprint.
struct Decoder {
  const char* type;
  // decodes data into a row (or the header when data is null); false when undecodable
  bool (*row)(const void* data, int size, std::string* line);
};

template <class T>
bool Row(const void* data, int size, std::string* line) {
  T msg{};
  if (data != nullptr && msg.decode(data, 0, size) != size) return false;
  Csv csv(data == nullptr, line);
  Visit(msg, csv);
  return true;
}

template <class T>
void Add(std::map<std::int64_t, Decoder>* decoders, const char* name) {
  (*decoders)[T::getHash()] = Decoder{name, &Row<T>};
}

std::int64_t Fingerprint(const void* data, int size) {
  if (size < 8) return 0;
  const auto* b = static_cast<const unsigned char*>(data);
  std::uint64_t h = 0;
  for (int i = 0; i < 8; ++i) h = (h << 8) | b[i];
  return static_cast<std::int64_t>(h);
}

struct ChannelOut {
  std::FILE* file = nullptr;
  std::string type;
  std::int64_t fingerprint = 0;
  std::uint64_t rows = 0, undecodable = 0;
};

}  // namespace

int main(int argc, char** argv) {
  bool allow_undecodable = false, plot = false, quiet = false;
  std::vector<std::string> args;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    if (a == "-h" || a == "--help") {
      std::fputs(kUsage, stdout);
      return 0;
    } else if (a == "--allow-undecodable") {
      allow_undecodable = true;
    } else if (a == "--plot") {
      plot = true;
    } else if (a == "--quiet" || a == "-q") {
      quiet = true;
    } else if (a.starts_with("-") && a.size() > 1) {
      std::fprintf(stderr, "hyq-lcm-export: unknown option '%s' (see --help)\n", argv[i]);
      return 2;
    } else {
      args.emplace_back(a);
    }
  }
  if (args.size() != 2) {
    std::fprintf(stderr, "hyq-lcm-export: expected LOG and OUT_DIR, found %zu argument(s) (see --help)\n",
                 args.size());
    return 2;
  }
  const std::string log_path = args[0];
  const fs::path out_dir = args[1];
  std::error_code ec;
  const auto log_size = fs::file_size(log_path, ec);
  if (ec) {
    std::fprintf(stderr, "hyq-lcm-export: cannot read '%s': %s\n", log_path.c_str(),
                 ec.message().c_str());
    return 2;
  }
  lcm::LogFile log(log_path, "r");
  if (!log.good()) {
    std::fprintf(stderr, "hyq-lcm-export: '%s' is not a readable LCM log\n", log_path.c_str());
    return 2;
  }
  fs::create_directories(out_dir, ec);
  if (ec) {
    std::fprintf(stderr, "hyq-lcm-export: cannot create '%s': %s\n", out_dir.c_str(),
                 ec.message().c_str());
    return 2;
  }

  std::map<std::int64_t, Decoder> decoders;
  Add<hyq_lcm::lcmt_hyq_joint_state>(&decoders, "lcmt_hyq_joint_state");
  Add<hyq_lcm::lcmt_hyq_joint_torque>(&decoders, "lcmt_hyq_joint_torque");
  Add<hyq_lcm::lcmt_hyq_base_state>(&decoders, "lcmt_hyq_base_state");
  Add<hyq_lcm::lcmt_hyq_contact_state>(&decoders, "lcmt_hyq_contact_state");
  Add<hyq_lcm::lcmt_hyq_servo_timing>(&decoders, "lcmt_hyq_servo_timing");
  Add<hyq_lcm::lcmt_hyq_health>(&decoders, "lcmt_hyq_health");
  Add<hyq_lcm::lcmt_hyq_event>(&decoders, "lcmt_hyq_event");
  Add<hyq_lcm::lcmt_hyq_command>(&decoders, "lcmt_hyq_command");

  std::map<std::string, ChannelOut> channels;
  std::uint64_t total = 0, undecodable = 0;
  std::string line;
  auto last_progress = std::chrono::steady_clock::now();
  const bool show_progress = !quiet && log_size > (8u << 20);
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    ++total;
    ChannelOut& ch = channels[ev->channel];
    const std::int64_t fp = Fingerprint(ev->data, ev->datalen);
    const auto it = decoders.find(fp);
    line = std::to_string(ev->timestamp);
    std::string cells;
    const bool known = it != decoders.end() && (ch.file == nullptr || ch.fingerprint == fp);
    if (!known || !it->second.row(ev->data, ev->datalen, &cells)) {
      ++ch.undecodable;
      ++undecodable;
      continue;
    }
    if (ch.file == nullptr) {
      const fs::path path = out_dir / (ev->channel + ".csv");
      ch.file = std::fopen(path.c_str(), "w");
      if (ch.file == nullptr) {
        std::fprintf(stderr, "hyq-lcm-export: cannot write '%s'\n", path.c_str());
        return 2;
      }
      ch.type = it->second.type;
      ch.fingerprint = fp;
      std::string header;
      it->second.row(nullptr, 0, &header);
      std::fprintf(ch.file, "log_utime (us),%s\n", header.c_str());
    }
    std::fprintf(ch.file, "%s,%s\n", line.c_str(), cells.c_str());
    ++ch.rows;
    if (show_progress && (total & 1023) == 0) {
      const auto now = std::chrono::steady_clock::now();
      if (now - last_progress > std::chrono::seconds(1)) {
        last_progress = now;
        const long pos = std::ftell(log.getFilePtr());
        std::fprintf(stderr, "\rhyq-lcm-export: %5.1f %% (%" PRIu64 " messages)",
                     100.0 * static_cast<double>(pos) / static_cast<double>(log_size), total);
      }
    }
  }
  if (show_progress) std::fprintf(stderr, "\r%60s\r", "");

  for (auto& [name, ch] : channels) {
    if (ch.file != nullptr) std::fclose(ch.file);
    if (!quiet || ch.undecodable != 0)
      std::printf("%-24s %-24s %10" PRIu64 " rows%s", name.c_str(),
                  ch.type.empty() ? "(unknown type)" : ch.type.c_str(), ch.rows,
                  ch.undecodable != 0 ? "" : "\n");
    if (ch.undecodable != 0) std::printf(", %" PRIu64 " undecodable\n", ch.undecodable);
  }
  std::printf("hyq-lcm-export: %" PRIu64 " messages, %zu channels, %" PRIu64
              " undecodable -> %s\n",
              total, channels.size(), undecodable, out_dir.c_str());

  int status = 0;
  if (undecodable != 0 && !allow_undecodable) {
    std::fprintf(stderr,
                 "hyq-lcm-export: %" PRIu64 " message(s) could not be decoded with the hyq_lcm "
                 "types (--allow-undecodable to accept)\n",
                 undecodable);
    status = 1;
  }
  if (plot) {
    // the script beside this executable (build tree), else the installed one
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    fs::path script = exe.parent_path() / "plot_lcm_log.py";
    if (!fs::exists(script)) script = exe.parent_path().parent_path() / "share/hyq/plot_lcm_log.py";
    if (!fs::exists(script)) {
      std::fprintf(stderr, "hyq-lcm-export: plot script plot_lcm_log.py not found near %s\n",
                   exe.c_str());
      return 1;
    }
    std::fflush(stdout);
    // Debian's python3 (with python3-matplotlib), not whatever python3 is first on PATH
    const std::string cmd = "/usr/bin/python3 '" + script.string() + "' '" + out_dir.string() + "'";
    if (std::system(cmd.c_str()) != 0) {
      std::fprintf(stderr, "hyq-lcm-export: plotting failed (%s)\n", cmd.c_str());
      return 1;
    }
  }
  return status;
}
