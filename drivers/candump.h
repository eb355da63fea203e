// candump log files (`candump -L`, python-can's .log): one frame per line,
//   (1700000000.123456) vcan0 123#DEADBEEF          classic, 11-bit id (3 hex digits)
//   (1700000000.123456) vcan0 1F334455#00           classic, 29-bit id (8 hex digits)
//   (1700000000.123456) vcan0 123#R                 remote frame (R<len> with a requested length)
//   (1700000000.123456) vcan0 123##1112233          FD frame: `##`, one flags digit (1 BRS,
//                                                    2 ESI), then the data
//   (1700000000.123456) vcan0 20000004#0004000000000000   error frame: CAN_ERR_FLAG | class
// python-can's writer appends a direction, ` R` (received) or ` T` (transmitted); the reader
// accepts it. The writer emits what candump emits, which can-utils' canplayer and log2asc read.
//
// Formatting and parsing one line neither allocate nor throw; CandumpWriter writes through a
// buffer it owns, so recording in a cycle does not allocate either (the file write itself can
// block: record from a non-RT thread or accept that). Reading a file is configuration work and
// throws or collects errors naming the file and line.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "hal/can_channel.h"

namespace hyq::drivers {

/// Longest line the formatter writes: timestamp, 15-char interface, 8-digit id, `##F`, 64 bytes.
inline constexpr std::size_t kMaxCandumpLine = 192;
inline constexpr std::size_t kMaxIfaceName = 15;  // IFNAMSIZ - 1

/// SocketCAN's error-frame flag and class mask (linux/can.h CAN_ERR_FLAG, CAN_ERR_MASK).
inline constexpr std::uint32_t kCanErrFlag = 0x20000000u;
inline constexpr std::uint32_t kCanErrMask = 0x1FFFFFFFu;

/// Writes one line (with '\n') for `frame` received at `frame.timestamp_ns` on `iface` into
/// `out`; returns its length, or 0 when the frame is invalid, the name is empty, longer than 15
/// or contains whitespace, or `out` is too small.
std::size_t FormatCandumpLine(const hal::CanFrame& frame, std::string_view iface,
                              std::span<char> out) noexcept;

/// One parsed line.
struct CandumpRecord {
  hal::CanFrame frame;        // timestamp_ns holds the logged time
  char iface[kMaxIfaceName + 1] = {};
  char direction = 0;         // 'R', 'T' or 0 when the line has none
  std::string_view iface_name() const noexcept { return iface; }
};

/// Parses one line (without or with its '\n' / "\r\n"). On failure returns false and points
/// `*why` at a static description of the first problem.
bool ParseCandumpLine(std::string_view line, CandumpRecord* record, const char** why) noexcept;

/// A whole log, with what was wrong in it.
struct CandumpLog {
  std::vector<CandumpRecord> records;
  std::size_t malformed_lines = 0;
  std::vector<std::string> errors;  // "file:line: why: 'text'" for the first 100 bad lines
};

enum class MalformedLines { kThrow, kSkipAndCount };

/// The largest log ReadCandumpFile() reads (it holds the whole text, then the records).
inline constexpr std::size_t kMaxCandumpFileBytes = std::size_t{2} << 30;

/// Reads a log file (a regular file or a pipe, at most kMaxCandumpFileBytes). Blank lines are
/// skipped. With kThrow the first malformed line throws
/// ChannelError("<path>:<line>: <why>: '<line>'"); with kSkipAndCount it is counted and skipped.
/// A file that cannot be opened always throws.
CandumpLog ReadCandumpFile(const std::string& path,
                           MalformedLines policy = MalformedLines::kThrow);

/// The same for text in memory; `source_name` stands for the file name in messages.
CandumpLog ReadCandumpText(std::string_view text, std::string_view source_name,
                           MalformedLines policy = MalformedLines::kThrow);

/// Appends frames to a candump log through a buffer allocated at open.
class CandumpWriter {
 public:
  /// Creates/truncates `path` (throws ChannelError). `iface` names the bus in every line
  /// unless Write() is given another.
  CandumpWriter(const std::string& path, std::string iface);
  /// Writes to an already open stream (e.g. stdout); the writer does not close it.
  CandumpWriter(std::FILE* stream, std::string iface);
  ~CandumpWriter();
  CandumpWriter(const CandumpWriter&) = delete;
  CandumpWriter& operator=(const CandumpWriter&) = delete;

  /// Formats and buffers one line; false (and counts in failed()) for an invalid frame or a
  /// failed write. Never allocates.
  bool Write(const hal::CanFrame& frame) noexcept;
  bool Write(const hal::CanFrame& frame, std::string_view iface) noexcept;
  /// Pushes buffered lines to the file; false on a write error.
  bool Flush() noexcept;

  std::uint64_t written() const noexcept { return written_; }
  std::uint64_t failed() const noexcept { return failed_; }

 private:
  std::FILE* file_ = nullptr;
  bool owns_file_ = false;
  std::string iface_;
  std::unique_ptr<char[]> stdio_buffer_;
  std::uint64_t written_ = 0;
  std::uint64_t failed_ = 0;
};

/// A recorded bus played back as a channel: Receive() hands out the logged frames in file order.
/// With ReplayTiming::kAsFast every frame is due at once; with kRealTime a frame is due when as
/// much CLOCK_MONOTONIC time has passed since the first Receive() as separates it from the first
/// logged frame. Frames keep their logged timestamps. Send() accepts and counts (tx_frames)
/// everything valid and drops it. Past the end Receive() returns kOk with nothing (finished()).
enum class ReplayTiming { kAsFast, kRealTime };

class ReplayChannel final : public hal::CanChannel {
 public:
  /// `iface` empty replays every line; otherwise only lines logged on that interface.
  ReplayChannel(std::vector<CandumpRecord> records, std::string iface, ReplayTiming timing,
                bool fd, std::string name);
  /// Reads `path` (malformed lines throw) and replays it.
  static std::unique_ptr<ReplayChannel> FromFile(const std::string& path, std::string iface = {},
                                                 ReplayTiming timing = ReplayTiming::kAsFast);

  hal::CanStatus Send(std::span<const hal::CanFrame> frames, std::size_t* sent) noexcept override;
  hal::CanStatus Receive(std::span<hal::CanFrame> out, std::size_t* received) noexcept override;
  const hal::CanCounters& counters() const noexcept override { return counters_; }
  bool fd_enabled() const noexcept override { return fd_; }
  std::string_view name() const noexcept override { return name_; }

  bool finished() const noexcept { return next_ >= records_.size(); }
  std::size_t size() const noexcept { return records_.size(); }
  /// Starts again from the first frame (and, for kRealTime, restarts the clock).
  void Rewind() noexcept;

 private:
  std::vector<CandumpRecord> records_;
  ReplayTiming timing_;
  bool fd_;
  std::string name_;
  std::size_t next_ = 0;
  std::int64_t start_mono_ns_ = -1;
  hal::CanCounters counters_;
};

/// Forwards to another channel and writes every frame it sends and receives to a CandumpWriter
/// (received frames with their receive time, sent ones with the time of Send()). "Record any
/// bus": wrap the channel the HAL uses.
class RecordingChannel final : public hal::CanChannel {
 public:
  RecordingChannel(hal::CanChannel* inner, CandumpWriter* writer, bool record_sent = true);

  hal::CanStatus Send(std::span<const hal::CanFrame> frames, std::size_t* sent) noexcept override;
  hal::CanStatus Receive(std::span<hal::CanFrame> out, std::size_t* received) noexcept override;
  const hal::CanCounters& counters() const noexcept override { return inner_->counters(); }
  bool fd_enabled() const noexcept override { return inner_->fd_enabled(); }
  std::string_view name() const noexcept override { return inner_->name(); }

 private:
  hal::CanChannel* inner_;
  CandumpWriter* writer_;
  bool record_sent_;
};

}  // namespace hyq::drivers
