// hyq_lcm messages as CSV cells: a header row "field (unit)" (array elements as field.lf_haa,
// field.x, ...) and one row per message. A type is recognised by its fingerprint (the first 8
// bytes of the data), whatever the channel is called. Decoding never throws and never trusts a
// length field: tests/tools/lcm_log_fuzz.cc runs it on fuzzed bytes.
#pragma once

#include <cstdint>
#include <span>
#include <string>

namespace hyq::lcm_export {

struct RowType {
  const char* name;  ///< "lcmt_hyq_joint_state", ...
  std::int64_t fingerprint;
  // the implementation: header cells when data is empty and `header`, else a row
  bool (*cells)(std::span<const std::uint8_t> data, bool header, std::string* line);
};

/// The hyq_lcm type of `data`, or null when its fingerprint is none of them.
const RowType* FindRowType(std::span<const std::uint8_t> data);

/// The header cells of `type`, comma-separated.
std::string HeaderCells(const RowType& type);

/// Appends the cells of one message of `type` to *line. False, with *line unchanged, when `data`
/// is not a well-formed `type` message (a length field out of range, bytes missing or left over).
bool RowCells(const RowType& type, std::span<const std::uint8_t> data, std::string* line);

}  // namespace hyq::lcm_export
