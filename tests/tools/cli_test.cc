// The tools' command-line helper (tools/cli/command_line.h): flags with separate and inline
// values, typed values, positional arguments, and every usage error's message and exit status 2.
#include "tools/cli/command_line.h"

#include <gtest/gtest.h>

#include <initializer_list>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace hyq::cli {
namespace {

// argv for CommandLine, program name first
class Argv {
 public:
  Argv(std::initializer_list<const char*> args) : args_{"tool"} {
    args_.insert(args_.end(), args.begin(), args.end());
  }
  int argc() const { return static_cast<int>(args_.size()); }
  const char* const* argv() const { return args_.data(); }

 private:
  std::vector<const char*> args_;
};

CommandLine Make(const Argv& a) {
  return CommandLine(a.argc(), a.argv(), "hyq-tool", "usage: hyq-tool\n");
}

TEST(ParseNumber, TakesTheWholeTextAsAFiniteNumber) {
  EXPECT_EQ(ParseNumber("0.25"), 0.25);
  EXPECT_EQ(ParseNumber("-3e2"), -300.0);
  EXPECT_FALSE(ParseNumber(""));
  EXPECT_FALSE(ParseNumber("1.5x"));
  EXPECT_FALSE(ParseNumber(" 1"));
  EXPECT_FALSE(ParseNumber("inf"));
  EXPECT_FALSE(ParseNumber("nan"));
  EXPECT_FALSE(ParseNumber("1e999"));
}

TEST(ParseInteger, TakesTheWholeTextAsADecimalInteger) {
  EXPECT_EQ(ParseInteger("42"), 42);
  EXPECT_EQ(ParseInteger("-7"), -7);
  EXPECT_FALSE(ParseInteger("1.5"));
  EXPECT_FALSE(ParseInteger("1e3"));
  EXPECT_FALSE(ParseInteger("99999999999999999999"));
  EXPECT_FALSE(ParseInteger(""));
}

TEST(Split, KeepsEmptyParts) {
  EXPECT_EQ(Split("a,,b", ','), (std::vector<std::string>{"a", "", "b"}));
  EXPECT_EQ(Split("", ','), (std::vector<std::string>{""}));
  EXPECT_EQ(Split("1:2", ':'), (std::vector<std::string>{"1", "2"}));
}

TEST(CommandLine, ReadsFlagsValuesAndPositionalArguments) {
  const Argv a{"--rate", "4", "--name=x=y", "-q", "in.log", "-", "-0.5", "--count", "12"};
  CommandLine cl = Make(a);
  double rate = 0, negative = 0;
  long long count = 0;
  std::string name;
  bool quiet = false;
  std::vector<std::string> files;
  while (cl.Next()) {
    if (cl.Flag("--rate")) rate = cl.Number(0.2, 20.0);
    else if (cl.Flag("--name")) name = cl.Value();
    else if (cl.Flag("-q")) quiet = true;
    else if (cl.Flag("--count")) count = cl.Integer(0, 100);
    else if (cl.IsOption()) cl.Unknown();
    else if (cl.arg() == "-0.5") negative = cl.NumberOf("X", cl.arg());
    else files.push_back(cl.arg());
  }
  EXPECT_EQ(rate, 4.0);
  EXPECT_EQ(name, "x=y");
  EXPECT_TRUE(quiet);
  EXPECT_EQ(count, 12);
  EXPECT_EQ(negative, -0.5);
  EXPECT_EQ(files, (std::vector<std::string>{"in.log", "-"}));
}

TEST(CommandLine, AFlagIsNotAPrefixOfAnother) {
  const Argv a{"--rate-hz", "3"};
  CommandLine cl = Make(a);
  ASSERT_TRUE(cl.Next());
  EXPECT_FALSE(cl.Flag("--rate"));
  EXPECT_TRUE(cl.Flag("--rate-hz"));
}

// each usage error: one line naming what, what was expected and what was found; exit 2
void ExpectUsageError(std::initializer_list<const char*> args, const std::string& message) {
  const Argv a(args);
  EXPECT_EXIT(
      {
        CommandLine cl = Make(a);
        while (cl.Next()) {
          if (cl.Flag("--rate")) (void)cl.Number(0.2, 20.0);
          else if (cl.Flag("--port")) (void)cl.Integer(0, 65535, "a port number 0..65535");
          else if (cl.Flag("--quiet")) continue;
          else if (cl.Flag("--bus")) (void)cl.KeyValue("BUS=SPEC");
          else if (cl.Flag("--mode")) {
            const std::string v = cl.Value();
            if (v != "fast") cl.BadValue("fast", v);
          } else if (cl.IsOption()) cl.Unknown();
          else (void)cl.NumberOf("VY", cl.arg());
        }
        std::exit(0);
      },
      ::testing::ExitedWithCode(kExitUsage), "hyq-tool: " + message);
}

TEST(CommandLine, UsageErrorsNameTheFlagTheExpectationAndTheFinding) {
  ExpectUsageError({"--rate", "fast"}, "--rate: expected a number in \\[0.2, 20\\], found 'fast'");
  ExpectUsageError({"--rate", "50"}, "--rate: expected a number in \\[0.2, 20\\], found '50'");
  ExpectUsageError({"--rate=50"}, "--rate: expected a number in \\[0.2, 20\\], found '50'");
  ExpectUsageError({"--port", "70000"},
                   "--port: expected a port number 0..65535, found '70000'");
  ExpectUsageError({"--port"}, "--port: expected a value, found 'end of arguments'");
  ExpectUsageError({"--mode", "slow"}, "--mode: expected fast, found 'slow'");
  ExpectUsageError({"--quiet=1"}, "--quiet: expected no value, found '1'");
  ExpectUsageError({"--frobnicate"}, "unknown option '--frobnicate'");
  ExpectUsageError({"--bus", "lf"}, "--bus: expected BUS=SPEC, found 'lf'");
  ExpectUsageError({"--bus", "=udp::1"}, "--bus: expected BUS=SPEC, found '=udp::1'");
  ExpectUsageError({"--bus=lf="}, "--bus: expected BUS=SPEC, found 'lf='");
  ExpectUsageError({"fast"}, "VY: expected a number, found 'fast'");
}

TEST(CommandLine, KeyValueCutsAtTheFirstEquals) {
  const Argv a{"--bus", "lf=udp::43101", "--bus=rh=socketcan:vcan0=x"};
  CommandLine cl = Make(a);
  std::vector<std::pair<std::string, std::string>> buses;
  while (cl.Next())
    if (cl.Flag("--bus")) buses.push_back(cl.KeyValue("BUS=SPEC"));
  EXPECT_EQ(buses, (std::vector<std::pair<std::string, std::string>>{
                       {"lf", "udp::43101"}, {"rh", "socketcan:vcan0=x"}}));
}

TEST(CommandLine, AnOptionalValueIsTheNextArgumentUnlessAnOption) {
  const Argv a{"--url", "udpm://x", "--url", "--quiet", "--url=-y", "--url"};
  CommandLine cl = Make(a);
  std::vector<std::optional<std::string>> urls;
  while (cl.Next())
    if (cl.Flag("--url")) urls.push_back(cl.OptionalValue());
  EXPECT_EQ(urls, (std::vector<std::optional<std::string>>{"udpm://x", std::nullopt, "-y",
                                                           std::nullopt}));
}

TEST(CommandLine, TextChecksItsLength) {
  const Argv a{"--sender", "op@console", "--sender", ""};
  CommandLine cl = Make(a);
  ASSERT_TRUE(cl.Next());
  ASSERT_TRUE(cl.Flag("--sender"));
  EXPECT_EQ(cl.Text(1, 63), "op@console");
  ASSERT_TRUE(cl.Next());
  ASSERT_TRUE(cl.Flag("--sender"));
  EXPECT_EXIT(cl.Text(1, 63), ::testing::ExitedWithCode(kExitUsage),
              "hyq-tool: --sender: expected 1..63 bytes, found 0");
}

TEST(Run, AnEscapingExceptionIsReportedWithStatusOne) {
  EXPECT_EQ(hyq::cli::Run("hyq-tool", [] { return 3; }), 3);
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(hyq::cli::Run("hyq-tool", []() -> int { throw std::runtime_error("config.yaml: bad key"); }),
            kExitError);
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "hyq-tool: config.yaml: bad key\n");
}

TEST(CommandLine, FailAddsTheHelpHint) {
  EXPECT_EXIT(Make(Argv{}).Fail("expected LOG and OUT_DIR, found 0 argument(s)"),
              ::testing::ExitedWithCode(2),
              "hyq-tool: expected LOG and OUT_DIR, found 0 argument\\(s\\)\n\\(hyq-tool --help "
              "for usage\\)");
}

TEST(CommandLine, HelpPrintsTheTextAndExitsZero) {
  const Argv a{"--rate", "1", "--help"};
  EXPECT_EXIT(
      {
        CommandLine cl = Make(a);
        while (cl.Next())
          if (cl.Flag("--rate")) (void)cl.Number(0.2, 20.0);
      },
      ::testing::ExitedWithCode(0), "");
}

}  // namespace
}  // namespace hyq::cli
