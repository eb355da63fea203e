// The problem file of hyq-qp-solve (its --help and docs/qp.md): one JSON object
//   {"H": [[..]], "g": [..], "A": [[..]], "lbA": [..], "ubA": [..], "lb": [..], "ub": [..]}
// read into a hyq::qp::Problem. Apart from the tool, tests/tools/qp_problem_fuzz.cc calls it.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

#include "qp/problem.h"

namespace hyq::qp_solve {

/// Limits far above a real problem (40 × 40 H and 80 × 40 A take about 150 kB): a longer,
/// deeper or larger file is malformed, not a reason to exhaust memory or the stack, nor to let
/// H x overflow (|entry| above kMaxMagnitude).
inline constexpr std::size_t kMaxFileBytes = std::size_t{16} << 20;
inline constexpr int kMaxDepth = 64;
inline constexpr double kMaxMagnitude = 1e150;

/// A malformed file. what() is "<name>: <what was wrong>": the key, what was expected and what
/// was found.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Parses a problem from `text`; `name` (the file) starts every message. @throws InputError
qp::Problem ParseProblem(std::string_view text, const std::string& name);

/// Reads the file `path` (a regular file or a pipe of at most kMaxFileBytes) and parses it.
/// @throws InputError
qp::Problem ReadProblemFile(const std::string& path);

}  // namespace hyq::qp_solve
