#include "tests/drivers/test_util.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <thread>

#include "tests/support/no_heap_guard.h"

extern char** environ;

namespace hyq::drivers::testing {

using hal::CanFrame;

bool InPrivateNetns() {
  const char* v = std::getenv("HYQ_NETNS");
  return v != nullptr && std::string(v) == "1";
}

Child::Child(const std::vector<std::string>& argv, bool merge_stderr) {
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error("pipe2 failed");
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, fds[1], 1);
  if (merge_stderr) posix_spawn_file_actions_adddup2(&fa, fds[1], 2);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const int rc = posix_spawnp(&pid_, args[0], &fa, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  close(fds[1]);
  out_fd_ = fds[0];
  if (rc != 0) {
    close(out_fd_);
    out_fd_ = -1;
    pid_ = -1;
    throw std::runtime_error("cannot start " + argv[0] + ": " + std::strerror(rc));
  }
}

Child::~Child() {
  if (pid_ > 0 && !reaped_) {
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
  }
  if (out_fd_ >= 0) close(out_fd_);
}

bool Child::ReadLine(std::string* line, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const std::size_t nl = buffer_.find('\n');
    if (nl != std::string::npos) {
      *line = buffer_.substr(0, nl);
      buffer_.erase(0, nl + 1);
      return true;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0 || out_fd_ < 0) return false;
    pollfd p{out_fd_, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left.count())) <= 0) return false;
    char buf[4096];
    const ssize_t n = read(out_fd_, buf, sizeof buf);
    if (n <= 0) {
      if (!buffer_.empty()) {
        *line = buffer_;
        buffer_.clear();
        return true;
      }
      return false;
    }
    buffer_.append(buf, static_cast<std::size_t>(n));
  }
}

bool Child::WaitForLine(const std::string& prefix, std::chrono::milliseconds timeout,
                        std::string* seen) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::string line;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    if (!ReadLine(&line, left)) return false;
    if (seen != nullptr) *seen += line + "\n";
    if (line.rfind(prefix, 0) == 0) return true;
  }
}

void Child::Signal(int sig) {
  if (pid_ > 0 && !reaped_) kill(pid_, sig);
}

int Child::Wait(std::chrono::milliseconds timeout) {
  if (reaped_) return status_;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  int st = 0;
  for (;;) {
    const pid_t r = waitpid(pid_, &st, WNOHANG);
    if (r == pid_) break;
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
      reaped_ = true;
      status_ = -1;
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  reaped_ = true;
  status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  return status_;
}

int RunCommand(const std::vector<std::string>& argv, std::string* output,
               std::chrono::milliseconds timeout) {
  Child c(argv, true);
  std::string line;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (c.ReadLine(&line, std::chrono::duration_cast<std::chrono::milliseconds>(
                               deadline - std::chrono::steady_clock::now())))
    *output += line + "\n";
  return c.Wait(std::chrono::duration_cast<std::chrono::milliseconds>(
      deadline - std::chrono::steady_clock::now() + std::chrono::seconds(1)));
}

CanFrame Classic(std::uint32_t id, std::initializer_list<std::uint8_t> data, bool extended) {
  CanFrame f;
  f.id = id;
  f.flags = extended ? CanFrame::kExtendedId : 0;
  for (std::uint8_t b : data) f.data[f.len++] = b;
  return f;
}

CanFrame Fd(std::uint32_t id, std::size_t len, std::uint8_t seed, bool brs, bool esi,
            bool extended) {
  CanFrame f;
  f.id = id;
  f.flags = static_cast<std::uint8_t>(CanFrame::kFd | (brs ? CanFrame::kBitrateSwitch : 0) |
                                      (esi ? CanFrame::kErrorStateIndicator : 0) |
                                      (extended ? CanFrame::kExtendedId : 0));
  f.len = static_cast<std::uint8_t>(len);
  for (std::size_t i = 0; i < len; ++i) f.data[i] = static_cast<std::uint8_t>(seed + 7 * i);
  return f;
}

CanFrame Remote(std::uint32_t id, std::uint8_t len, bool extended) {
  CanFrame f;
  f.id = id;
  f.len = len;
  f.flags = static_cast<std::uint8_t>(CanFrame::kRemote | (extended ? CanFrame::kExtendedId : 0));
  return f;
}

CanFrame Error(std::uint32_t error_class, std::initializer_list<std::uint8_t> data) {
  CanFrame f = Classic(error_class, data);
  f.flags = CanFrame::kError;
  return f;
}

std::string Describe(const CanFrame& f) {
  std::ostringstream s;
  s << std::hex << "id=0x" << f.id << " flags=0x" << int{f.flags} << std::dec
    << " len=" << int{f.len} << " data=";
  const bool remote = (f.flags & CanFrame::kRemote) != 0;
  for (std::size_t i = 0; !remote && i < f.len; ++i) {
    static const char* hex = "0123456789abcdef";
    s << hex[f.data[i] >> 4] << hex[f.data[i] & 15];
  }
  return s.str();
}

::testing::AssertionResult SameFrame(const CanFrame& a, const CanFrame& b) {
  bool same = a.id == b.id && a.flags == b.flags && a.len == b.len;
  if (same && (a.flags & CanFrame::kRemote) == 0)
    same = std::memcmp(a.data.data(), b.data.data(), a.len) == 0;
  if (same) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << Describe(a) << " != " << Describe(b);
}

std::vector<CanFrame> ReceiveN(hal::CanChannel& ch, std::size_t n,
                               std::chrono::milliseconds timeout, std::size_t chunk) {
  std::vector<CanFrame> got;
  std::vector<CanFrame> buf(chunk);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (got.size() < n && std::chrono::steady_clock::now() < deadline) {
    std::size_t k = 0;
    EXPECT_EQ(ch.Receive(buf, &k), hal::CanStatus::kOk);
    got.insert(got.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(k));
    if (k == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return got;
}

std::size_t Drain(hal::CanChannel& ch, std::chrono::milliseconds settle) {
  std::this_thread::sleep_for(settle);
  std::vector<CanFrame> buf(64);
  std::size_t total = 0, k = 0;
  do {
    EXPECT_EQ(ch.Receive(buf, &k), hal::CanStatus::kOk);
    total += k;
  } while (k > 0);
  return total;
}

::testing::AssertionResult RoundTripsWithoutHeap(hal::CanChannel& tx, hal::CanChannel& rx,
                                                 const std::vector<CanFrame>& burst,
                                                 int rounds) {
  std::size_t n = 0;
  const hal::CanStatus warm_up = tx.Send(burst, &n);
  if (warm_up != hal::CanStatus::kOk)
    return ::testing::AssertionFailure() << "warm-up Send: " << hal::ToString(warm_up);
  if (const std::size_t got = ReceiveN(rx, burst.size()).size(); got != burst.size())
    return ::testing::AssertionFailure()
           << "warm-up: received " << got << " of " << burst.size() << " frames";
  std::array<CanFrame, 64> out;
  for (int round = 0; round < rounds; ++round) {
    std::size_t got = 0, tries = 0, allocations = 0;
    hal::CanStatus s;
    {
      hyq::testing::NoHeapGuard guard;
      s = tx.Send(burst, &n);
      while (got < burst.size() && ++tries < 1'000'000) {
        std::size_t k = 0;
        s = rx.Receive(out, &k);
        got += k;
      }
      allocations = guard.allocations();
    }
    if (s != hal::CanStatus::kOk || got != burst.size() || allocations != 0)
      return ::testing::AssertionFailure()
             << "round " << round << ": last call " << hal::ToString(s) << ", received " << got
             << " of " << burst.size() << " frames, " << allocations << " heap allocations";
  }
  return ::testing::AssertionSuccess();
}

bool WriteLog(CandumpWriter& w, const std::vector<CanFrame>& frames) {
  std::int64_t t = 1'700'000'000'000'000'000;
  bool all = true;
  for (CanFrame f : frames) {
    f.timestamp_ns = (t += 1'000'000);
    all = w.Write(f) && all;
  }
  return all;
}

std::uint16_t TestPort(int k) {
  // a private namespace per test process: fixed ports cannot collide with other tests
  return static_cast<std::uint16_t>(43113 + 10 + k);
}

}  // namespace hyq::drivers::testing
