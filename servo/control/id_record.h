// ID problem files: one JSON object per line, written by the servo loop and the experiments for
// debugging and regression, solved again by hyq-id (docs/inverse_dynamics.md, "Problem files").
//
//   {"q": [19], "v": [18], "qdd_des": [12], "stance": [4 bools, lf rf lh rh], "mu": [4],
//    "normal": [[3] × 4] (optional, default world z), "h": s,
//    "controller": "two_stage" | "stage1" | "noslip"}
// with q, v as in docs/conventions.md. A solved line carries "result" as well:
//   {"tau": [12] N·m, "impulses": [{"foot": "lf", "normal": N·s, "tangent": [3] N·s}, ...],
//    "stage1": {"status": .., "objective": ..}, "stage2": {...}, "kinetic_energy": J,
//    "fallback": "none" | "stage1_torque" | "contact_free_id" | "safety"}
// Reading and writing allocate: this is for tools and non-real-time threads, never the cycle.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

#include "servo/control/controller.h"

namespace hyq::servo {

/// Limits on one line, far above a real record (about 2 kB, nested 3 deep): a longer or deeper
/// line is malformed, not a reason to exhaust memory or the stack.
inline constexpr std::size_t kMaxIdRecordBytes = std::size_t{1} << 20;
inline constexpr int kMaxIdRecordDepth = 64;

/// A malformed line. what() names the key, what was expected and what was found.
class IdRecordError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct IdRecord {
  IdInput input;
  ControllerKind controller = ControllerKind::kTwoStageId;
};

/// Parses one line. @throws IdRecordError (and nothing else but std::bad_alloc)
IdRecord ParseIdRecord(std::string_view line);

/// One line (no newline) for `record`, with "result" when `result` is given.
std::string FormatIdRecord(const IdRecord& record, const IdOutput* result = nullptr);

}  // namespace hyq::servo
