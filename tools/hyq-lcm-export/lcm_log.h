// Reading an lcm-logger file that may be damaged (a crash mid-write, a bad disk block). Each
// event is, big-endian (LCM's eventlog.c):
//   uint32 sync 0xEDA1DA01, int64 event number, int64 timestamp (µs), int32 channel length,
//   int32 data length, channel bytes, data bytes
// An event is taken when its lengths are plausible and it ends at the end of the log or where a
// sync word follows; otherwise the reader counts the damage and scans for the next sync word, so
// one bad byte costs one event, not the rest of the log. Reads memory (the tool maps the file);
// tests/tools/lcm_log_fuzz.cc calls it on fuzzed bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace hyq::lcm_export {

inline constexpr std::uint32_t kLogSync = 0xEDA1DA01;
inline constexpr std::size_t kLogHeaderBytes = 28;
/// LCM channel names have at most 63 characters; a longer length field is damage.
inline constexpr std::int32_t kMaxChannelBytes = 255;

struct LogEvent {
  std::int64_t event_number = 0;
  std::int64_t timestamp_us = 0;  ///< when lcm-logger received it
  std::string_view channel;       ///< raw bytes: any value, see SafeFileName()
  std::span<const std::uint8_t> data;
  std::size_t offset = 0;  ///< of its sync word in the log
};

/// What was wrong with the log. Any of it makes the export "damaged" (hyq-lcm-export exit 3).
struct LogDamage {
  std::uint64_t resyncs = 0;        ///< scans for the next sync word
  std::uint64_t bad_records = 0;    ///< a sync word with impossible lengths after it
  std::uint64_t skipped_bytes = 0;  ///< not part of any event read
  bool truncated = false;           ///< the last event is cut short
  bool any() const noexcept { return resyncs != 0 || bad_records != 0 || truncated; }
};

class LogReader {
 public:
  explicit LogReader(std::span<const std::uint8_t> log) noexcept : log_(log) {}

  /// The next intact event; false at the end of the log. Never reads outside the log.
  bool Next(LogEvent* event) noexcept;

  std::size_t position() const noexcept { return pos_; }
  const LogDamage& damage() const noexcept { return damage_; }

 private:
  // the offset of the first sync word in [from, to), or `to`
  std::size_t FindSync(std::size_t from, std::size_t to) const noexcept;
  bool SyncAt(std::size_t at) const noexcept;

  std::span<const std::uint8_t> log_;
  std::size_t pos_ = 0;
  LogDamage damage_;
};

/// `channel` as a file name in OUT_DIR: bytes outside [A-Za-z0-9_.-] become '_', and so does a
/// leading '.'; at most 200 bytes; never empty, never a path ("../../x" gives "_._.._x").
std::string SafeFileName(std::string_view channel);

/// `channel` for a terminal: printable ASCII as is, other bytes as \xHH.
std::string Printable(std::string_view channel);

}  // namespace hyq::lcm_export
