// hyq-lcm-export on damaged and hostile logs: the reader resynchronises after a bad sync word or
// impossible lengths and says so (exit 3), a corrupt length inside a message is undecodable
// rather than a crash, channel names never become paths, and --plot runs no shell.
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "hyq_lcm/lcmt_hyq_command.hpp"
#include "hyq_lcm/lcmt_hyq_signed_command.hpp"
#include "hyq_lcm/lcmt_hyq_event.hpp"
#include "hyq_lcm/lcmt_hyq_joint_state.hpp"
#include "tests/support/run_tool.h"
#include "tools/hyq-lcm-export/csv_rows.h"
#include "tools/hyq-lcm-export/lcm_log.h"

namespace hyq::lcm_export {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;
using ::testing::HasSubstr;
using ::testing::Not;

template <class T>
Bytes Encode(const T& msg) {
  Bytes b(static_cast<std::size_t>(msg.getEncodedSize()));
  EXPECT_EQ(msg.encode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  return b;
}

void PutBe(Bytes* out, std::uint64_t v, int bytes) {
  for (int i = bytes - 1; i >= 0; --i) out->push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

// one lcm-logger event (lcm_log.h)
void Append(Bytes* log, const std::string& channel, const Bytes& data, std::int64_t n) {
  PutBe(log, kLogSync, 4);
  PutBe(log, static_cast<std::uint64_t>(n), 8);
  PutBe(log, static_cast<std::uint64_t>(1000 * n), 8);
  PutBe(log, channel.size(), 4);
  PutBe(log, data.size(), 4);
  log->insert(log->end(), channel.begin(), channel.end());
  log->insert(log->end(), data.begin(), data.end());
}

Bytes JointState(std::int64_t cycle) {
  hyq_lcm::lcmt_hyq_joint_state m{};
  m.utime = 1000 * cycle;
  m.cycle = cycle;
  for (int j = 0; j < 12; ++j) m.q_rad[j] = 0.1 * j + 1e-3 * static_cast<double>(cycle);
  return Encode(m);
}

Bytes Event(const std::string& detail) {
  hyq_lcm::lcmt_hyq_event m{};
  m.utime = 7;
  m.from_name = "standby";
  m.to_name = "active";
  m.reason = "command";
  m.detail = detail;
  return Encode(m);
}

// `n` joint states on HYQ_JOINT_STATE, with the offset of each event's sync word
Bytes Log(int n, std::vector<std::size_t>* offsets = nullptr) {
  Bytes log;
  for (int i = 0; i < n; ++i) {
    if (offsets != nullptr) offsets->push_back(log.size());
    Append(&log, "HYQ_JOINT_STATE", JointState(i), i);
  }
  return log;
}

struct ReadAll {
  int events = 0;
  LogDamage damage;
};
ReadAll Read(const Bytes& log) {
  LogReader r(log);
  LogEvent ev;
  ReadAll out;
  while (r.Next(&ev)) ++out.events;
  out.damage = r.damage();
  return out;
}

TEST(LcmLogReader, ReadsAnIntactLogWithoutDamage) {
  const ReadAll r = Read(Log(50));
  EXPECT_EQ(r.events, 50);
  EXPECT_FALSE(r.damage.any());
  EXPECT_EQ(r.damage.skipped_bytes, 0u);
}

TEST(LcmLogReader, ResyncsAfterABadSyncWordAndLosesOneEvent) {
  std::vector<std::size_t> at;
  Bytes log = Log(100, &at);
  log[at[3]] ^= 0xff;  // before: reading stopped here, 3 of 100 kept, exit 0
  const ReadAll r = Read(log);
  EXPECT_EQ(r.events, 99);
  EXPECT_EQ(r.damage.resyncs, 1u);
  EXPECT_EQ(r.damage.skipped_bytes, at[4] - at[3]);
  EXPECT_FALSE(r.damage.truncated);
}

TEST(LcmLogReader, ImpossibleLengthsAreBadRecordsNotReads) {
  for (const std::uint32_t bad : {0x7fffffffu, 0x80000000u, 0xffffffffu, 0x00100000u}) {
    std::vector<std::size_t> at;
    Bytes log = Log(20, &at);
    // data length of event 5, then channel length of event 9
    for (int k = 0; k < 4; ++k) log[at[5] + 24 + k] = static_cast<std::uint8_t>(bad >> (24 - 8 * k));
    for (int k = 0; k < 4; ++k) log[at[9] + 20 + k] = static_cast<std::uint8_t>(bad >> (24 - 8 * k));
    const ReadAll r = Read(log);
    EXPECT_EQ(r.events, 18) << bad;
    EXPECT_EQ(r.damage.bad_records, 2u) << bad;
    EXPECT_FALSE(r.damage.truncated) << bad;
  }
}

TEST(LcmLogReader, ADataLengthTooLongDoesNotSwallowTheNextEvents) {
  std::vector<std::size_t> at;
  Bytes log = Log(20, &at);
  const std::size_t len = at[6] - at[5] - kLogHeaderBytes - 15;  // HYQ_JOINT_STATE: 15 bytes
  const std::uint32_t longer = static_cast<std::uint32_t>(len + 3 * (at[6] - at[5]) + 5);
  for (int k = 0; k < 4; ++k) log[at[5] + 24 + k] = static_cast<std::uint8_t>(longer >> (24 - 8 * k));
  const ReadAll r = Read(log);
  EXPECT_EQ(r.events, 19);
  EXPECT_EQ(r.damage.bad_records, 1u);
}

TEST(LcmLogReader, ATruncatedLastEventIsReported) {
  for (const std::size_t cut : {1, 3, 4, 20, 28, 40}) {
    std::vector<std::size_t> at;
    Bytes log = Log(10, &at);
    log.resize(at[9] + cut);
    const ReadAll r = Read(log);
    EXPECT_EQ(r.events, 9) << cut;
    EXPECT_TRUE(r.damage.truncated) << cut;
    EXPECT_EQ(r.damage.skipped_bytes, cut) << cut;
  }
}

TEST(LcmLogReader, GarbageIsSkippedToTheNextSyncWord) {
  Bytes log = {1, 2, 3, 0xED, 0xA1, 5};
  const Bytes rest = Log(5);
  log.insert(log.end(), rest.begin(), rest.end());
  log.insert(log.end(), {9, 9, 9, 9, 9, 9, 9});
  const ReadAll r = Read(log);
  EXPECT_EQ(r.events, 5);
  EXPECT_EQ(r.damage.resyncs, 2u);
  EXPECT_EQ(r.damage.skipped_bytes, 13u);
}

TEST(LcmChannelNames, BecomeSafeFileNames) {
  EXPECT_EQ(SafeFileName("HYQ_JOINT_STATE"), "HYQ_JOINT_STATE");
  EXPECT_EQ(SafeFileName("a.b-c_9"), "a.b-c_9");
  EXPECT_EQ(SafeFileName("../../x"), "_._.._x");
  EXPECT_EQ(SafeFileName("/etc/passwd"), "_etc_passwd");
  EXPECT_EQ(SafeFileName(".hidden"), "_hidden");
  EXPECT_EQ(SafeFileName(".."), "_.");
  EXPECT_EQ(SafeFileName(std::string("a\0b\n", 4)), "a_b_");
  EXPECT_EQ(SafeFileName(std::string(1000, 'x')).size(), 200u);
  EXPECT_EQ(Printable(std::string("a\x1b[2J\\", 6)), "a\\x1b[2J\\x5c");
}

// The length checks before the generated decode must describe the generated encoding exactly:
// every encoded message passes, every truncation of it fails.
TEST(LcmCsvRows, LengthChecksMatchTheGeneratedCode) {
  std::vector<Bytes> messages;
  for (const std::string& s : {std::string(), std::string("x"), std::string(300, 'y')}) {
    messages.push_back(Event(s));
    hyq_lcm::lcmt_hyq_command c{};
    c.kind = hyq_lcm::lcmt_hyq_command::KIND_SET_MU;
    c.num_feet = static_cast<std::int8_t>(s.size() % 5);
    c.mu.assign(static_cast<std::size_t>(c.num_feet), 0.5);
    c.controller = s;
    messages.push_back(Encode(c));
    hyq_lcm::lcmt_hyq_signed_command sc{};
    sc.sender = s;
    sc.command = Encode(c);
    sc.command_size = static_cast<std::int32_t>(sc.command.size());
    messages.push_back(Encode(sc));
  }
  messages.push_back(JointState(3));
  for (const Bytes& m : messages) {
    const RowType* type = FindRowType(m);
    ASSERT_NE(type, nullptr);
    std::string cells;
    EXPECT_TRUE(RowCells(*type, m, &cells)) << type->name;
    const std::string header = HeaderCells(*type);
    EXPECT_EQ(std::count(cells.begin(), cells.end(), ','),
              std::count(header.begin(), header.end(), ','))
        << type->name;
    for (std::size_t n = 8; n < m.size(); ++n)
      EXPECT_FALSE(RowCells(*type, std::span(m.data(), n), &cells)) << type->name << " " << n;
    Bytes longer = m;
    longer.push_back(0);
    EXPECT_FALSE(RowCells(*type, longer, &cells)) << type->name;
  }
}

// before: a string length ≤ 0 threw std::length_error out of main (abort), INT32_MIN read 2 GB
// past the message (SIGSEGV), num_feet = -1 resized a vector to SIZE_MAX
TEST(LcmCsvRows, CorruptLengthFieldsAreUndecodable) {
  const Bytes event = Event("detail");
  const std::size_t from_name_len = 8 + 8 + 8 + 1 + 1;  // fingerprint, utime, cycle, modes
  for (const std::uint32_t bad : {0u, 0xffffffffu, 0x80000000u, 0x7fffffffu, 0x00010000u}) {
    Bytes m = event;
    for (int k = 0; k < 4; ++k)
      m[from_name_len + static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(bad >> (24 - 8 * k));
    std::string cells;
    EXPECT_FALSE(RowCells(*FindRowType(m), m, &cells)) << bad;
  }
  hyq_lcm::lcmt_hyq_command c{};
  c.num_feet = 2;
  c.mu = {0.1, 0.2};
  Bytes m = Encode(c);
  m[8 + 8 + 8 + 1] = 0xff;  // num_feet = -1
  std::string cells;
  EXPECT_FALSE(RowCells(*FindRowType(m), m, &cells));
}

using hyq::test::ToolRun;

ToolRun RunTool(const std::string& args) { return hyq::test::RunTool(HYQ_LCM_EXPORT_TOOL, args); }

class HyqLcmExport : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("hyq_lcm_export_test_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Write(const Bytes& log) {
    const fs::path p = dir_ / "in.lcmlog";
    std::ofstream(p, std::ios::binary)
        .write(reinterpret_cast<const char*>(log.data()), static_cast<std::streamsize>(log.size()));
    return p.string();
  }
  static int Rows(const fs::path& csv) {
    std::ifstream in(csv);
    int n = 0;
    for (std::string line; std::getline(in, line);) ++n;
    return n - 1;  // the header
  }

  fs::path dir_;
};

TEST_F(HyqLcmExport, AnIntactLogExitsZero) {
  const ToolRun r = RunTool(Write(Log(30)) + " " + (dir_ / "out").string());
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_EQ(Rows(dir_ / "out/HYQ_JOINT_STATE.csv"), 30);
  EXPECT_THAT(r.out, Not(HasSubstr("damaged")));
}

TEST_F(HyqLcmExport, ADamagedLogIsReadOnAndExitsThree) {
  std::vector<std::size_t> at;
  Bytes log = Log(200, &at);
  log[at[10] + 1] = 0;                                          // a bad sync word
  for (int k = 0; k < 4; ++k) log[at[50] + 24 + k] = 0xff;      // data length -1
  log.resize(at[199] + 30);                                     // the last event cut short
  const ToolRun r = RunTool(Write(log) + " " + (dir_ / "out").string());
  EXPECT_EQ(r.exit_code, 3) << r.out;
  EXPECT_EQ(Rows(dir_ / "out/HYQ_JOINT_STATE.csv"), 197);
  EXPECT_THAT(r.out, HasSubstr("in.lcmlog is damaged: 197 messages read, 1 bad event header(s), "
                               "2 resync(s)"));
  EXPECT_THAT(r.out, HasSubstr("the last event truncated"));
  EXPECT_THAT(RunTool("--help").out, HasSubstr("3 the log is damaged"));
}

TEST_F(HyqLcmExport, CorruptMessagesAreCountedNotFatal) {
  Bytes log = Log(5);
  Bytes bad = Event("x");
  for (int k = 0; k < 4; ++k) bad[26 + static_cast<std::size_t>(k)] = k == 0 ? 0x80 : 0;  // INT32_MIN
  Append(&log, "HYQ_EVENT", bad, 5);
  bad = Event("x");
  for (int k = 0; k < 4; ++k) bad[26 + static_cast<std::size_t>(k)] = 0xff;  // -1
  Append(&log, "HYQ_EVENT", bad, 6);
  Append(&log, "HYQ_EVENT", Event("fine"), 7);
  const Bytes more = Log(3);
  log.insert(log.end(), more.begin(), more.end());
  const ToolRun r = RunTool(Write(log) + " " + (dir_ / "out").string());
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_THAT(r.out, HasSubstr("2 undecodable"));
  EXPECT_EQ(Rows(dir_ / "out/HYQ_JOINT_STATE.csv"), 8);
  EXPECT_EQ(Rows(dir_ / "out/HYQ_EVENT.csv"), 1);
}

TEST_F(HyqLcmExport, ChannelNamesNeverLeaveOutDir) {
  const std::string absolute = (dir_ / "abs").string();
  const std::string flat = SafeFileName(absolute);
  Bytes log;
  Append(&log, "../../escaped", JointState(1), 1);
  Append(&log, absolute, JointState(2), 2);
  Append(&log, flat, JointState(3), 3);  // the same file name
  Append(&log, ".hidden", JointState(4), 4);
  fs::create_directories(dir_ / "a/b");
  const ToolRun r = RunTool(Write(log) + " " + (dir_ / "a/b/out").string());
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "a/escaped.csv"));  // before: written there
  EXPECT_FALSE(fs::exists(absolute + ".csv"));       // and there
  EXPECT_EQ(Rows(dir_ / "a/b/out/_._.._escaped.csv"), 1);
  EXPECT_EQ(Rows(dir_ / "a/b/out" / (flat + ".csv")), 1);
  EXPECT_EQ(Rows(dir_ / "a/b/out" / (flat + "-2.csv")), 1);
  EXPECT_EQ(Rows(dir_ / "a/b/out/_hidden.csv"), 1);
  EXPECT_THAT(r.out, HasSubstr("channel \"../../escaped\" is written to"));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "a/b/out"), fs::directory_iterator{}), 4);
}

TEST_F(HyqLcmExport, PlotRunsNoShell) {
  const fs::path marker = dir_ / "injected";
  // before: system("/usr/bin/python3 'plot_lcm_log.py' '<OUT_DIR>'") ran the touch
  const std::string out = (dir_ / "o'; touch '").string() + marker.string() + "'; '";
  const ToolRun r = RunTool(Write(Log(3)) + " \"" + out + "\" --plot");
  EXPECT_FALSE(fs::exists(marker)) << r.out;
  EXPECT_TRUE(fs::exists(out + "/HYQ_JOINT_STATE.csv")) << r.out;
}

TEST_F(HyqLcmExport, NotARegularFileExitsTwo) {
  for (const std::string& path : {std::string("/dev/zero"), dir_.string()}) {
    const ToolRun r = RunTool(path + " " + (dir_ / "out").string());
    EXPECT_EQ(r.exit_code, 2) << r.out;
    EXPECT_THAT(r.out, HasSubstr("expected a regular file")) << path;
  }
}

}  // namespace
}  // namespace hyq::lcm_export
