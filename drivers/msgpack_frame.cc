#include "drivers/msgpack_frame.h"

#include <bit>
#include <cmath>
#include <cstring>
#include <string_view>

namespace hyq::drivers {
namespace {

using hal::CanFrame;

constexpr std::uint32_t kStdIdMax = 0x7FF;
constexpr std::uint32_t kExtIdMax = 0x1FFFFFFF;
constexpr int kMaxSkipDepth = 8;

// ---- encoder: a cursor into a caller's buffer that goes sticky-bad on overflow ----
class Writer {
 public:
  explicit Writer(std::span<std::uint8_t> out) noexcept : out_(out) {}
  void Byte(std::uint8_t b) noexcept {
    if (pos_ < out_.size()) {
      out_[pos_++] = b;
    } else {
      ok_ = false;
    }
  }
  void BigEndian(std::uint64_t v, int bytes) noexcept {
    for (int i = bytes - 1; i >= 0; --i) Byte(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void Str(std::string_view s) noexcept {  // fixstr: every key is shorter than 32
    Byte(static_cast<std::uint8_t>(0xA0u | s.size()));
    for (char c : s) Byte(static_cast<std::uint8_t>(c));
  }
  void Bool(bool b) noexcept { Byte(b ? 0xC3 : 0xC2); }
  void Uint(std::uint64_t v) noexcept {  // the smallest width, as msgpack-python packs ints
    if (v <= 0x7F) {
      Byte(static_cast<std::uint8_t>(v));
    } else if (v <= 0xFF) {
      Byte(0xCC);
      BigEndian(v, 1);
    } else if (v <= 0xFFFF) {
      Byte(0xCD);
      BigEndian(v, 2);
    } else if (v <= 0xFFFFFFFF) {
      Byte(0xCE);
      BigEndian(v, 4);
    } else {
      Byte(0xCF);
      BigEndian(v, 8);
    }
  }
  void Float64(double d) noexcept {
    Byte(0xCB);
    BigEndian(std::bit_cast<std::uint64_t>(d), 8);
  }
  void Bin(const std::uint8_t* p, std::size_t n) noexcept {  // bin8: n <= 64
    Byte(0xC4);
    Byte(static_cast<std::uint8_t>(n));
    for (std::size_t i = 0; i < n; ++i) Byte(p[i]);
  }
  std::size_t size() const noexcept { return ok_ ? pos_ : 0; }

 private:
  std::span<std::uint8_t> out_;
  std::size_t pos_ = 0;
  bool ok_ = true;
};

// ---- decoder: one scalar value, or a skipped container ----
enum class Kind : std::uint8_t { kNil, kBool, kUint, kInt, kFloat, kStr, kBin, kOther };

struct Value {
  Kind kind = Kind::kNil;
  bool b = false;
  std::uint64_t u = 0;
  std::int64_t i = 0;
  double f = 0.0;
  const std::uint8_t* bytes = nullptr;  // str / bin payload
  std::size_t len = 0;
};

class Reader {
 public:
  explicit Reader(std::span<const std::uint8_t> in) noexcept : in_(in) {}

  bool Need(std::size_t n) const noexcept { return in_.size() - pos_ >= n; }
  std::size_t remaining() const noexcept { return in_.size() - pos_; }

  bool BigEndian(int bytes, std::uint64_t* v) noexcept {
    if (!Need(static_cast<std::size_t>(bytes))) return false;
    std::uint64_t r = 0;
    for (int k = 0; k < bytes; ++k) r = (r << 8) | in_[pos_++];
    *v = r;
    return true;
  }

  bool Payload(std::size_t n, Value* v) noexcept {
    if (!Need(n)) return false;
    v->bytes = in_.data() + pos_;
    v->len = n;
    pos_ += n;
    return true;
  }

  // Reads one value. Arrays, maps and ext types are skipped whole (depth-limited) as kOther.
  MsgpackError Read(Value* v, int depth) noexcept {
    if (depth > kMaxSkipDepth) return MsgpackError::kTooDeep;
    if (!Need(1)) return MsgpackError::kTruncated;
    const std::uint8_t t = in_[pos_++];
    std::uint64_t n = 0;
    *v = Value{};
    if (t <= 0x7F) {
      v->kind = Kind::kUint;
      v->u = t;
      return MsgpackError::kOk;
    }
    if (t >= 0xE0) {
      v->kind = Kind::kInt;
      v->i = static_cast<std::int8_t>(t);
      return MsgpackError::kOk;
    }
    if ((t & 0xE0) == 0xA0) {
      v->kind = Kind::kStr;
      return Payload(t & 0x1Fu, v) ? MsgpackError::kOk : MsgpackError::kTruncated;
    }
    if ((t & 0xF0) == 0x80) return SkipContainer(t & 0x0Fu, 2, v, depth);
    if ((t & 0xF0) == 0x90) return SkipContainer(t & 0x0Fu, 1, v, depth);
    switch (t) {
      case 0xC0: v->kind = Kind::kNil; return MsgpackError::kOk;
      case 0xC2: v->kind = Kind::kBool; v->b = false; return MsgpackError::kOk;
      case 0xC3: v->kind = Kind::kBool; v->b = true; return MsgpackError::kOk;
      case 0xC4: case 0xC5: case 0xC6:
      case 0xD9: case 0xDA: case 0xDB: {
        const bool is_bin = t <= 0xC6;
        const int w = 1 << (is_bin ? t - 0xC4 : t - 0xD9);
        if (!BigEndian(w, &n)) return MsgpackError::kTruncated;
        v->kind = is_bin ? Kind::kBin : Kind::kStr;
        return Payload(n, v) ? MsgpackError::kOk : MsgpackError::kTruncated;
      }
      case 0xCA: {
        if (!BigEndian(4, &n)) return MsgpackError::kTruncated;
        v->kind = Kind::kFloat;
        v->f = static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(n)));
        return MsgpackError::kOk;
      }
      case 0xCB: {
        if (!BigEndian(8, &n)) return MsgpackError::kTruncated;
        v->kind = Kind::kFloat;
        v->f = std::bit_cast<double>(n);
        return MsgpackError::kOk;
      }
      case 0xCC: case 0xCD: case 0xCE: case 0xCF: {
        if (!BigEndian(1 << (t - 0xCC), &n)) return MsgpackError::kTruncated;
        v->kind = Kind::kUint;
        v->u = n;
        return MsgpackError::kOk;
      }
      case 0xD0: case 0xD1: case 0xD2: case 0xD3: {
        const int w = 1 << (t - 0xD0);
        if (!BigEndian(w, &n)) return MsgpackError::kTruncated;
        const int shift = 64 - 8 * w;  // sign-extend the w-byte two's complement value
        v->kind = Kind::kInt;
        v->i = static_cast<std::int64_t>(n << shift) >> shift;
        return MsgpackError::kOk;
      }
      case 0xD4: case 0xD5: case 0xD6: case 0xD7: case 0xD8:  // fixext 1..16
        v->kind = Kind::kOther;
        return Payload(1 + (std::size_t{1} << (t - 0xD4)), v) ? MsgpackError::kOk
                                                                 : MsgpackError::kTruncated;
      case 0xC7: case 0xC8: case 0xC9: {  // ext 8/16/32
        if (!BigEndian(1 << (t - 0xC7), &n)) return MsgpackError::kTruncated;
        v->kind = Kind::kOther;
        if (n > remaining()) return MsgpackError::kTruncated;
        return Payload(n + 1, v) ? MsgpackError::kOk : MsgpackError::kTruncated;
      }
      case 0xDC: case 0xDD: case 0xDE: case 0xDF: {  // array16/32, map16/32
        const int w = (t == 0xDC || t == 0xDE) ? 2 : 4;
        if (!BigEndian(w, &n)) return MsgpackError::kTruncated;
        return SkipContainer(n, t >= 0xDE ? 2 : 1, v, depth);
      }
      default:  // 0xC1 is never used
        return MsgpackError::kBadType;
    }
  }

  std::size_t pos() const noexcept { return pos_; }
  std::uint8_t Peek() const noexcept { return in_[pos_]; }
  void Advance() noexcept { ++pos_; }

 private:
  MsgpackError SkipContainer(std::uint64_t count, int per_entry, Value* v, int depth) noexcept {
    // every element takes at least one byte: a count beyond the rest is a truncation
    if (count > remaining()) return MsgpackError::kTruncated;
    Value inner;
    for (std::uint64_t k = 0; k < count * static_cast<std::uint64_t>(per_entry); ++k) {
      const MsgpackError e = Read(&inner, depth + 1);
      if (e != MsgpackError::kOk) return e;
    }
    *v = Value{};
    v->kind = Kind::kOther;
    return MsgpackError::kOk;
  }

  std::span<const std::uint8_t> in_;
  std::size_t pos_ = 0;
};

bool KeyIs(const Value& key, std::string_view name) noexcept {
  return key.len == name.size() && std::memcmp(key.bytes, name.data(), key.len) == 0;
}

bool AsUint(const Value& v, std::uint64_t* out) noexcept {
  if (v.kind == Kind::kUint) {
    *out = v.u;
    return true;
  }
  if (v.kind == Kind::kInt && v.i >= 0) {
    *out = static_cast<std::uint64_t>(v.i);
    return true;
  }
  return false;
}

}  // namespace

const char* ToString(MsgpackError e) noexcept {
  switch (e) {
    case MsgpackError::kOk: return "ok";
    case MsgpackError::kTruncated: return "truncated datagram";
    case MsgpackError::kNotAMap: return "not a msgpack map";
    case MsgpackError::kBadKey: return "unknown or non-string key";
    case MsgpackError::kBadType: return "value of the wrong type";
    case MsgpackError::kBadValue: return "value out of range";
    case MsgpackError::kMissingField: return "arbitration_id missing";
    case MsgpackError::kTrailingBytes: return "bytes after the map";
    case MsgpackError::kTooDeep: return "nesting too deep";
  }
  return "unknown";
}

bool IsValidFdLength(std::size_t len) noexcept {
  return len <= 8 || len == 12 || len == 16 || len == 20 || len == 24 || len == 32 ||
         len == 48 || len == 64;
}

bool IsValidFrame(const CanFrame& f) noexcept {
  constexpr std::uint8_t kKnown = CanFrame::kExtendedId | CanFrame::kRemote | CanFrame::kError |
                                  CanFrame::kFd | CanFrame::kBitrateSwitch |
                                  CanFrame::kErrorStateIndicator;
  if ((f.flags & ~kKnown) != 0) return false;
  const bool fd = f.is_fd();
  const bool remote = (f.flags & CanFrame::kRemote) != 0;
  if (f.id > (f.is_extended() || f.is_error() ? kExtIdMax : kStdIdMax)) return false;
  if (!fd && (f.flags & (CanFrame::kBitrateSwitch | CanFrame::kErrorStateIndicator)) != 0)
    return false;
  if (remote && (fd || f.is_error())) return false;
  if (f.is_error() && fd) return false;
  return fd ? IsValidFdLength(f.len) : f.len <= hal::kCanClassicMaxData;
}

std::size_t EncodeFrameDatagram(const CanFrame& frame, double timestamp_s,
                                std::span<std::uint8_t> out) noexcept {
  if (!IsValidFrame(frame)) return 0;
  if (!(timestamp_s >= 0.0) || std::isinf(timestamp_s)) timestamp_s = 0.0;  // python-can checks
  const bool remote = (frame.flags & CanFrame::kRemote) != 0;
  Writer w(out);
  w.Byte(0x8B);  // fixmap, 11 entries
  w.Str("timestamp");
  w.Float64(timestamp_s);
  w.Str("arbitration_id");
  w.Uint(frame.id);
  w.Str("is_extended_id");
  w.Bool(frame.is_extended() || (frame.is_error() && frame.id > kStdIdMax));
  w.Str("is_remote_frame");
  w.Bool(remote);
  w.Str("is_error_frame");
  w.Bool(frame.is_error());
  w.Str("channel");
  w.Byte(0xC0);  // nil: python-can's logger then names the channel itself
  w.Str("dlc");
  w.Uint(frame.len);
  w.Str("data");
  w.Bin(frame.data.data(), remote ? 0 : frame.len);  // remote frames carry no data
  w.Str("is_fd");
  w.Bool(frame.is_fd());
  w.Str("bitrate_switch");
  w.Bool((frame.flags & CanFrame::kBitrateSwitch) != 0);
  w.Str("error_state_indicator");
  w.Bool((frame.flags & CanFrame::kErrorStateIndicator) != 0);
  return w.size();
}

MsgpackError DecodeFrameDatagram(std::span<const std::uint8_t> in, CanFrame* frame) noexcept {
  Reader r(in);
  if (!r.Need(1)) return MsgpackError::kTruncated;
  std::uint64_t entries = 0;
  const std::uint8_t t = r.Peek();
  if ((t & 0xF0) == 0x80) {
    entries = t & 0x0Fu;
    r.Advance();
  } else if (t == 0xDE || t == 0xDF) {
    r.Advance();
    if (!r.BigEndian(t == 0xDE ? 2 : 4, &entries)) return MsgpackError::kTruncated;
  } else {
    return MsgpackError::kNotAMap;
  }
  if (entries > r.remaining()) return MsgpackError::kTruncated;

  // python-can Message defaults: extended id unless told otherwise, dlc = len(data)
  bool have_id = false, have_dlc = false, extended = true, remote = false, error = false;
  bool fd = false, brs = false, esi = false;
  std::uint64_t id = 0, dlc = 0;
  const std::uint8_t* data = nullptr;
  std::size_t data_len = 0;

  Value key, v;
  for (std::uint64_t k = 0; k < entries; ++k) {
    MsgpackError e = r.Read(&key, 1);
    if (e != MsgpackError::kOk) return e;
    if (key.kind != Kind::kStr) return MsgpackError::kBadKey;
    e = r.Read(&v, 1);
    if (e != MsgpackError::kOk) return e;

    bool* flag = nullptr;
    if (KeyIs(key, "timestamp")) {
      if (v.kind != Kind::kFloat && v.kind != Kind::kUint && v.kind != Kind::kInt &&
          v.kind != Kind::kNil)
        return MsgpackError::kBadType;
    } else if (KeyIs(key, "arbitration_id")) {
      if (!AsUint(v, &id)) return MsgpackError::kBadType;
      have_id = true;
    } else if (KeyIs(key, "channel")) {
      if (v.kind != Kind::kStr && v.kind != Kind::kNil && v.kind != Kind::kUint &&
          v.kind != Kind::kInt)
        return MsgpackError::kBadType;
    } else if (KeyIs(key, "dlc")) {
      if (v.kind == Kind::kNil) continue;
      if (!AsUint(v, &dlc)) return MsgpackError::kBadType;
      have_dlc = true;
    } else if (KeyIs(key, "data")) {
      if (v.kind == Kind::kNil) {
        data_len = 0;
        continue;
      }
      if (v.kind != Kind::kBin) return MsgpackError::kBadType;
      if (v.len > hal::kCanFdMaxData) return MsgpackError::kBadValue;
      data = v.bytes;
      data_len = v.len;
    } else if (KeyIs(key, "is_extended_id")) {
      flag = &extended;
    } else if (KeyIs(key, "is_remote_frame")) {
      flag = &remote;
    } else if (KeyIs(key, "is_error_frame")) {
      flag = &error;
    } else if (KeyIs(key, "is_fd")) {
      flag = &fd;
    } else if (KeyIs(key, "bitrate_switch")) {
      flag = &brs;
    } else if (KeyIs(key, "error_state_indicator")) {
      flag = &esi;
    } else if (KeyIs(key, "is_rx")) {  // a Message argument too; meaningless on the wire
      if (v.kind != Kind::kBool) return MsgpackError::kBadType;
    } else {
      return MsgpackError::kBadKey;
    }
    if (flag != nullptr) {
      if (v.kind != Kind::kBool) return MsgpackError::kBadType;
      *flag = v.b;
    }
  }
  if (r.remaining() != 0) return MsgpackError::kTrailingBytes;
  if (!have_id) return MsgpackError::kMissingField;
  if (!have_dlc) dlc = remote ? 0 : data_len;

  // python-can's Message._check, plus what a real FD frame can carry
  if (remote && (data_len != 0 || dlc > hal::kCanClassicMaxData)) return MsgpackError::kBadValue;
  if (!remote && dlc != data_len) return MsgpackError::kBadValue;
  if (id > (extended || error ? kExtIdMax : kStdIdMax)) return MsgpackError::kBadValue;

  *frame = CanFrame{};
  frame->id = static_cast<std::uint32_t>(id);
  frame->len = static_cast<std::uint8_t>(dlc);
  frame->flags = static_cast<std::uint8_t>(
      (extended && !error ? CanFrame::kExtendedId : 0) | (remote ? CanFrame::kRemote : 0) |
      (error ? CanFrame::kError : 0) | (fd ? CanFrame::kFd : 0) |
      (brs ? CanFrame::kBitrateSwitch : 0) | (esi ? CanFrame::kErrorStateIndicator : 0));
  if (data_len > 0) std::memcpy(frame->data.data(), data, data_len);
  return IsValidFrame(*frame) ? MsgpackError::kOk : MsgpackError::kBadValue;
}

}  // namespace hyq::drivers
