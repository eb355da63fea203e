// tools/hyq-qp-solve: a good file gives the optimum as JSON (exit 0); malformed files give one
// clear line naming the file, the key, what was expected and what was found (exit 2).
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/paths.h"
#include "tests/support/run_tool.h"

namespace {

using hyq::test::ToolRun;

ToolRun RunTool(const std::string& args) { return hyq::test::RunTool(HYQ_QP_SOLVE, args); }

std::string WriteTemp(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / ("hyq_qp_tool_test_" + name);
  std::ofstream(path) << text;
  return path.string();
}

TEST(HyqQpSolve, SolvesTheExampleFile) {
  const std::string file = (hyq::testing::SourceDir() / "tests/qp/data/tool_example.json").string();
  const ToolRun r = RunTool(file);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("status"), "optimal");
  EXPECT_NEAR(j.at("x")[0].get<double>(), 1.25, 1e-12);
  EXPECT_NEAR(j.at("x")[1].get<double>(), 0.75, 1e-12);
  EXPECT_NEAR(j.at("x")[2].get<double>(), 0.0, 1e-12);
  EXPECT_NEAR(j.at("objective").get<double>(), -4.40625, 1e-12);
  EXPECT_GE(j.at("iterations").get<int>(), 1);
  EXPECT_LE(j.at("kkt").at("stationarity").get<double>(), 1e-9);
  EXPECT_LE(j.at("kkt").at("primal").get<double>(), 1e-9);
}

TEST(HyqQpSolve, ReportsOtherStatusesWithExitOne) {
  const ToolRun r = RunTool(WriteTemp("infeasible.json",
                                  R"({"H": [[1]], "g": [0], "lb": [1], "ub": [null],
                                      "A": [[1]], "ubA": [0]})"));
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out).at("status"), "infeasible");
  const ToolRun u = RunTool(WriteTemp("unbounded.json", R"({"H": [[0]], "g": [-1], "lb": [0]})"));
  EXPECT_EQ(u.exit_code, 1) << u.out;
  EXPECT_EQ(nlohmann::json::parse(u.out).at("status"), "unbounded");
  const ToolRun b = RunTool(WriteTemp("badinput.json", R"({"H": [[1]], "g": [0], "lb": [2], "ub": [1]})"));
  EXPECT_EQ(b.exit_code, 1) << b.out;
  EXPECT_EQ(nlohmann::json::parse(b.out).at("status"), "bad_input");
}

TEST(HyqQpSolve, HelpAndUsage) {
  const ToolRun h = RunTool("--help");
  EXPECT_EQ(h.exit_code, 0);
  EXPECT_NE(h.out.find("usage: hyq-qp-solve FILE.json"), std::string::npos);
  EXPECT_EQ(RunTool("").exit_code, 2);
}

struct Malformed {
  const char* name;
  const char* text;
  const char* expect;  // a piece of the one-line message
};

TEST(HyqQpSolve, MalformedFilesGiveAClearErrorAndExitTwo) {
  const Malformed cases[] = {
      {"not_json", "{\"H\": [[1]], ", "not valid JSON"},
      {"not_object", "[1, 2]", "expected a JSON object at the top level, found array"},
      {"missing_h", R"({"g": [1]})", "key \"H\" is missing"},
      {"missing_g", R"({"H": [[1]]})", "key \"g\" is missing"},
      {"h_ragged", R"({"H": [[1, 0], [0]], "g": [1, 1]})",
       "key \"H[1]\": expected an array of 2 numbers (H is n × n), found array [0]"},
      {"h_string", R"({"H": [[1, "x"], [0, 1]], "g": [1, 1]})",
       "key \"H[0][1]\": expected a number, found string \"x\""},
      {"g_size", R"({"H": [[1]], "g": [1, 2]})", "key \"g\": expected an array of 1 numbers"},
      {"a_columns", R"({"H": [[1]], "g": [1], "A": [[1, 2]]})",
       "key \"A[0]\": expected an array of 1 numbers (A has n columns)"},
      {"lba_without_a", R"({"H": [[1]], "g": [1], "lbA": [0]})", "given without \"A\""},
      {"ub_bool", R"({"H": [[1]], "g": [1], "ub": [true]})",
       "key \"ub[0]\": expected a number or null, found boolean true"},
      {"typo", R"({"H": [[1]], "g": [1], "lB": [0]})", "unknown key \"lB\""},
      {"h_empty", R"({"H": [], "g": []})", "key \"H\": expected an array of 1 to 40 rows"},
  };
  for (const Malformed& c : cases) {
    const std::string file = WriteTemp(std::string(c.name) + ".json", c.text);
    const ToolRun r = RunTool(file);
    EXPECT_EQ(r.exit_code, 2) << c.name << ": " << r.out;
    EXPECT_NE(r.out.find(file), std::string::npos) << c.name << ": " << r.out;
    EXPECT_NE(r.out.find(c.expect), std::string::npos) << c.name << ": " << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << c.name << ": " << r.out;
  }
  const ToolRun missing = RunTool("/nonexistent/problem.json");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.out.find("/nonexistent/problem.json: cannot open the file"), std::string::npos);
}

}  // namespace
