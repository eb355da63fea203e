// The tools' command lines, read one argument at a time:
//
//   hyq::cli::CommandLine cl(argc, argv, "hyq-tool", kHelp);
//   while (cl.Next()) {
//     if (cl.Flag("--rate")) rate_hz = cl.Number(0.2, 20.0);
//     else if (cl.Flag("--quiet")) quiet = true;
//     else if (cl.IsOption()) cl.Unknown();
//     else files.push_back(cl.arg());
//   }
//
// -h and --help print the help text on stdout and exit 0. Every usage error prints one line
// "<tool>: <what>: expected <this>, found '<that>'" and a hint on stderr and exits with
// kExitUsage (2), before the tool opens any file, key or socket. Errors exit rather than throw,
// so that no tool's catch-all around its start-up can turn a usage error into another status.
#pragma once

#include <cstddef>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hyq::cli {

/// The exit status of a usage error (a bad flag, value or argument count), as for getopt tools.
inline constexpr int kExitUsage = 2;
/// The exit status of a configuration or start-up error (see Run).
inline constexpr int kExitError = 1;

/// The whole of `text` as a finite number (strtod syntax); nullopt for anything else.
std::optional<double> ParseNumber(std::string_view text);
/// The whole of `text` as a decimal integer; nullopt for anything else or beyond long long.
std::optional<long long> ParseInteger(std::string_view text);
/// `text` cut at every `separator` ("a,,b" gives "a", "", "b"; "" gives one empty part).
std::vector<std::string> Split(std::string_view text, char separator);

class CommandLine {
 public:
  /// `tool` names the messages; `help` is printed for -h / --help.
  CommandLine(int argc, const char* const* argv, std::string tool, std::string help);

  /// Steps to the next argument; false after the last. Prints the help and exits 0 for -h or
  /// --help; a usage error for a flag given as --flag=VALUE whose value was not used.
  bool Next();
  /// The current argument as given.
  const std::string& arg() const { return arg_; }
  /// Whether the current argument is `name` or `name=VALUE` (then Value() is VALUE).
  bool Flag(std::string_view name);
  /// Whether the current argument looks like an option: a '-' and more, but not "-" (standard
  /// input or output) and not a negative number.
  bool IsOption() const;

  /// The current flag's value: after its '=', else the next argument.
  /// Usage error "FLAG: expected a value, found 'end of arguments'" when there is none.
  std::string Value();
  /// The current flag's optional value: after its '=', else the next argument unless there is
  /// none or it begins with '-' (another option; such a value needs the --flag=VALUE form).
  std::optional<std::string> OptionalValue();
  /// Value() as KEY=VALUE cut at its first '=', both parts non-empty; `expected` names the form
  /// ("BUS=SPEC").
  std::pair<std::string, std::string> KeyValue(std::string_view expected);
  /// Value() of min_bytes..max_bytes bytes ("FLAG: expected 1..63 bytes, found 64").
  std::string Text(std::size_t min_bytes, std::size_t max_bytes);
  /// Value() as a finite number in [lo, hi]; `expected` replaces "a number in [lo, hi]".
  double Number(double lo, double hi, std::string_view expected = {});
  /// Value() as an integer in [lo, hi]; `expected` replaces "an integer from lo to hi".
  long long Integer(long long lo, long long hi, std::string_view expected = {});
  /// `text` (a positional argument or part of a value, called `what` in the message) as a finite
  /// number in [lo, hi]; without bounds "a number" is expected.
  double NumberOf(std::string_view what, std::string_view text,
                  double lo = std::numeric_limits<double>::lowest(),
                  double hi = std::numeric_limits<double>::max(),
                  std::string_view expected = {}) const;

  /// Usage error about the current flag: "FLAG: expected EXPECTED, found 'FOUND'".
  [[noreturn]] void BadValue(std::string_view expected, std::string_view found) const;
  /// Usage error about `what` (a flag, an argument, a part of a value).
  [[noreturn]] void Bad(std::string_view what, std::string_view expected,
                        std::string_view found) const;
  /// Usage error "unknown option 'ARG'" for the current argument.
  [[noreturn]] void Unknown() const;
  /// Usage error with `message` as it is.
  [[noreturn]] void Fail(std::string_view message) const;

  const std::string& tool() const { return tool_; }

 private:
  std::vector<std::string> args_;
  std::string tool_, help_;
  std::size_t next_ = 0;
  std::string arg_, flag_;
  std::optional<std::string> inline_value_;  // the VALUE of a current --flag=VALUE
};

/// Runs a tool's work after its command line was read: its exit status, or kExitError with
/// "<tool>: <what>" on stderr for an exception escaping it (a configuration or start-up error).
int Run(std::string_view tool, const std::function<int()>& work);

}  // namespace hyq::cli
