#include "drivers/channel_setup.h"

#include <chrono>
#include <string>
#include <thread>

#include "drivers/channel_error.h"

namespace hyq::drivers {
namespace {

[[noreturn]] void Throw(const hal::CanChannel& ch, const std::string& what, hal::CanStatus s) {
  std::string msg = std::string(ch.name()) + ": " + what + ": " + hal::ToString(s);
  if (s == hal::CanStatus::kIoError)
    msg += " (" + SystemErrorText("errno " + std::to_string(ch.counters().last_errno),
                                  ch.counters().last_errno) + ")";
  throw ChannelError(msg);
}

}  // namespace

void SendAllOrThrow(hal::CanChannel& channel, std::span<const hal::CanFrame> frames,
                    int retry_ms) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(retry_ms);
  std::size_t done = 0;
  while (done < frames.size()) {
    std::size_t sent = 0;
    const hal::CanStatus s = channel.Send(frames.subspan(done), &sent);
    done += sent;
    if (s == hal::CanStatus::kOk) continue;
    if (s == hal::CanStatus::kWouldBlock && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::microseconds(100));
      continue;
    }
    Throw(channel,
          "send of frame " + std::to_string(done + 1) + " of " + std::to_string(frames.size()) +
              " failed",
          s);
  }
}

std::size_t ReceiveOrThrow(hal::CanChannel& channel, std::span<hal::CanFrame> out) {
  std::size_t n = 0;
  const hal::CanStatus s = channel.Receive(out, &n);
  if (s != hal::CanStatus::kOk) Throw(channel, "receive failed", s);
  return n;
}

}  // namespace hyq::drivers
