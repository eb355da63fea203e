#include "drivers/candump.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <utility>

#include "drivers/channel_error.h"
#include "drivers/msgpack_frame.h"
#include "drivers/socket_util.h"
#include "hal/clock.h"

namespace hyq::drivers {
namespace {

using hal::CanFrame;
using hal::CanStatus;

constexpr char kHex[] = "0123456789ABCDEF";
constexpr std::size_t kMaxReportedErrors = 100;
constexpr std::size_t kWriterBufferBytes = 64 * 1024;

int HexValue(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

bool IsSpace(char c) noexcept { return c == ' ' || c == '\t'; }

// interface names in a log: printable ASCII without spaces (what IFNAMSIZ names look like)
bool IsIfaceChar(char c) noexcept { return c > ' ' && c < 0x7F; }

// a tiny bounded output cursor
class Out {
 public:
  explicit Out(std::span<char> buf) noexcept : buf_(buf) {}
  void Put(char c) noexcept {
    if (pos_ < buf_.size()) {
      buf_[pos_++] = c;
    } else {
      ok_ = false;
    }
  }
  void Hex(std::uint64_t v, int digits) noexcept {
    for (int i = digits - 1; i >= 0; --i) Put(kHex[(v >> (4 * i)) & 0xF]);
  }
  void Dec(std::uint64_t v, int min_digits) noexcept {
    char tmp[24];
    int n = 0;
    do {
      tmp[n++] = static_cast<char>('0' + v % 10);
      v /= 10;
    } while (v != 0);
    for (int i = n; i < min_digits; ++i) Put('0');
    while (n > 0) Put(tmp[--n]);
  }
  void Str(std::string_view s) noexcept {
    for (char c : s) Put(c);
  }
  std::size_t size() const noexcept { return ok_ ? pos_ : 0; }

 private:
  std::span<char> buf_;
  std::size_t pos_ = 0;
  bool ok_ = true;
};

std::string Quoted(std::string_view line) {
  constexpr std::size_t kMaxShown = 120;
  std::string s = "'";
  for (char c : line.substr(0, kMaxShown)) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u < 0x7F) {
      s += c;
    } else {
      s += "\\x";
      s += kHex[u >> 4];
      s += kHex[u & 0xF];
    }
  }
  if (line.size() > kMaxShown) s += "...";
  return s + "'";
}

}  // namespace

std::size_t FormatCandumpLine(const CanFrame& frame, std::string_view iface,
                              std::span<char> out) noexcept {
  if (!IsValidFrame(frame) || iface.empty() || iface.size() > kMaxIfaceName) return 0;
  for (char c : iface)
    if (!IsIfaceChar(c)) return 0;
  std::int64_t t = frame.timestamp_ns < 0 ? 0 : frame.timestamp_ns;
  Out o(out);
  o.Put('(');
  o.Dec(static_cast<std::uint64_t>(t / 1'000'000'000), 10);
  o.Put('.');
  o.Dec(static_cast<std::uint64_t>(t % 1'000'000'000 / 1000), 6);
  o.Str(") ");
  o.Str(iface);
  o.Put(' ');
  if (frame.is_error()) {
    o.Hex((frame.id & kCanErrMask) | kCanErrFlag, 8);
  } else if (frame.is_extended()) {
    o.Hex(frame.id, 8);
  } else {
    o.Hex(frame.id, 3);
  }
  o.Put('#');
  if (frame.is_fd()) {
    o.Put('#');
    o.Hex(((frame.flags & CanFrame::kBitrateSwitch) ? 1u : 0u) |
              ((frame.flags & CanFrame::kErrorStateIndicator) ? 2u : 0u),
          1);
  } else if ((frame.flags & CanFrame::kRemote) != 0) {
    o.Put('R');
    if (frame.len > 0) o.Dec(frame.len, 1);
    o.Put('\n');
    return o.size();
  }
  for (std::size_t i = 0; i < frame.len; ++i) o.Hex(frame.data[i], 2);
  o.Put('\n');
  return o.size();
}

bool ParseCandumpLine(std::string_view line, CandumpRecord* rec, const char** why) noexcept {
  const auto fail = [why](const char* w) {
    *why = w;
    return false;
  };
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r' || IsSpace(line.back())))
    line.remove_suffix(1);
  *rec = CandumpRecord{};
  std::size_t p = 0;
  const auto at = [&line, &p]() noexcept { return p < line.size() ? line[p] : '\0'; };

  // (seconds.fraction)
  if (at() != '(') return fail("expected '(' opening the timestamp");
  ++p;
  std::uint64_t sec = 0;
  int digits = 0;
  while (at() >= '0' && at() <= '9') {
    if (++digits > 12) return fail("timestamp seconds too long");
    sec = sec * 10 + static_cast<std::uint64_t>(at() - '0');
    ++p;
  }
  if (digits == 0) return fail("expected timestamp seconds");
  if (at() != '.') return fail("expected '.' in the timestamp");
  ++p;
  std::uint64_t frac_ns = 0;
  digits = 0;
  while (at() >= '0' && at() <= '9') {
    if (++digits > 9) return fail("timestamp fraction longer than 9 digits");
    frac_ns = frac_ns * 10 + static_cast<std::uint64_t>(at() - '0');
    ++p;
  }
  if (digits == 0) return fail("expected timestamp fraction digits");
  for (int i = digits; i < 9; ++i) frac_ns *= 10;
  if (at() != ')') return fail("expected ')' closing the timestamp");
  ++p;
  rec->frame.timestamp_ns = static_cast<std::int64_t>(sec * 1'000'000'000 + frac_ns);

  // interface
  if (!IsSpace(at())) return fail("expected a space after the timestamp");
  while (IsSpace(at())) ++p;
  std::size_t n = 0;
  while (p < line.size() && !IsSpace(line[p])) {
    if (n >= kMaxIfaceName) return fail("interface name longer than 15 characters");
    if (!IsIfaceChar(line[p])) return fail("control or non-ASCII byte in the interface name");
    rec->iface[n++] = line[p++];
  }
  if (n == 0) return fail("expected an interface name");
  if (!IsSpace(at())) return fail("expected a space after the interface name");
  while (IsSpace(at())) ++p;

  // identifier: 3 hex digits (11-bit) or 8 (29-bit, or CAN_ERR_FLAG | error class)
  std::uint32_t id = 0;
  digits = 0;
  while (HexValue(at()) >= 0) {
    if (++digits > 8) return fail("identifier longer than 8 hex digits");
    id = (id << 4) | static_cast<std::uint32_t>(HexValue(at()));
    ++p;
  }
  if (at() != '#') return fail("expected hex identifier then '#'");
  ++p;
  CanFrame& f = rec->frame;
  if (digits == 3) {
    if (id > 0x7FF) return fail("11-bit identifier above 7FF");
    f.id = id;
  } else if (digits == 8) {
    if ((id & kCanErrFlag) != 0) {
      if ((id & ~(kCanErrFlag | kCanErrMask)) != 0)
        return fail("error frame identifier with EFF/RTR bits set");
      f.id = id & kCanErrMask;
      f.flags |= CanFrame::kError;
    } else if (id > kCanErrMask) {
      return fail("29-bit identifier above 1FFFFFFF");
    } else {
      f.id = id;
      f.flags |= CanFrame::kExtendedId;
    }
  } else {
    return fail("identifier must have 3 (11-bit) or 8 (29-bit) hex digits");
  }

  // payload
  std::size_t max_len = hal::kCanClassicMaxData;
  if (at() == '#') {
    ++p;
    const int flags = HexValue(at());
    if (flags < 0) return fail("expected an FD flags hex digit after '##'");
    ++p;
    if (f.is_error()) return fail("error frame cannot be an FD frame");
    f.flags |= CanFrame::kFd;
    if (flags & 1) f.flags |= CanFrame::kBitrateSwitch;
    if (flags & 2) f.flags |= CanFrame::kErrorStateIndicator;
    max_len = hal::kCanFdMaxData;
  } else if (at() == 'R' || at() == 'r') {
    ++p;
    if (f.is_error()) return fail("error frame cannot be a remote frame");
    f.flags |= CanFrame::kRemote;
    if (at() >= '0' && at() <= '8') {
      f.len = static_cast<std::uint8_t>(at() - '0');
      ++p;
    }
  }
  if ((f.flags & CanFrame::kRemote) == 0) {
    while (p < line.size() && !IsSpace(line[p])) {
      if (line[p] == '.') {  // candump's optional byte separator
        ++p;
        continue;
      }
      const int hi = HexValue(line[p]);
      const int lo = p + 1 < line.size() ? HexValue(line[p + 1]) : -1;
      if (hi < 0 || lo < 0) return fail("expected data as pairs of hex digits");
      if (f.len >= max_len) return fail("too many data bytes for the frame type");
      f.data[f.len++] = static_cast<std::uint8_t>(hi << 4 | lo);
      p += 2;
    }
    if (f.is_fd() && !IsValidFdLength(f.len))
      return fail("FD data length is not one of 0-8, 12, 16, 20, 24, 32, 48, 64");
  }

  // optional direction (python-can): " R" or " T"
  if (p < line.size()) {
    if (!IsSpace(line[p])) return fail("unexpected character after the frame");
    while (IsSpace(at())) ++p;
    if (p + 1 == line.size() && (line[p] == 'R' || line[p] == 'T')) {
      rec->direction = line[p];
    } else {
      return fail("unexpected text after the frame (only a direction R or T may follow)");
    }
  }
  if (!IsValidFrame(f)) return fail("not a valid CAN frame");
  return true;
}

CandumpLog ReadCandumpText(std::string_view text, std::string_view source_name,
                           MalformedLines policy) {
  CandumpLog log;
  std::size_t line_no = 0;
  while (!text.empty()) {
    const std::size_t eol = text.find('\n');
    std::string_view line = text.substr(0, eol);
    text.remove_prefix(eol == std::string_view::npos ? text.size() : eol + 1);
    ++line_no;
    std::string_view trimmed = line;
    while (!trimmed.empty() && (IsSpace(trimmed.back()) || trimmed.back() == '\r'))
      trimmed.remove_suffix(1);
    if (trimmed.empty()) continue;
    CandumpRecord rec;
    const char* why = "";
    if (ParseCandumpLine(line, &rec, &why)) {
      log.records.push_back(rec);
      continue;
    }
    std::string msg = std::string(source_name) + ":" + std::to_string(line_no) + ": " + why +
                      ": " + Quoted(line);
    if (policy == MalformedLines::kThrow) throw ChannelError(msg);
    ++log.malformed_lines;
    if (log.errors.size() < kMaxReportedErrors) log.errors.push_back(std::move(msg));
  }
  return log;
}

CandumpLog ReadCandumpFile(const std::string& path, MalformedLines policy) {
  // the whole file is held in memory: /dev/zero (or any device) would never end
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISFIFO(st.st_mode))
    throw ChannelError("candump log " + path + ": expected a regular file, found " +
                       (S_ISDIR(st.st_mode)   ? "a directory"
                        : S_ISCHR(st.st_mode) ? "a character device"
                                              : "another kind of file"));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ChannelError(SystemErrorText("candump log " + path + ": cannot open", errno));
  std::string all;
  char buf[65536];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    if (all.size() + static_cast<std::size_t>(in.gcount()) > kMaxCandumpFileBytes)
      throw ChannelError("candump log " + path + ": expected at most " +
                         std::to_string(kMaxCandumpFileBytes >> 20) + " MiB, found more");
    all.append(buf, static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) throw ChannelError("candump log " + path + ": read error");
  return ReadCandumpText(all, path, policy);
}

// ---- writer ----

CandumpWriter::CandumpWriter(const std::string& path, std::string iface)
    : iface_(std::move(iface)) {
  file_ = std::fopen(path.c_str(), "w");
  if (file_ == nullptr)
    throw ChannelError(SystemErrorText("candump log " + path + ": cannot create", errno));
  owns_file_ = true;
  stdio_buffer_ = std::make_unique<char[]>(kWriterBufferBytes);
  std::setvbuf(file_, stdio_buffer_.get(), _IOFBF, kWriterBufferBytes);
}

CandumpWriter::CandumpWriter(std::FILE* stream, std::string iface)
    : file_(stream), iface_(std::move(iface)) {
  stdio_buffer_ = std::make_unique<char[]>(kWriterBufferBytes);
  std::setvbuf(file_, stdio_buffer_.get(), _IOFBF, kWriterBufferBytes);
}

CandumpWriter::~CandumpWriter() {
  if (file_ == nullptr) return;
  std::fflush(file_);
  if (owns_file_) {
    std::fclose(file_);
  } else {
    std::setvbuf(file_, nullptr, _IOLBF, 0);  // our buffer dies with us
  }
}

bool CandumpWriter::Write(const CanFrame& frame) noexcept { return Write(frame, iface_); }

bool CandumpWriter::Write(const CanFrame& frame, std::string_view iface) noexcept {
  char line[kMaxCandumpLine];
  const std::size_t n = FormatCandumpLine(frame, iface, line);
  if (n == 0 || std::fwrite(line, 1, n, file_) != n) {
    ++failed_;
    return false;
  }
  ++written_;
  return true;
}

bool CandumpWriter::Flush() noexcept { return std::fflush(file_) == 0; }

// ---- replay ----

ReplayChannel::ReplayChannel(std::vector<CandumpRecord> records, std::string iface,
                             ReplayTiming timing, bool fd, std::string name)
    : timing_(timing), fd_(fd), name_(std::move(name)) {
  for (CandumpRecord& r : records)
    if (iface.empty() || r.iface_name() == iface) records_.push_back(r);
}

std::unique_ptr<ReplayChannel> ReplayChannel::FromFile(const std::string& path, std::string iface,
                                                       ReplayTiming timing) {
  CandumpLog log = ReadCandumpFile(path, MalformedLines::kThrow);
  return std::make_unique<ReplayChannel>(std::move(log.records), std::move(iface), timing, true,
                                         "replay:" + path);
}

void ReplayChannel::Rewind() noexcept {
  next_ = 0;
  start_mono_ns_ = -1;
}

CanStatus ReplayChannel::Send(std::span<const CanFrame> frames, std::size_t* sent) noexcept {
  *sent = 0;
  for (const CanFrame& f : frames) {
    if (!IsValidFrame(f) || (f.is_fd() && !fd_)) {
      ++counters_.bad_frames;
      return CanStatus::kBadFrame;
    }
    ++*sent;
    ++counters_.tx_frames;
  }
  return CanStatus::kOk;
}

CanStatus ReplayChannel::Receive(std::span<CanFrame> out, std::size_t* received) noexcept {
  *received = 0;
  if (records_.empty()) return CanStatus::kOk;
  std::int64_t due_offset_ns = INT64_MAX;
  if (timing_ == ReplayTiming::kRealTime) {
    const std::int64_t now = MonotonicNs();
    if (start_mono_ns_ < 0) start_mono_ns_ = now;
    due_offset_ns = now - start_mono_ns_;
  }
  const std::int64_t t0 = records_.front().frame.timestamp_ns;
  while (*received < out.size() && next_ < records_.size()) {
    const CanFrame& f = records_[next_].frame;
    if (f.timestamp_ns - t0 > due_offset_ns) break;
    ++next_;
    if (f.is_fd() && !fd_) {
      ++counters_.bad_frames;
      continue;
    }
    if (f.is_error()) ++counters_.error_frames;
    out[(*received)++] = f;
    ++counters_.rx_frames;
  }
  return CanStatus::kOk;
}

// ---- recording ----

RecordingChannel::RecordingChannel(hal::CanChannel* inner, CandumpWriter* writer,
                                   bool record_sent)
    : inner_(inner), writer_(writer), record_sent_(record_sent) {}

CanStatus RecordingChannel::Send(std::span<const CanFrame> frames, std::size_t* sent) noexcept {
  const CanStatus s = inner_->Send(frames, sent);
  if (record_sent_) {
    const std::int64_t now_ns = internal::RealtimeNs();
    for (std::size_t i = 0; i < *sent; ++i) {
      CanFrame f = frames[i];
      f.timestamp_ns = now_ns;
      (void)writer_->Write(f);
    }
  }
  return s;
}

CanStatus RecordingChannel::Receive(std::span<CanFrame> out, std::size_t* received) noexcept {
  const CanStatus s = inner_->Receive(out, received);
  for (std::size_t i = 0; i < *received; ++i) (void)writer_->Write(out[i]);
  return s;
}

}  // namespace hyq::drivers
