// Helpers for the drivers tests: child processes with a readable stdout, frame builders, receiving
// and draining channels, writing candump logs, and the network-namespace check. The drivers tests
// are written inside hyq::drivers::testing, so they name these unqualified.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

#include "drivers/candump.h"
#include "hal/can_channel.h"

namespace hyq::drivers::testing {

/// True inside tests/drivers/in_netns.sh (a private network namespace).
bool InPrivateNetns();

#define HYQ_REQUIRE_PRIVATE_NETNS()                                                          \
  do {                                                                                       \
    if (!::hyq::drivers::testing::InPrivateNetns())                                          \
      GTEST_SKIP() << "not inside a private network namespace (run through ctest, which "    \
                      "wraps this test in tests/drivers/in_netns.sh = unshare -n); multicast " \
                      "tests never run on the host network";                                 \
  } while (false)

/// A child process whose stdout (and stderr, when asked) we read line by line.
class Child {
 public:
  explicit Child(const std::vector<std::string>& argv, bool merge_stderr = false);
  ~Child();
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  /// Next stdout line (without '\n'); false on EOF or when `timeout` passes first.
  bool ReadLine(std::string* line, std::chrono::milliseconds timeout);
  /// Reads lines until one starts with `prefix`; false on EOF/timeout. Lines read go to *seen.
  bool WaitForLine(const std::string& prefix, std::chrono::milliseconds timeout,
                   std::string* seen = nullptr);
  void Signal(int sig);
  /// Waits for exit; returns the exit status (128+signal when killed), -1 on timeout (then kills).
  int Wait(std::chrono::milliseconds timeout);
  int pid() const { return pid_; }

 private:
  int pid_ = -1;
  int out_fd_ = -1;
  std::string buffer_;
  bool reaped_ = false;
  int status_ = 0;
};

/// Runs a command to completion, returning its exit status and stdout+stderr.
int RunCommand(const std::vector<std::string>& argv, std::string* output,
               std::chrono::milliseconds timeout = std::chrono::seconds(30));

hal::CanFrame Classic(std::uint32_t id, std::initializer_list<std::uint8_t> data,
                      bool extended = false);
hal::CanFrame Fd(std::uint32_t id, std::size_t len, std::uint8_t seed, bool brs = true,
                 bool esi = false, bool extended = false);
hal::CanFrame Remote(std::uint32_t id, std::uint8_t len, bool extended = false);
hal::CanFrame Error(std::uint32_t error_class, std::initializer_list<std::uint8_t> data);

/// Equal id, flags, len and payload (the timestamp is not compared).
::testing::AssertionResult SameFrame(const hal::CanFrame& a, const hal::CanFrame& b);
std::string Describe(const hal::CanFrame& f);

/// Receives from `ch`, `chunk` frames per call, until `n` frames arrived or `timeout` passed
/// (every Receive is expected to return kOk).
std::vector<hal::CanFrame> ReceiveN(hal::CanChannel& ch, std::size_t n,
                                    std::chrono::milliseconds timeout = std::chrono::seconds(10),
                                    std::size_t chunk = 16);
/// After `settle`, receives until nothing is left; returns how many frames that was.
std::size_t Drain(hal::CanChannel& ch,
                  std::chrono::milliseconds settle = std::chrono::milliseconds(0));

/// The no-heap proof of a channel pair: after a warm-up round, `rounds` times one Send of `burst`
/// on `tx` and Receives on `rx` until all of it arrived, each round under a NoHeapGuard. Fails
/// naming the round where a call did not return kOk, a frame was missing or the heap was used.
::testing::AssertionResult RoundTripsWithoutHeap(hal::CanChannel& tx, hal::CanChannel& rx,
                                                 const std::vector<hal::CanFrame>& burst,
                                                 int rounds);

/// Writes every frame to `w`, stamped 1 ms apart from 1'700'000'001'000'000'000 ns on; false when
/// the writer refused one.
bool WriteLog(CandumpWriter& w, const std::vector<hal::CanFrame>& frames);

/// A port no other test in this namespace uses (tests run one process per namespace anyway).
std::uint16_t TestPort(int k = 0);

}  // namespace hyq::drivers::testing
