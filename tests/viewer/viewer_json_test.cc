// hyq-viewer's decoding and JSON frames (tools/hyq-viewer/telemetry_json.h) and its log player's
// controls (log_player.h): messages encoded with the generated hyq_lcm types come out as the
// page's JSON field by field; malformed bytes, unknown types and garbage controls are counted or
// refused, never thrown. And the field lists (lcmtypes/telemetry_fields.h): a field added to a
// list reaches hyq-lcm-export's CSV and the viewer's JSON with no other change.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hyq_lcm/lcmt_hyq_contact_state.hpp"
#include "hyq_lcm/lcmt_hyq_event.hpp"
#include "hyq_lcm/lcmt_hyq_joint_state.hpp"
#include "hyq_lcm/lcmt_hyq_sim_truth.hpp"
#include "tools/hyq-lcm-export/csv_rows.h"
#include "tools/hyq-viewer/log_player.h"
#include "tools/hyq-viewer/telemetry_json.h"

namespace test_lcm {

// lcmt_hyq_joint_torque with one field more, as lcm-gen would generate it after one line was
// added to lcmt_hyq_joint_torque.lcm, and its list: today's list plus the one line a new field
// adds.
struct lcmt_hyq_joint_torque_plus : hyq_lcm::lcmt_hyq_joint_torque {
  double pump_pressure_bar = 0.0;
};

template <class A>
void Serialize(A* a, lcmt_hyq_joint_torque_plus* m) {
  Serialize(a, static_cast<hyq_lcm::lcmt_hyq_joint_torque*>(m));
  a->Visit("pump_pressure_bar", "bar", &m->pump_pressure_bar);
}

}  // namespace test_lcm

namespace hyq::viewer {
namespace {

TEST(TelemetryFields, AFieldAddedToTheListReachesCsvAndJson) {
  test_lcm::lcmt_hyq_joint_torque_plus m{};
  m.cycle = 9;
  m.controller = 3;
  for (int j = 0; j < 12; ++j) m.tau_command_Nm[j] = 0.5 * j;
  m.pump_pressure_bar = 171.25;
  const hyq_lcm::lcmt_hyq_joint_torque& today = m;

  EXPECT_EQ(lcm_export::CsvHeader<test_lcm::lcmt_hyq_joint_torque_plus>(),
            lcm_export::CsvHeader<hyq_lcm::lcmt_hyq_joint_torque>() + ",pump_pressure_bar (bar)");
  EXPECT_EQ(lcm_export::CsvRow(m), lcm_export::CsvRow(today) + ",171.25");

  nlohmann::json json = ToJson(m);
  EXPECT_DOUBLE_EQ(json["pump_pressure_bar"].get<double>(), 171.25);
  json.erase("pump_pressure_bar");
  EXPECT_EQ(json, ToJson(today));
}

// Every element of every kind of field, named in the CSV header and present in the JSON: arrays
// of messages (the buses), labels per device, 2-D arrays, booleans, byte arrays.
TEST(TelemetryFields, TheListsDriveEveryColumnAndKey) {
  hyq_lcm::lcmt_hyq_health h{};
  h.buses[7].wkc_received = 5;
  h.max_held_in_row[15] = 4;
  const std::string header = lcm_export::CsvHeader<hyq_lcm::lcmt_hyq_health>();
  EXPECT_NE(header.find(",bus7.wkc_received (count),num_devices (count),device_state.0 (enum),"),
            std::string::npos)
      << header;
  EXPECT_NE(header.find(",max_held_in_row.15 (count),max_held_cycles (count),"), std::string::npos);
  const nlohmann::json hj = ToJson(h);
  ASSERT_EQ(hj["buses"].size(), 8u);
  EXPECT_EQ(hj["buses"][7]["wkc_received"], 5);
  EXPECT_EQ(hj["max_held_in_row"][15], 4);

  hyq_lcm::lcmt_hyq_friction_estimate f{};
  f.force_N[3][2] = 2.5;
  f.slipping[1] = 7;  // a boolean is any non-zero byte on the wire
  const std::string row = lcm_export::CsvRow(f);
  const std::string fh = lcm_export::CsvHeader<hyq_lcm::lcmt_hyq_friction_estimate>();
  EXPECT_NE(fh.find("force_N.rh.z (N),loaded.lf (bool)"), std::string::npos) << fh;
  EXPECT_NE(row.find(",2.5,0,0,0,0,0,1,0,0,"), std::string::npos) << row;
  const nlohmann::json fj = ToJson(f);
  EXPECT_DOUBLE_EQ(fj["force_N"][3][2].get<double>(), 2.5);
  EXPECT_EQ(fj["slipping"], nlohmann::json({false, true, false, false}));

  hyq_lcm::lcmt_hyq_signed_command sc{};
  sc.sender = "op";
  sc.mac[0] = 0xab;
  sc.mac[31] = 0x01;
  EXPECT_EQ(lcm_export::CsvHeader<hyq_lcm::lcmt_hyq_signed_command>(),
            "sender (text),command_size (bytes),mac (hex)");
  EXPECT_EQ(lcm_export::CsvRow(sc), "\"op\",0,\"ab" + std::string(60, '0') + "01\"");
  EXPECT_EQ(ToJson(sc)["mac"], "ab" + std::string(60, '0') + "01");
}

template <class T>
std::vector<std::uint8_t> Encode(const T& msg) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
  EXPECT_EQ(msg.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  return buf;
}

hyq_lcm::lcmt_hyq_event Event(std::int64_t cycle, const std::string& detail) {
  hyq_lcm::lcmt_hyq_event e{};
  e.cycle = cycle;
  e.from_mode = 2;
  e.to_mode = 3;
  e.from_name = "active";
  e.to_name = "damping";
  e.reason_code = 4;
  e.reason = "input_missing";
  e.joint = 2;
  e.bus = -1;
  e.detail = detail;
  return e;
}

TEST(ViewerJson, JointStateFieldByField) {
  hyq_lcm::lcmt_hyq_joint_state m{};
  m.utime = 123456;
  m.cycle = 42;
  m.mode = 2;
  for (int j = 0; j < 12; ++j) m.q_rad[j] = 0.1 * j;
  m.tracking_error_rad = 0.031;
  const auto json = DecodeMessage(Encode(m));
  ASSERT_TRUE(json.has_value());
  EXPECT_EQ((*json)["kind"], "joint");
  EXPECT_EQ((*json)["cycle"], 42);
  EXPECT_EQ((*json)["utime"], 123456);
  EXPECT_EQ((*json)["mode_name"], "active");
  ASSERT_EQ((*json)["q_rad"].size(), 12u);
  for (int j = 0; j < 12; ++j) EXPECT_DOUBLE_EQ((*json)["q_rad"][j].get<double>(), 0.1 * j);
  EXPECT_DOUBLE_EQ((*json)["tracking_error_rad"].get<double>(), 0.031);
}

TEST(ViewerJson, ContactCountsStanceAndAddsTheQpTimes) {
  hyq_lcm::lcmt_hyq_contact_state m{};
  m.cycle = 7;
  m.stance_estimated[0] = 1;
  m.stance_estimated[3] = 1;
  m.mu[2] = 0.4;
  m.contact_force_N[3][2] = 210.5;
  m.stage1_solve_us = 12.5;
  m.stage2_solve_us = 30.0;
  const auto json = DecodeMessage(Encode(m));
  ASSERT_TRUE(json.has_value());
  EXPECT_EQ((*json)["kind"], "contact");
  EXPECT_EQ((*json)["stance_count"], 2);
  EXPECT_EQ((*json)["stance_estimated"], nlohmann::json({true, false, false, true}));
  EXPECT_DOUBLE_EQ((*json)["mu"][2].get<double>(), 0.4);
  EXPECT_DOUBLE_EQ((*json)["contact_force_N"][3][2].get<double>(), 210.5);
  EXPECT_DOUBLE_EQ((*json)["qp_solve_us"].get<double>(), 42.5);
}

TEST(ViewerJson, SimTruth) {
  hyq_lcm::lcmt_hyq_sim_truth m{};
  m.sim_time_s = 1.25;
  m.position_m[2] = 0.6;
  m.orientation_wxyz[0] = 1.0;
  m.touching[1] = 1;
  m.mu[1] = 0.1;
  const auto json = DecodeMessage(Encode(m));
  ASSERT_TRUE(json.has_value());
  EXPECT_EQ((*json)["kind"], "truth");
  EXPECT_DOUBLE_EQ((*json)["position_m"][2].get<double>(), 0.6);
  EXPECT_EQ((*json)["touching"], nlohmann::json({false, true, false, false}));
}

TEST(ViewerJson, MalformedMessagesAreRefused) {
  hyq_lcm::lcmt_hyq_joint_state m{};
  std::vector<std::uint8_t> good = Encode(m);
  EXPECT_FALSE(DecodeMessage({}).has_value());
  EXPECT_FALSE(DecodeMessage(std::vector<std::uint8_t>(good.begin(), good.end() - 1)).has_value());
  std::vector<std::uint8_t> longer = good;
  longer.push_back(0);
  EXPECT_FALSE(DecodeMessage(longer).has_value());
  std::vector<std::uint8_t> unknown = good;
  unknown[0] ^= 0xff;
  EXPECT_FALSE(DecodeMessage(unknown).has_value());
  // an event whose string length runs past the datagram (the generated decoder trusts it)
  std::vector<std::uint8_t> event = Encode(Event(1, "x"));
  const std::size_t from_name_len = 8 + 8 + 8 + 1 + 1;  // fingerprint, utime, cycle, from, to
  event[from_name_len] = 0x7f;
  EXPECT_FALSE(DecodeMessage(event).has_value());
  // every truncation of a valid event
  const std::vector<std::uint8_t> whole = Encode(Event(1, "detail"));
  for (std::size_t n = 0; n < whole.size(); ++n)
    EXPECT_FALSE(DecodeMessage(std::vector<std::uint8_t>(whole.begin(), whole.begin() + static_cast<long>(n))))
        << n;
}

TEST(ViewerJson, FrameKeepsLatestStateAndEveryEventOnce) {
  TelemetryModel model;
  hyq_lcm::lcmt_hyq_joint_state j{};
  for (int c = 1; c <= 3; ++c) {
    j.cycle = c;
    EXPECT_TRUE(model.Feed("HYQ_JOINT_STATE", Encode(j)));
  }
  // the daemon repeats each event; the page gets it once
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(model.Feed("HYQ_EVENT", Encode(Event(2, "lf_kfe"))));
  EXPECT_TRUE(model.Feed("HYQ_EVENT", Encode(Event(3, "lf_kfe"))));
  EXPECT_FALSE(model.Feed("HYQ_JOINT_STATE", std::vector<std::uint8_t>{1, 2, 3}));
  nlohmann::json f = model.TakeFrame();
  EXPECT_EQ(f["type"], "frame");
  EXPECT_EQ(f["joint"]["cycle"], 3);
  ASSERT_EQ(f["events"].size(), 2u);
  EXPECT_EQ(f["events"][0]["cycle"], 2);
  EXPECT_EQ(f["events"][1]["cycle"], 3);
  EXPECT_EQ(f["recent_events"].size(), 2u);
  EXPECT_EQ(f["stats"]["messages"], 8);
  EXPECT_EQ(f["stats"]["undecodable"], 1);
  EXPECT_EQ(f["stats"]["channels"]["HYQ_EVENT"], 4);
  // the next frame: the state stays, the events were sent
  f = model.TakeFrame();
  EXPECT_EQ(f["joint"]["cycle"], 3);
  EXPECT_TRUE(f["events"].empty());
  EXPECT_EQ(f["recent_events"].size(), 2u);
  // a channel name of any bytes still dumps as JSON
  EXPECT_FALSE(model.Feed(std::string("\xff\x01 bad", 6), std::vector<std::uint8_t>{0}));
  EXPECT_NO_THROW((void)model.TakeFrame().dump());
}

// an lcm-logger file: sync, event number, timestamp, channel and data lengths, big-endian
void AppendLogEvent(std::vector<std::uint8_t>* log, std::int64_t n, std::int64_t t_us, const std::string& channel,
                    const std::vector<std::uint8_t>& data) {
  auto be = [&](std::uint64_t v, int bytes) {
    for (int i = bytes - 1; i >= 0; --i) log->push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  };
  be(0xEDA1DA01, 4);
  be(static_cast<std::uint64_t>(n), 8);
  be(static_cast<std::uint64_t>(t_us), 8);
  be(channel.size(), 4);
  be(data.size(), 4);
  log->insert(log->end(), channel.begin(), channel.end());
  log->insert(log->end(), data.begin(), data.end());
}

TEST(ViewerLogPlayer, SeekPauseSpeedAndGarbage) {
  const std::string path = testing::TempDir() + "viewer_player_test.lcmlog";
  {
    std::vector<std::uint8_t> log;
    hyq_lcm::lcmt_hyq_joint_state j{};
    for (int c = 0; c <= 100; ++c) {  // 1 s of joint states at 100 Hz, from t = 5 s
      j.cycle = c;
      AppendLogEvent(&log, c, 5'000'000 + 10'000 * c, "HYQ_JOINT_STATE", Encode(j));
    }
    AppendLogEvent(&log, 101, 5'500'000, "OTHER", {1, 2, 3});  // not a viewer channel: dropped
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(log.data()),
                                                 static_cast<std::streamsize>(log.size()));
  }
  LogPlayer player(path);
  EXPECT_EQ(player.size(), 101u);
  player.StartPaused();
  TelemetryModel model;
  player.Advance(100.0, &model);
  EXPECT_EQ(model.TakeFrame()["joint"]["cycle"], 0);
  EXPECT_TRUE(player.Control(R"({"cmd": "seek", "t_s": 0.5})", 100.0, &model));
  player.Advance(101.0, &model);  // paused: stays
  EXPECT_EQ(model.TakeFrame()["joint"]["cycle"], 50);
  EXPECT_DOUBLE_EQ(player.Status(101.0)["t_s"].get<double>(), 0.5);
  EXPECT_TRUE(player.Control(R"({"cmd": "speed", "speed": 0.5})", 101.0, &model));
  EXPECT_TRUE(player.Control(R"({"cmd": "resume"})", 101.0, &model));
  player.Advance(101.2, &model);  // 0.2 s wall at 0.5x: 0.1 s of log
  EXPECT_EQ(model.TakeFrame()["joint"]["cycle"], 60);
  player.Advance(110.0, &model);  // the end: paused there
  EXPECT_EQ(model.TakeFrame()["joint"]["cycle"], 100);
  EXPECT_TRUE(player.Status(110.0)["paused"].get<bool>());
  for (const char* bad : {"", "garbage {", "[1,2]", R"({"cmd": 3})", R"({"cmd": "seek"})",
                          R"({"cmd": "seek", "t_s": "soon"})", R"({"cmd": "speed", "speed": 1e9})",
                          R"({"cmd": "speed", "speed": -1})", R"({"cmd": "drive", "v": 1})"})
    EXPECT_FALSE(player.Control(bad, 111.0, &model)) << bad;
  EXPECT_TRUE(player.Control(R"({"cmd": "seek", "t_s": -3})", 111.0, &model));  // clamped to 0
  EXPECT_DOUBLE_EQ(player.Status(111.0)["t_s"].get<double>(), 0.0);
  std::remove(path.c_str());
}

TEST(ViewerLogPlayer, UnreadableOrEmptyLogThrowsNamingIt) {
  EXPECT_THROW(LogPlayer("/nonexistent/x.lcmlog"), std::runtime_error);
  const std::string path = testing::TempDir() + "viewer_empty.lcmlog";
  std::ofstream(path) << "not a log";
  try {
    LogPlayer p(path);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
}

}  // namespace
}  // namespace hyq::viewer
