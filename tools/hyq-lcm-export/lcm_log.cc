#include "tools/hyq-lcm-export/lcm_log.h"

#include <algorithm>
#include <cstdio>

namespace hyq::lcm_export {
namespace {

constexpr std::uint8_t kSyncBytes[4] = {0xED, 0xA1, 0xDA, 0x01};

std::uint32_t Be32(const std::uint8_t* b) {
  return (std::uint32_t{b[0]} << 24) | (std::uint32_t{b[1]} << 16) | (std::uint32_t{b[2]} << 8) |
         std::uint32_t{b[3]};
}

std::uint64_t Be64(const std::uint8_t* b) {
  return (std::uint64_t{Be32(b)} << 32) | Be32(b + 4);
}

}  // namespace

bool LogReader::SyncAt(std::size_t at) const noexcept {
  return log_.size() - at >= 4 && Be32(log_.data() + at) == kLogSync;
}

std::size_t LogReader::FindSync(std::size_t from, std::size_t to) const noexcept {
  if (from >= to) return to;
  const auto it = std::search(log_.begin() + static_cast<std::ptrdiff_t>(from),
                              log_.begin() + static_cast<std::ptrdiff_t>(to), kSyncBytes,
                              kSyncBytes + 4);
  return static_cast<std::size_t>(it - log_.begin());
}

bool LogReader::Next(LogEvent* event) noexcept {
  const std::size_t size = log_.size();
  while (pos_ < size) {
    const std::size_t left = size - pos_;
    if (SyncAt(pos_)) {
      if (left < kLogHeaderBytes) break;  // cut inside the header
      const std::uint8_t* h = log_.data() + pos_;
      const auto channel_len = static_cast<std::int32_t>(Be32(h + 20));
      const auto data_len = static_cast<std::int32_t>(Be32(h + 24));
      bool plausible = channel_len >= 1 && channel_len <= kMaxChannelBytes && data_len >= 0;
      std::size_t end = 0;
      if (plausible) {
        end = pos_ + kLogHeaderBytes + static_cast<std::size_t>(channel_len) +
              static_cast<std::size_t>(data_len);
        if (end > size) {
          // cut short: the last event, unless another follows (then a length is wrong)
          if (FindSync(pos_ + 4, size) == size) break;
          plausible = false;
        } else if (end != size && !SyncAt(end) && FindSync(pos_ + 4, end) != end) {
          // not followed by a sync word but holding one: a length is too long and the event
          // swallowed its successors
          plausible = false;
        }
      }
      if (plausible) {
        event->event_number = static_cast<std::int64_t>(Be64(h + 4));
        event->timestamp_us = static_cast<std::int64_t>(Be64(h + 12));
        event->channel = std::string_view(reinterpret_cast<const char*>(h + kLogHeaderBytes),
                                          static_cast<std::size_t>(channel_len));
        event->data = log_.subspan(pos_ + kLogHeaderBytes + static_cast<std::size_t>(channel_len),
                                   static_cast<std::size_t>(data_len));
        event->offset = pos_;
        pos_ = end;
        return true;
      }
      ++damage_.bad_records;
    } else if (left < 4 && std::equal(log_.begin() + static_cast<std::ptrdiff_t>(pos_),
                                      log_.end(), kSyncBytes)) {
      break;  // cut inside the sync word
    }
    // resync: on to the next sync word (or the end)
    const std::size_t next = FindSync(pos_ + 1, size);
    ++damage_.resyncs;
    damage_.skipped_bytes += next - pos_;
    pos_ = next;
  }
  if (pos_ < size) {
    damage_.truncated = true;
    damage_.skipped_bytes += size - pos_;
    pos_ = size;
  }
  return false;
}

std::string SafeFileName(std::string_view channel) {
  std::string name;
  for (const char c : channel.substr(0, 200)) {
    const bool safe = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                      c == '_' || c == '-' || (c == '.' && !name.empty());
    name += safe ? c : '_';
  }
  return name.empty() ? "_" : name;
}

std::string Printable(std::string_view channel) {
  std::string s;
  for (const char c : channel) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u < 0x7f && c != '\\') {
      s += c;
    } else {
      char b[8];
      std::snprintf(b, sizeof b, "\\x%02x", u);
      s += b;
    }
  }
  return s;
}

}  // namespace hyq::lcm_export
