// candump log writer/reader, replay and recording channels, and can-utils' log2asc reading our
// logs.
#include "drivers/candump.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "drivers/channel_error.h"
#include "drivers/channel_factory.h"
#include "drivers/msgpack_frame.h"
#include "tests/drivers/test_util.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::drivers::testing {
namespace {

using hal::CanFrame;
using hal::CanStatus;

std::string Line(CanFrame f, std::int64_t t_ns, std::string_view iface = "vcan0") {
  f.timestamp_ns = t_ns;
  char buf[kMaxCandumpLine];
  const std::size_t n = FormatCandumpLine(f, iface, buf);
  return std::string(buf, n);
}

std::filesystem::path TempPath(const std::string& name) {
  return std::filesystem::temp_directory_path() /
         ("hyq_drivers_" + std::to_string(getpid()) + "_" + name);
}

std::vector<CanFrame> SampleFrames() {
  return {Classic(0x123, {0xDE, 0xAD, 0xBE, 0xEF}),
          Classic(0x000, {}),
          Classic(0x1F334455, {0x01, 0x02}, true),
          Remote(0x701, 0),
          Remote(0x601, 4),
          Remote(0x18FF0001, 8, true),
          Error(0x004, {0, 0x04, 0, 0, 0, 0, 0, 0}),
          Fd(0x181, 12, 3, true, false),
          Fd(0x182, 64, 5, false, true),
          Fd(0x10000183, 0, 0, false, false, true),
          Fd(0x184, 8, 1, true, true)};
}

TEST(Candump, FormatsLikeCandump) {
  EXPECT_EQ(Line(Classic(0x123, {0xDE, 0xAD, 0xBE, 0xEF}), 1'700'000'000'123'456'789),
            "(1700000000.123456) vcan0 123#DEADBEEF\n");
  EXPECT_EQ(Line(Classic(0x1F334455, {0x00}, true), 5'000'000), "(0000000000.005000) vcan0 1F334455#00\n");
  EXPECT_EQ(Line(Remote(0x123, 0), 0, "can1"), "(0000000000.000000) can1 123#R\n");
  EXPECT_EQ(Line(Remote(0x123, 3), 0, "can1"), "(0000000000.000000) can1 123#R3\n");
  EXPECT_EQ(Line(Fd(0x123, 2, 0x11, true, false), 0), "(0000000000.000000) vcan0 123##11118\n");
  EXPECT_EQ(Line(Error(0x40, {0, 0, 0, 0, 0, 0, 0, 0}), 0),
            "(0000000000.000000) vcan0 20000040#0000000000000000\n");
  char small[10];
  EXPECT_EQ(FormatCandumpLine(Classic(1, {}), "vcan0", small), 0u);
  char buf[kMaxCandumpLine];
  EXPECT_EQ(FormatCandumpLine(Classic(1, {}), "", buf), 0u);
  EXPECT_EQ(FormatCandumpLine(Classic(1, {}), "a b", buf), 0u);
  EXPECT_EQ(FormatCandumpLine(Classic(1, {}), "sixteen_chars_xx", buf), 0u);
}

TEST(Candump, RoundTripsEveryFrameKind) {
  std::int64_t t = 1'700'000'000'000'000'000;
  for (const CanFrame& f : SampleFrames()) {
    t += 1234567000;  // whole microseconds survive
    const std::string line = Line(f, t, "can3");
    CandumpRecord rec;
    const char* why = "";
    ASSERT_TRUE(ParseCandumpLine(line, &rec, &why)) << line << ": " << why;
    EXPECT_TRUE(SameFrame(rec.frame, f)) << line;
    EXPECT_EQ(rec.frame.timestamp_ns, t);
    EXPECT_EQ(rec.iface_name(), "can3");
    EXPECT_EQ(rec.direction, 0);
  }
}

TEST(Candump, ReadsPythonCanLogLines) {
  // as python-can 4.1's CanutilsLogWriter writes them: direction suffix, "R" without length,
  // error frames as CAN_ERR_FLAG | CAN_ERR_BUSERROR
  const std::string text =
      "(1700000000.100000) vcan0 123#0102 R\n"
      "(1700000000.200000) vcan0 00000123#R T\n"
      "(1700000000.300000) vcan0 181##1AABB01020304050607080910 R\n"
      "(1700000000.400000) vcan0 20000080#\n"
      "\n"
      "(1700000000.5) can0 7FF#\r\n";
  const CandumpLog log = ReadCandumpText(text, "python.log");
  ASSERT_EQ(log.records.size(), 5u);
  EXPECT_TRUE(SameFrame(log.records[0].frame, Classic(0x123, {1, 2})));
  EXPECT_EQ(log.records[0].direction, 'R');
  EXPECT_TRUE(SameFrame(log.records[1].frame, Remote(0x123, 0, true)));
  EXPECT_EQ(log.records[1].direction, 'T');
  EXPECT_TRUE(log.records[2].frame.is_fd());
  EXPECT_EQ(log.records[2].frame.len, 12);
  EXPECT_TRUE(SameFrame(log.records[3].frame, Error(0x80, {})));
  EXPECT_EQ(log.records[4].frame.timestamp_ns, 1'700'000'000'500'000'000);
  EXPECT_EQ(log.records[4].iface_name(), "can0");
}

TEST(Candump, MalformedLinesNameFileAndLine) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"1700000000.1 vcan0 123#00", "expected '('"},
      {"(1700000000.1 vcan0 123#00", "expected ')'"},
      {"(17000x0000.1) vcan0 123#00", "expected '.'"},
      {"(1.1234567891) vcan0 123#00", "longer than 9"},
      {"(1.1)vcan0 123#00", "expected a space"},
      {"(1.1) vcan0", "expected a space after the interface"},
      {"(1.1) averyveryverylongname 123#00", "longer than 15"},
      {"(1.1) vcan0 12#00", "3 (11-bit) or 8"},
      {"(1.1) vcan0 800#00", "above 7FF"},
      {"(1.1) vcan0 123456789#00", "longer than 8"},
      {"(1.1) vcan0 40000000#00", "above 1FFFFFFF"},
      {"(1.1) vcan0 123 00", "then '#'"},
      {"(1.1) vcan0 123#0", "pairs of hex"},
      {"(1.1) vcan0 123#0G", "pairs of hex"},
      {"(1.1) vcan0 123#010203040506070809", "too many data bytes"},
      {"(1.1) vcan0 123##G00", "FD flags"},
      {"(1.1) vcan0 123##0010203040506070809", "FD data length"},
      {"(1.1) vcan0 123#00 X", "only a direction"},
      {"(1.1) vcan0 123#R9", "unexpected character"},
      {"(1.1) vcan0 20000040##000", "cannot be an FD"},
      {"(1.1) vcan0 A0000040#00", "EFF/RTR"},
      {std::string("(1.1) vc\0n0 123#00", 18), "control or non-ASCII"},
      {"(1.1) vc\rn0 123#00", "control or non-ASCII"},
  };
  for (const auto& [line, why] : bad) {
    const std::string text = "(1.0) vcan0 123#00\n" + line + "\n";
    try {
      (void)ReadCandumpText(text, "bad.log");
      ADD_FAILURE() << "accepted: " << line;
    } catch (const ChannelError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("bad.log:2: "), std::string::npos) << msg;
      EXPECT_NE(msg.find(why), std::string::npos) << msg;
    }
  }
  // the counting mode keeps going and reports every bad line
  std::string text;
  for (const auto& [line, why] : bad) text += line + "\n(2.0) vcan0 7FF#\n";
  const CandumpLog log = ReadCandumpText(text, "bad.log", MalformedLines::kSkipAndCount);
  EXPECT_EQ(log.malformed_lines, bad.size());
  EXPECT_EQ(log.records.size(), bad.size());
  ASSERT_EQ(log.errors.size(), bad.size());
  EXPECT_NE(log.errors[1].find("bad.log:3: "), std::string::npos) << log.errors[1];
}

TEST(Candump, MissingFileThrowsWithPath) {
  try {
    (void)ReadCandumpFile("/nonexistent/dir/x.log");
    FAIL();
  } catch (const ChannelError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/x.log"), std::string::npos);
  }
}

TEST(Candump, RandomLinesNeverCrash) {
  std::mt19937 rng(6);
  const std::string alphabet = "()#.R T0123456789ABCDEFabcdefvcan\n\t";
  std::string text;
  for (int i = 0; i < 20000; ++i) {
    std::string line = Line(Fd(0x181, 16, static_cast<std::uint8_t>(i)), i * 1000);
    const int edits = 1 + static_cast<int>(rng() % 3);
    for (int k = 0; k < edits; ++k) line[rng() % line.size()] = alphabet[rng() % alphabet.size()];
    text += line;
  }
  const CandumpLog log = ReadCandumpText(text, "fuzz.log", MalformedLines::kSkipAndCount);
  EXPECT_GT(log.malformed_lines, 0u);
  for (const CandumpRecord& r : log.records) EXPECT_TRUE(IsValidFrame(r.frame));
}

TEST(Candump, WriterOutputIsReadBackAndAcceptedByLog2asc) {
  const auto path = TempPath("writer.log");
  const std::vector<CanFrame> frames = SampleFrames();
  {
    CandumpWriter w(path.string(), "vcan0");
    EXPECT_TRUE(testing::WriteLog(w, frames));
    CanFrame bad = Classic(0x900, {});
    EXPECT_FALSE(w.Write(bad));
    EXPECT_EQ(w.written(), frames.size());
    EXPECT_EQ(w.failed(), 1u);
  }
  const CandumpLog log = ReadCandumpFile(path.string());
  ASSERT_EQ(log.records.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i)
    EXPECT_TRUE(SameFrame(log.records[i].frame, frames[i]));

  // can-utils' log2asc parses every line with its own parser and stops at the first it cannot
  if (access("/usr/bin/log2asc", X_OK) != 0)
    GTEST_SKIP() << "can-utils log2asc not installed (scripts/bootstrap.sh installs can-utils)";
  std::string out;
  const int rc = testing::RunCommand({"/usr/bin/log2asc", "-I", path.string(), "vcan0"}, &out);
  EXPECT_EQ(rc, 0) << out;
  std::istringstream lines(out);
  std::string l;
  int frame_lines = 0, fd_lines = 0, error_lines = 0;
  while (std::getline(lines, l)) {
    if (l.find(" Rx ") != std::string::npos) ++frame_lines;
    if (l.find("CANFD") != std::string::npos) ++fd_lines;
    if (l.find("ErrorFrame") != std::string::npos) ++error_lines;
  }
  EXPECT_EQ(fd_lines, 4) << out;
  EXPECT_EQ(error_lines, 1) << out;
  EXPECT_EQ(frame_lines, static_cast<int>(frames.size()) - 1) << out;  // all but the error frame
  std::filesystem::remove(path);
}

TEST(Candump, ReplayChannelReturnsFramesInOrder) {
  std::string text;
  std::int64_t t = 1'700'000'000'000'000'000;
  std::vector<CanFrame> frames = SampleFrames();
  for (std::size_t i = 0; i < frames.size(); ++i)
    text += Line(frames[i], t + static_cast<std::int64_t>(i) * 1000, i % 2 ? "can1" : "can0");
  CandumpLog log = ReadCandumpText(text, "mem");
  ReplayChannel all(log.records, "", ReplayTiming::kAsFast, true, "replay");
  std::array<CanFrame, 4> out;
  std::vector<CanFrame> got;
  std::size_t n = 0;
  do {
    ASSERT_EQ(all.Receive(out, &n), CanStatus::kOk);
    got.insert(got.end(), out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n));
  } while (n > 0);
  ASSERT_EQ(got.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_TRUE(SameFrame(got[i], frames[i]));
  EXPECT_TRUE(all.finished());
  EXPECT_EQ(all.counters().rx_frames, frames.size());
  EXPECT_EQ(all.counters().error_frames, 1u);

  ReplayChannel can1(log.records, "can1", ReplayTiming::kAsFast, false, "replay");
  std::array<CanFrame, 32> many;
  ASSERT_EQ(can1.Receive(many, &n), CanStatus::kOk);
  EXPECT_EQ(n + can1.counters().bad_frames, frames.size() / 2);  // FD frames dropped
  std::size_t sent = 0;
  EXPECT_EQ(can1.Send(std::span<const CanFrame>(frames.data(), 3), &sent), CanStatus::kOk);
  EXPECT_EQ(sent, 3u);
  const CanFrame fd = Fd(1, 8, 0);
  EXPECT_EQ(can1.Send(std::span<const CanFrame>(&fd, 1), &sent), CanStatus::kBadFrame);
}

TEST(Candump, ReplayRealTimeReleasesFramesOnSchedule) {
  std::string text = Line(Classic(1, {}), 1'000'000'000) + Line(Classic(2, {}), 1'000'000'000) +
                     Line(Classic(3, {}), 1'150'000'000);
  ReplayChannel ch(ReadCandumpText(text, "mem").records, "", ReplayTiming::kRealTime, true, "r");
  std::array<CanFrame, 8> out;
  std::size_t n = 0;
  ASSERT_EQ(ch.Receive(out, &n), CanStatus::kOk);
  EXPECT_EQ(n, 2u);  // the two at t0 are due at once, the third 150 ms later
  ASSERT_EQ(ch.Receive(out, &n), CanStatus::kOk);
  EXPECT_EQ(n, 0u);
  usleep(200'000);
  ASSERT_EQ(ch.Receive(out, &n), CanStatus::kOk);
  ASSERT_EQ(n, 1u);
  EXPECT_EQ(out[0].id, 3u);
  EXPECT_EQ(out[0].timestamp_ns, 1'150'000'000);
}

TEST(Candump, RecordingChannelLogsBothDirections) {
  const auto in_path = TempPath("rec_in.log");
  const auto out_path = TempPath("rec_out.log");
  {
    std::ofstream in(in_path);
    in << Line(Classic(0x181, {1, 2}), 10'000'000'000) << Line(Fd(0x281, 16, 1), 10'001'000'000);
  }
  auto replay = OpenChannel("replay:" + in_path.string());
  {
    CandumpWriter w(out_path.string(), "vcan2");
    RecordingChannel rec(replay.get(), &w);
    std::array<CanFrame, 4> out;
    std::size_t n = 0;
    ASSERT_EQ(rec.Receive(out, &n), CanStatus::kOk);
    ASSERT_EQ(n, 2u);
    const CanFrame tx = Classic(0x201, {9});
    ASSERT_EQ(rec.Send(std::span<const CanFrame>(&tx, 1), &n), CanStatus::kOk);
    EXPECT_EQ(rec.name(), "replay:" + in_path.string());
  }
  const CandumpLog log = ReadCandumpFile(out_path.string());
  ASSERT_EQ(log.records.size(), 3u);
  EXPECT_EQ(log.records[0].frame.timestamp_ns, 10'000'000'000);
  EXPECT_TRUE(log.records[1].frame.is_fd());
  EXPECT_EQ(log.records[2].frame.id, 0x201u);
  EXPECT_EQ(log.records[2].iface_name(), "vcan2");
  std::filesystem::remove(in_path);
  std::filesystem::remove(out_path);
}

}  // namespace
}  // namespace hyq::drivers::testing

namespace hyq::drivers::testing {
namespace {

TEST(Candump, NoHeapWhenRecordingOrReplaying) {
  HYQ_REQUIRE_HEAP_HOOKS();
  const auto path = TempPath("noheap.log");
  std::string text;
  for (std::uint32_t i = 0; i < 64; ++i) text += Line(Fd(0x180 + i, 16, 1), i * 1000);
  ReplayChannel replay(ReadCandumpText(text, "mem").records, "", ReplayTiming::kAsFast, true, "r");
  CandumpWriter writer(path.string(), "vcan0");
  RecordingChannel rec(&replay, &writer);
  std::array<CanFrame, 13> out;
  std::size_t n = 0;
  ASSERT_EQ(rec.Receive(out, &n), CanStatus::kOk);  // warm-up: stdio sets up on first write
  for (int cycle = 0; cycle < 3; ++cycle) {
    hyq::testing::NoHeapGuard guard;
    const CanStatus r = rec.Receive(out, &n);
    const CanStatus s = rec.Send(std::span<const CanFrame>(out.data(), n), &n);
    const bool ok = writer.Flush();
    const std::size_t allocations = guard.allocations();
    ASSERT_EQ(r, CanStatus::kOk);
    ASSERT_EQ(s, CanStatus::kOk);
    ASSERT_TRUE(ok);
    ASSERT_EQ(allocations, 0u) << "cycle " << cycle;
  }
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace hyq::drivers::testing
