// Interop with programs we did not write: python-can (Debian python3-can 4.1, run with
// /usr/bin/python3) talks to our UDP channel both ways, records our traffic with can.logger, and
// reads our candump logs. Each case runs in a private network namespace.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <filesystem>
#include <sstream>
#include <thread>

#include "drivers/candump.h"
#include "drivers/udp_multicast_channel.h"
#include "tests/drivers/test_util.h"

namespace hyq::drivers::testing {
namespace {

using hal::CanFrame;
using hal::CanStatus;

constexpr const char* kPython = "/usr/bin/python3";

#define HYQ_REQUIRE_PYTHON_CAN()                                                            \
  do {                                                                                      \
    std::string out_;                                                                       \
    if (access(kPython, X_OK) != 0 ||                                                       \
        testing::RunCommand({kPython, "-c", "import can, msgpack"}, &out_) != 0)            \
      GTEST_SKIP() << "Debian's python3-can / python3-msgpack are not importable by "       \
                   << kPython << " (scripts/bootstrap.sh installs them): " << out_;         \
  } while (false)

// What python_can_peer.py prints for a frame it received.
std::string PythonDescription(const CanFrame& f) {
  const bool remote = (f.flags & CanFrame::kRemote) != 0;
  std::ostringstream s;
  s << std::hex << f.id << std::dec << " ext=" << (f.is_extended() ? 1 : 0)
    << " rtr=" << (remote ? 1 : 0) << " err=" << (f.is_error() ? 1 : 0)
    << " fd=" << (f.is_fd() ? 1 : 0) << " brs=" << ((f.flags & CanFrame::kBitrateSwitch) ? 1 : 0)
    << " esi=" << ((f.flags & CanFrame::kErrorStateIndicator) ? 1 : 0)
    << " dlc=" << int{f.len} << " data=";
  static const char* hex = "0123456789abcdef";
  for (std::size_t i = 0; !remote && i < f.len; ++i) s << hex[f.data[i] >> 4] << hex[f.data[i] & 15];
  return s.str();
}

std::vector<CanFrame> TestFrames() {
  return {Classic(0x181, {0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88}),
          Classic(0x000, {}),
          Classic(0x1ABCDEF0, {0x01, 0x02, 0x03}, true),
          Remote(0x702, 1),
          Remote(0x18DAF110, 8, true),
          Error(0x40, {0, 0, 0, 0, 0, 0, 0, 0}),
          Fd(0x282, 64, 0x10, true, false),
          Fd(0x1F000282, 12, 0x20, false, true, true),
          Fd(0x382, 5, 0x30, false, false)};
}

TEST(PythonCanInterop, EchoPeerBothWays) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  HYQ_REQUIRE_PYTHON_CAN();
  UdpMulticastOptions o;
  o.port = TestPort();
  UdpMulticastChannel ch(o);
  const std::vector<CanFrame> frames = TestFrames();
  Child peer({kPython, std::string(HYQ_DRIVERS_TEST_DIR) + "/python_can_peer.py", o.group,
              std::to_string(o.port), std::to_string(frames.size())},
             true);
  std::string seen;
  ASSERT_TRUE(peer.WaitForLine("ready", std::chrono::seconds(30), &seen)) << seen;

  std::size_t sent = 0;
  ASSERT_EQ(ch.Send(frames, &sent), CanStatus::kOk);
  ASSERT_EQ(sent, frames.size());

  // python-can decoded each of our datagrams into the same frame
  for (const CanFrame& f : frames) {
    std::string line;
    ASSERT_TRUE(peer.ReadLine(&line, std::chrono::seconds(15))) << "python peer fell silent";
    EXPECT_EQ(line, "rx " + PythonDescription(f));
  }
  // and we decode each of python-can's replies
  const std::vector<CanFrame> replies = ReceiveN(ch, frames.size(), std::chrono::seconds(15));
  ASSERT_EQ(replies.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    CanFrame expect = frames[i];
    expect.id ^= 1;
    if ((expect.flags & CanFrame::kRemote) == 0)
      std::reverse(expect.data.begin(), expect.data.begin() + expect.len);
    EXPECT_TRUE(SameFrame(replies[i], expect)) << "reply " << i;
    EXPECT_GT(replies[i].timestamp_ns, 0);
  }
  std::string line;
  EXPECT_TRUE(peer.WaitForLine("done", std::chrono::seconds(10), &line)) << line;
  EXPECT_EQ(peer.Wait(std::chrono::seconds(10)), 0);
  EXPECT_EQ(ch.counters().bad_frames, 0u);
  EXPECT_EQ(ch.counters().rx_frames, frames.size());  // no echoes of our own frames
}

TEST(PythonCanInterop, CanLoggerRecordsOurTrafficAndWeReadItsLog) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  HYQ_REQUIRE_PYTHON_CAN();
  const std::filesystem::path log_path = std::filesystem::temp_directory_path() /
                                         ("hyq_can_logger_" + std::to_string(getpid()) + ".log");
  // the documented default group and port: this namespace is ours alone
  Child logger({kPython, "-u", "-m", "can.logger", "-i", "udp_multicast", "-c", kDefaultUdpGroup,
                "--fd", "-f", log_path.string()},
               true);
  std::string seen;
  ASSERT_TRUE(logger.WaitForLine("Connected to", std::chrono::seconds(30), &seen)) << seen;

  UdpMulticastChannel ch(UdpMulticastOptions{});
  const std::vector<CanFrame> frames = TestFrames();
  std::size_t sent = 0;
  ASSERT_EQ(ch.Send(frames, &sent), CanStatus::kOk);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // logger polls with recv(1)
  logger.Signal(SIGINT);
  EXPECT_EQ(logger.Wait(std::chrono::seconds(15)), 0);

  const CandumpLog log = ReadCandumpFile(log_path.string());  // throws on any malformed line
  ASSERT_EQ(log.records.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const CanFrame& got = log.records[i].frame;
    if (frames[i].is_error()) {
      // python-can's writer logs every error frame as CAN_ERR_FLAG | CAN_ERR_BUSERROR
      EXPECT_TRUE(got.is_error());
      EXPECT_EQ(got.id, 0x80u);
    } else if ((frames[i].flags & CanFrame::kRemote) != 0) {
      // python-can's writer logs remote frames as "ID#R", without the requested length
      CanFrame expect = frames[i];
      expect.len = 0;
      EXPECT_TRUE(SameFrame(got, expect)) << "line " << i + 1;
    } else {
      EXPECT_TRUE(SameFrame(got, frames[i])) << "line " << i + 1;
    }
    if (i > 0) {
      EXPECT_GE(got.timestamp_ns, log.records[i - 1].frame.timestamp_ns);
    }
  }
  std::filesystem::remove(log_path);
}

TEST(PythonCanInterop, PythonCanReadsOurCandumpLog) {
  HYQ_REQUIRE_PYTHON_CAN();
  const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                     ("hyq_ours_" + std::to_string(getpid()) + ".log");
  const std::vector<CanFrame> frames = TestFrames();
  {
    CandumpWriter w(path.string(), "vcan0");
    ASSERT_TRUE(testing::WriteLog(w, frames));
  }
  std::string out;
  const int rc = testing::RunCommand(
      {kPython, "-c",
       "import sys, can\n"
       "for m in can.LogReader(sys.argv[1]):\n"
       "    print(f'{m.arbitration_id:x} {int(m.is_extended_id)} {int(m.is_remote_frame)} "
       "{int(m.is_error_frame)} {int(m.is_fd)} {m.dlc} {m.data.hex() if m.data else \"\"}')\n",
       path.string()},
      &out);
  ASSERT_EQ(rc, 0) << out;
  std::istringstream lines(out);
  std::string line;
  std::size_t i = 0;
  for (; std::getline(lines, line) && i < frames.size(); ++i) {
    const CanFrame& f = frames[i];
    if (f.is_error()) {
      // python-can's reader only knows CAN_ERR_BUSERROR error frames and reads others (here
      // CAN_ERR_BUSOFF) as an extended data frame with the class as id: the line still parses
      EXPECT_EQ(line, "40 1 0 0 0 8 0000000000000000");
      continue;
    }
    std::ostringstream e;
    e << std::hex << f.id << std::dec << ' ' << (f.is_extended() ? 1 : 0) << ' '
      << ((f.flags & CanFrame::kRemote) ? 1 : 0) << " 0 " << (f.is_fd() ? 1 : 0) << ' '
      << int{f.len} << ' ';
    static const char* hex = "0123456789abcdef";
    for (std::size_t k = 0; (f.flags & CanFrame::kRemote) == 0 && k < f.len; ++k)
      e << hex[f.data[k] >> 4] << hex[f.data[k] & 15];
    EXPECT_EQ(line, e.str());
  }
  EXPECT_EQ(i, frames.size()) << out;
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace hyq::drivers::testing
