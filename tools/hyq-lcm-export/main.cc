// hyq-lcm-export: an lcm-logger file -> one CSV per channel, decoded with the hyq_lcm types
// (recognised by their fingerprint, so any channel name works), header row with units.
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "tools/cli/command_line.h"
#include "tools/cli/install_paths.h"
#include "tools/hyq-lcm-export/csv_rows.h"
#include "tools/hyq-lcm-export/lcm_log.h"

namespace fs = std::filesystem;

namespace {

constexpr const char* kUsage = R"TXT(usage: hyq-lcm-export [options] LOG OUT_DIR

Decodes every message of an lcm-logger file with the hyq_lcm types and writes one CSV per channel
to OUT_DIR/<CHANNEL>.csv: a header row "field (unit)" (array elements as field.lf_haa, field.x,
...), then one row per message, first column log_utime (µs, when lcm-logger received it).
Messages are recognised by their type fingerprint, whatever the channel is called. A channel
name that is not a safe file name (only A-Z a-z 0-9 _ . -, no leading dot) is written under a
safe one, and said so on stderr.

A damaged log (a bad sync word, impossible lengths, a truncated last event) is read on from the
next sync word; the damage is counted and reported, and what could be read is still exported.

options:
  --allow-undecodable    exit 0 even if some messages could not be decoded (they are counted)
  --plot                 then run the plot script on OUT_DIR (PNG figures: joint tracking,
                         torques, timing histogram, events timeline); needs python3-matplotlib
  --quiet                no progress output
  -h, --help             this text

exit status: 0 ok
             1 undecodable messages (without --allow-undecodable), or the plot failed
             2 bad arguments, an unreadable log, or an OUT_DIR that cannot be written
             3 the log is damaged (see above); everything readable was exported
)TXT";

using hyq::lcm_export::Printable;

struct ChannelOut {
  std::FILE* file = nullptr;
  std::string type;
  std::string path;
  std::int64_t fingerprint = 0;
  std::uint64_t rows = 0, undecodable = 0;
};

// The log mapped read-only (lcm-logger files run to gigabytes; the reader needs random access to
// resynchronise). Only a regular file: a device would never end.
class MappedLog {
 public:
  ~MappedLog() {
    if (map_ != MAP_FAILED) ::munmap(map_, size_);
  }
  // an empty string, or why not
  std::string Open(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return std::strerror(errno);
    struct stat st {};
    std::string why;
    if (::fstat(fd, &st) != 0) {
      why = std::strerror(errno);
    } else if (!S_ISREG(st.st_mode)) {
      why = S_ISDIR(st.st_mode) ? "expected a regular file, found a directory"
                                : "expected a regular file, found a device, pipe or socket";
    } else if (st.st_size > 0) {
      size_ = static_cast<std::size_t>(st.st_size);
      map_ = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
      if (map_ == MAP_FAILED) why = std::strerror(errno);
      else ::madvise(map_, size_, MADV_SEQUENTIAL);
    }
    ::close(fd);
    return why;
  }
  std::span<const std::uint8_t> bytes() const {
    if (map_ == MAP_FAILED) return {};
    return {static_cast<const std::uint8_t*>(map_), size_};
  }

 private:
  void* map_ = MAP_FAILED;
  std::size_t size_ = 0;
};

// Runs /usr/bin/python3 SCRIPT DIR and waits: an argument vector, no shell to interpret DIR.
// Debian's python3 (with python3-matplotlib), not whatever python3 is first on PATH. Returns
// the wait status, or -1 when it could not be started.
int RunPlot(const std::string& script, const std::string& dir) {
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    const char* argv[] = {"/usr/bin/python3", script.c_str(), dir.c_str(), nullptr};
    ::execv(argv[0], const_cast<char* const*>(argv));
    std::fprintf(stderr, "hyq-lcm-export: cannot run %s: %s\n", argv[0], std::strerror(errno));
    ::_exit(127);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return -1;
  }
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  bool allow_undecodable = false, plot = false, quiet = false;
  std::vector<std::string> args;
  hyq::cli::CommandLine cl(argc, argv, "hyq-lcm-export", kUsage);
  while (cl.Next()) {
    if (cl.Flag("--allow-undecodable")) {
      allow_undecodable = true;
    } else if (cl.Flag("--plot")) {
      plot = true;
    } else if (cl.Flag("--quiet") || cl.Flag("-q")) {
      quiet = true;
    } else if (cl.IsOption()) {
      cl.Unknown();
    } else {
      args.push_back(cl.arg());
    }
  }
  if (args.size() != 2)
    cl.Fail("expected LOG and OUT_DIR, found " + std::to_string(args.size()) + " argument(s)");
  const std::string log_path = args[0];
  const fs::path out_dir = args[1];
  MappedLog mapped;
  if (const std::string why = mapped.Open(log_path); !why.empty()) {
    std::fprintf(stderr, "hyq-lcm-export: cannot read '%s': %s\n", log_path.c_str(), why.c_str());
    return 2;
  }
  const std::span<const std::uint8_t> log = mapped.bytes();
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) {
    std::fprintf(stderr, "hyq-lcm-export: cannot create '%s': %s\n", out_dir.c_str(),
                 ec.message().c_str());
    return 2;
  }

  hyq::lcm_export::LogReader reader(log);
  hyq::lcm_export::LogEvent ev;
  std::map<std::string, ChannelOut, std::less<>> channels;
  std::set<std::string> file_names;
  std::uint64_t total = 0, undecodable = 0;
  std::string cells;
  auto last_progress = std::chrono::steady_clock::now();
  const bool show_progress = !quiet && log.size() > (8u << 20);
  while (reader.Next(&ev)) {
    ++total;
    auto it_ch = channels.find(ev.channel);
    if (it_ch == channels.end()) it_ch = channels.emplace(std::string(ev.channel), ChannelOut{}).first;
    ChannelOut& ch = it_ch->second;
    const hyq::lcm_export::RowType* type = hyq::lcm_export::FindRowType(ev.data);
    const bool known = type != nullptr && (ch.file == nullptr || ch.fingerprint == type->fingerprint);
    if (!known || !hyq::lcm_export::RowCells(*type, ev.data, &cells)) {
      ++ch.undecodable;
      ++undecodable;
      continue;
    }
    if (ch.file == nullptr) {
      // the channel name comes from the log: never a path ("../../x"), never a clash
      const std::string safe = hyq::lcm_export::SafeFileName(ev.channel);
      std::string name = safe;
      for (int k = 2; !file_names.insert(name).second; ++k) name = safe + "-" + std::to_string(k);
      const fs::path path = out_dir / (name + ".csv");
      if (name != ev.channel)
        std::fprintf(stderr, "hyq-lcm-export: channel \"%s\" is written to %s\n",
                     Printable(ev.channel).c_str(), path.c_str());
      ch.file = std::fopen(path.c_str(), "w");
      if (ch.file == nullptr) {
        std::fprintf(stderr, "hyq-lcm-export: cannot write '%s': %s\n", path.c_str(),
                     std::strerror(errno));
        return 2;
      }
      ch.type = type->name;
      ch.path = path.string();
      ch.fingerprint = type->fingerprint;
      std::fprintf(ch.file, "log_utime (us),%s\n", hyq::lcm_export::HeaderCells(*type).c_str());
    }
    std::fprintf(ch.file, "%" PRId64 ",%s\n", ev.timestamp_us, cells.c_str());
    ++ch.rows;
    if (show_progress && (total & 1023) == 0) {
      const auto now = std::chrono::steady_clock::now();
      if (now - last_progress > std::chrono::seconds(1)) {
        last_progress = now;
        std::fprintf(stderr, "\rhyq-lcm-export: %5.1f %% (%" PRIu64 " messages)",
                     100.0 * static_cast<double>(reader.position()) / static_cast<double>(log.size()),
                     total);
      }
    }
  }
  if (show_progress) std::fprintf(stderr, "\r%60s\r", "");

  bool write_failed = false;
  for (auto& [name, ch] : channels) {
    if (ch.file != nullptr && (std::ferror(ch.file) != 0) + (std::fclose(ch.file) != 0) != 0) {
      std::fprintf(stderr, "hyq-lcm-export: writing '%s' failed (disk full or an I/O error)\n",
                   ch.path.c_str());
      write_failed = true;
    }
    if (!quiet || ch.undecodable != 0)
      std::printf("%-24s %-24s %10" PRIu64 " rows%s", Printable(name).c_str(),
                  ch.type.empty() ? "(unknown type)" : ch.type.c_str(), ch.rows,
                  ch.undecodable != 0 ? "" : "\n");
    if (ch.undecodable != 0) std::printf(", %" PRIu64 " undecodable\n", ch.undecodable);
  }
  std::printf("hyq-lcm-export: %" PRIu64 " messages, %zu channels, %" PRIu64
              " undecodable -> %s\n",
              total, channels.size(), undecodable, out_dir.c_str());
  if (write_failed) return 2;

  int status = 0;
  if (undecodable != 0 && !allow_undecodable) {
    std::fprintf(stderr,
                 "hyq-lcm-export: %" PRIu64 " message(s) could not be decoded with the hyq_lcm "
                 "types (--allow-undecodable to accept)\n",
                 undecodable);
    status = 1;
  }
  if (const hyq::lcm_export::LogDamage& d = reader.damage(); d.any()) {
    std::fprintf(stderr,
                 "hyq-lcm-export: %s is damaged: %" PRIu64 " messages read, %" PRIu64
                 " bad event header(s), %" PRIu64 " resync(s) to the next sync word, %" PRIu64
                 " byte(s) skipped%s; what could be read was exported\n",
                 log_path.c_str(), total, d.bad_records, d.resyncs, d.skipped_bytes,
                 d.truncated ? ", the last event truncated" : "");
    status = 3;
  }
  if (plot) {
    // the source tree's script (build tree), else the installed one
    const fs::path script = hyq::cli::DataFile(HYQ_PLOT_SCRIPT, "plot_lcm_log.py");
    if (!fs::exists(script)) {
      std::fprintf(stderr, "hyq-lcm-export: plot script %s not found\n", script.c_str());
      return status != 0 ? status : 1;
    }
    // absolute, so that an OUT_DIR such as "-h" is not taken for an option
    const int rc = RunPlot(script.string(), fs::absolute(out_dir, ec).string());
    if (rc != 0) {
      std::fprintf(stderr, "hyq-lcm-export: plotting failed (%s on %s: %s)\n", script.c_str(),
                   out_dir.c_str(),
                   rc == -1 ? "could not start /usr/bin/python3"
                   : WIFEXITED(rc) ? ("exit status " + std::to_string(WEXITSTATUS(rc))).c_str()
                                   : "killed by a signal");
      return status != 0 ? status : 1;
    }
  }
  return status;
}
