#include "tools/cli/command_line.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <utility>

namespace hyq::cli {
namespace {

// %g, without the trailing zeros std::to_string gives ("0.2", not "0.200000")
std::string Format(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

}  // namespace

std::optional<double> ParseNumber(std::string_view text) {
  const std::string s(text);
  if (s.empty() || std::isspace(static_cast<unsigned char>(s[0]))) return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || errno == ERANGE || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<long long> ParseInteger(std::string_view text) {
  const std::string s(text);
  if (s.empty() || std::isspace(static_cast<unsigned char>(s[0]))) return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (end != s.c_str() + s.size() || errno == ERANGE) return std::nullopt;
  return v;
}

std::vector<std::string> Split(std::string_view text, char separator) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t k = 0; k <= text.size(); ++k)
    if (k == text.size() || text[k] == separator) {
      parts.emplace_back(text.substr(start, k - start));
      start = k + 1;
    }
  return parts;
}

CommandLine::CommandLine(int argc, const char* const* argv, std::string tool, std::string help)
    : tool_(std::move(tool)), help_(std::move(help)) {
  for (int i = 1; i < argc; ++i) args_.emplace_back(argv[i]);
}

bool CommandLine::Next() {
  if (inline_value_) BadValue("no value", *inline_value_);
  flag_.clear();
  if (next_ >= args_.size()) return false;
  arg_ = args_[next_++];
  if (arg_ == "-h" || arg_ == "--help") {
    std::fputs(help_.c_str(), stdout);
    std::exit(0);
  }
  return true;
}

bool CommandLine::Flag(std::string_view name) {
  if (arg_ == name) {
    flag_ = name;
    return true;
  }
  if (name.starts_with("--") && arg_.size() > name.size() && arg_.starts_with(name) &&
      arg_[name.size()] == '=') {
    flag_ = name;
    inline_value_ = arg_.substr(name.size() + 1);
    return true;
  }
  return false;
}

bool CommandLine::IsOption() const {
  return arg_.size() > 1 && arg_[0] == '-' && !ParseNumber(arg_);
}

std::string CommandLine::Value() {
  if (inline_value_) {
    std::string v = std::move(*inline_value_);
    inline_value_.reset();
    return v;
  }
  if (next_ >= args_.size()) BadValue("a value", "end of arguments");
  return args_[next_++];
}

std::optional<std::string> CommandLine::OptionalValue() {
  if (inline_value_) return Value();
  if (next_ >= args_.size() || args_[next_].starts_with('-')) return std::nullopt;
  return args_[next_++];
}

std::pair<std::string, std::string> CommandLine::KeyValue(std::string_view expected) {
  const std::string v = Value();
  const std::size_t eq = v.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == v.size()) BadValue(expected, v);
  return {v.substr(0, eq), v.substr(eq + 1)};
}

std::string CommandLine::Text(std::size_t min_bytes, std::size_t max_bytes) {
  std::string v = Value();
  if (v.size() < min_bytes || v.size() > max_bytes)
    Fail(flag_ + ": expected " + std::to_string(min_bytes) + ".." + std::to_string(max_bytes) +
         " bytes, found " + std::to_string(v.size()));
  return v;
}

double CommandLine::Number(double lo, double hi, std::string_view expected) {
  const std::string v = Value();
  return NumberOf(flag_, v, lo, hi, expected);
}

long long CommandLine::Integer(long long lo, long long hi, std::string_view expected) {
  const std::string v = Value();
  const std::optional<long long> x = ParseInteger(v);
  if (!x || *x < lo || *x > hi)
    BadValue(expected.empty()
                 ? "an integer from " + std::to_string(lo) + " to " + std::to_string(hi)
                 : std::string(expected),
             v);
  return *x;
}

double CommandLine::NumberOf(std::string_view what, std::string_view text, double lo, double hi,
                             std::string_view expected) const {
  const std::optional<double> x = ParseNumber(text);
  if (!x || *x < lo || *x > hi) {
    const bool bounded =
        lo > std::numeric_limits<double>::lowest() || hi < std::numeric_limits<double>::max();
    Bad(what,
        !expected.empty() ? std::string(expected)
        : bounded         ? "a number in [" + Format(lo) + ", " + Format(hi) + "]"
                          : std::string("a number"),
        text);
  }
  return *x;
}

void CommandLine::BadValue(std::string_view expected, std::string_view found) const {
  Bad(flag_.empty() ? std::string_view(arg_) : std::string_view(flag_), expected, found);
}

void CommandLine::Bad(std::string_view what, std::string_view expected,
                      std::string_view found) const {
  Fail(std::string(what) + ": expected " + std::string(expected) + ", found '" +
       std::string(found) + "'");
}

void CommandLine::Unknown() const { Fail("unknown option '" + arg_ + "'"); }

void CommandLine::Fail(std::string_view message) const {
  std::fprintf(stderr, "%s: %.*s\n(%s --help for usage)\n", tool_.c_str(),
               static_cast<int>(message.size()), message.data(), tool_.c_str());
  std::exit(kExitUsage);
}

int Run(std::string_view tool, const std::function<int()>& work) {
  try {
    return work();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%.*s: %s\n", static_cast<int>(tool.size()), tool.data(), e.what());
    return kExitError;
  }
}

}  // namespace hyq::cli
