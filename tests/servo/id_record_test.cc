// ID problem files: round trips, clear errors for malformed lines, and hyq-id on a file with bad
// lines among good ones.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <unistd.h>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "servo/control/id_record.h"
#include "tests/servo/id_fixture.h"

namespace hyq::servo {
namespace {

using ::testing::HasSubstr;
using testing::HyqModel;

IdRecord Example(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  IdRecord r;
  r.input = testing::StandingInput(&rng, {true, false, false, true});
  testing::MakeContactConsistent(&r.input, dynamics::Vector6d::Constant(0.05),
                                 dynamics::Vector6d::Constant(0.3), &rng);
  r.input.mu = {0.1, 0.2, 0.3, 0.4};
  r.input.normal_W[1] = Eigen::Vector3d(0.1, 0.0, 1.0).normalized();
  r.controller = ControllerKind::kStage1Id;
  return r;
}

std::string ErrorOf(const std::string& line) {
  try {
    ParseIdRecord(line);
  } catch (const IdRecordError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted: " << line;
  return "";
}

TEST(IdRecord, RoundTripsExactly) {
  const IdRecord r = Example(1);
  const IdRecord back = ParseIdRecord(FormatIdRecord(r));
  EXPECT_EQ(back.input.q, r.input.q);
  EXPECT_EQ(back.input.v, r.input.v);
  EXPECT_EQ(back.input.qdd_des, r.input.qdd_des);
  EXPECT_EQ(back.input.stance, r.input.stance);
  EXPECT_EQ(back.input.mu, r.input.mu);
  for (int f = 0; f < 4; ++f) EXPECT_EQ(back.input.normal_W[f], r.input.normal_W[f]);
  EXPECT_EQ(back.input.dt, r.input.dt);
  EXPECT_EQ(back.controller, r.controller);
}

TEST(IdRecord, MalformedLinesNameTheKey) {
  nlohmann::json j = nlohmann::json::parse(FormatIdRecord(Example(2)));
  auto with = [&](const std::string& key, const nlohmann::json& value) {
    nlohmann::json k = j;
    k[key] = value;
    return k.dump();
  };
  auto without = [&](const std::string& key) {
    nlohmann::json k = j;
    k.erase(key);
    return k.dump();
  };
  EXPECT_THAT(ErrorOf("{\"q\": [1, 2"), HasSubstr("not valid JSON"));
  EXPECT_THAT(ErrorOf("[1, 2]"), HasSubstr("a JSON object"));
  EXPECT_THAT(ErrorOf(without("qdd_des")), HasSubstr("\"qdd_des\": missing"));
  EXPECT_THAT(ErrorOf(with("v", {1, 2, 3})), HasSubstr("\"v\": expected an array of 18 numbers"));
  nlohmann::json q = j["q"];
  q[3] = 2.0;
  EXPECT_THAT(ErrorOf(with("q", q)), HasSubstr("unit quaternion"));
  EXPECT_THAT(ErrorOf(with("stance", {true, 1, false, true})), HasSubstr("stance[1]"));
  EXPECT_THAT(ErrorOf(with("mu", {0.5, -1, 0.5, 0.5})), HasSubstr("mu[1]"));
  EXPECT_THAT(ErrorOf(with("h", 0)), HasSubstr("\"h\": expected a time step"));
  EXPECT_THAT(ErrorOf(with("controller", "pid")), HasSubstr("\"controller\": expected"));
  EXPECT_THAT(ErrorOf(with("normal", {{0, 0, 0}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}})),
              HasSubstr("normal[0]"));
  nlohmann::json qdd = j["qdd_des"];
  qdd[4] = "fast";
  EXPECT_THAT(ErrorOf(with("qdd_des", qdd)), HasSubstr("qdd_des[4]\": expected a number, found \"fast\""));
}

// before: 1e999 escaped as nlohmann's out_of_range (hyq-id aborted, losing every later line) and
// 100 000 '[' overflowed the stack
TEST(IdRecord, HostileLinesAreIdRecordErrors) {
  std::string line = FormatIdRecord(Example(3));
  const auto h = line.find("\"h\":");
  ASSERT_NE(h, std::string::npos);
  EXPECT_THAT(ErrorOf(line.substr(0, h) + "\"h\":1e999,\"x\":" + line.substr(h + 4)),
              HasSubstr("expected numbers within the range of a double, found: "));
  EXPECT_THAT(ErrorOf(line.substr(0, h) + "\"h\":-1e999,\"x\":" + line.substr(h + 4)),
              HasSubstr("-1e999"));
  EXPECT_THAT(ErrorOf(std::string(100000, '[') + std::string(100000, ']')),
              HasSubstr("nested at most 64 deep, found more"));
  EXPECT_THAT(ErrorOf("{\"q\": " + std::string(65, '[') + std::string(65, ']') + "}"),
              HasSubstr("nested at most 64 deep"));
  // brackets inside a string are text, not nesting
  EXPECT_THAT(ErrorOf("{\"q\": \"" + std::string(1000, '[') + "\\\"\"}"),
              HasSubstr("\"q\": expected an array of 19 numbers"));
  EXPECT_THAT(ErrorOf(std::string(kMaxIdRecordBytes + 1, ' ')), HasSubstr("at most 1048576 bytes"));
}

TEST(HyqIdTool, SolvesGoodLinesAndReportsBadOnes) {
  const auto dir = std::filesystem::temp_directory_path() / ("hyq_id_test_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const auto in_path = dir / "in.jsonl", out_path = dir / "out.jsonl", err_path = dir / "err.txt";
  std::vector<IdRecord> good;
  {
    std::ofstream in(in_path);
    for (int i = 0; i < 5; ++i) {
      if (i == 1) in << "{\"q\": 3}\n";      // line 2: bad
      if (i == 3) in << "not json at all\n";  // line 5: bad
      IdRecord r = Example(10 + i);
      r.controller = i % 3 == 0 ? ControllerKind::kTwoStageId
                                : (i % 3 == 1 ? ControllerKind::kStage1Id : ControllerKind::kNoSlipId);
      good.push_back(r);
      in << FormatIdRecord(r) << "\n";
    }
  }
  const std::string cmd = std::string(HYQ_ID_TOOL) + " " + in_path.string() + " " +
                          out_path.string() + " 2> " + err_path.string();
  const int rc = std::system(cmd.c_str());
  EXPECT_EQ(WEXITSTATUS(rc), 1);  // bad lines present
  std::ifstream err(err_path);
  std::stringstream es;
  es << err.rdbuf();
  EXPECT_THAT(es.str(), HasSubstr("in.jsonl:2: \"q\": expected an array of 19 numbers"));
  EXPECT_THAT(es.str(), HasSubstr("in.jsonl:5: not valid JSON"));
  EXPECT_THAT(es.str(), HasSubstr("5 solved"));

  // every good line is solved exactly as an in-process solve does
  std::ifstream out(out_path);
  std::string line;
  int n = 0;
  TwoStageSettings s1;
  s1.stage2 = false;
  TwoStageId two, one(s1);
  NoSlipId noslip;
  while (std::getline(out, line)) {
    const nlohmann::json j = nlohmann::json::parse(line);
    ASSERT_TRUE(j.contains("result"));
    const IdRecord& r = good[n++];
    auto d = std::make_unique<dynamics::CycleDynamics>();
    ASSERT_EQ(dynamics::ComputeCycleDynamics(HyqModel(), r.input.q, r.input.v, d.get()),
              dynamics::DynamicsStatus::kOk);
    IdOutput o;
    if (r.controller == ControllerKind::kTwoStageId) (void)two.Solve(HyqModel(), *d, r.input, &o);
    if (r.controller == ControllerKind::kStage1Id) (void)one.Solve(HyqModel(), *d, r.input, &o);
    if (r.controller == ControllerKind::kNoSlipId) (void)noslip.Solve(HyqModel(), *d, r.input, &o);
    for (int k = 0; k < 12; ++k) EXPECT_NEAR(j["result"]["tau"][k].get<double>(), o.tau_Nm(k), 1e-9);
    EXPECT_EQ(j["result"]["impulses"].size(), 2u);  // lf and rh in stance
    EXPECT_EQ(j["result"]["fallback"], "none");
  }
  EXPECT_EQ(n, 5);
  std::filesystem::remove_all(dir);
}

TEST(HyqIdTool, UsageErrorsExitTwo) {
  EXPECT_EQ(WEXITSTATUS(std::system((std::string(HYQ_ID_TOOL) + " > /dev/null 2>&1").c_str())), 2);
  EXPECT_EQ(WEXITSTATUS(std::system((std::string(HYQ_ID_TOOL) + " --tangents 0 a b > /dev/null 2>&1").c_str())), 2);
  EXPECT_EQ(WEXITSTATUS(std::system((std::string(HYQ_ID_TOOL) + " /nonexistent.jsonl - > /dev/null 2>&1").c_str())), 2);
  EXPECT_EQ(WEXITSTATUS(std::system((std::string(HYQ_ID_TOOL) + " --help > /dev/null").c_str())), 0);
}

}  // namespace
}  // namespace hyq::servo
