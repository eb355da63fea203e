// hyq_lcm messages as CSV cells: a header row "field (unit)" (array elements as field.lf_haa,
// field.x, ...) and one row per message, both derived from the message's field list
// (lcmtypes/telemetry_fields.h) by CsvArchive. A type is recognised by its fingerprint (the first
// 8 bytes of the data), whatever the channel is called. Decoding never throws and never trusts a
// length field: tests/tools/lcm_log_fuzz.cc runs it on fuzzed bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "lcmtypes/telemetry_fields.h"

namespace hyq::lcm_export {

/// Writes either the header cells or one message's cells, comma-separated, in the order of the
/// message's Serialize. Names: field, field.label, field.label.label2, and for an array of
/// messages label.subfield ("bus0.rx_frames"). Values: numbers as %.17g or integers, "bool"
/// fields as 1/0, strings quoted (" doubled, line breaks as spaces), byte arrays as quoted hex.
class CsvArchive {
 public:
  CsvArchive(bool header, std::string* line) : header_(header), line_(line) {}

  template <class T>
  void Visit(const char* name, const char* unit, const T* value) {
    Cell(std::string(name), unit, *value);
  }
  template <class T, std::size_t N>
  void Visit(const char* name, const char* unit, const T (*values)[N],
             const char* const (&labels)[N]) {
    for (std::size_t i = 0; i < N; ++i) Cell(Join(name, labels[i]), unit, (*values)[i]);
  }
  template <class T, std::size_t N, std::size_t M>
  void Visit(const char* name, const char* unit, const T (*values)[N][M],
             const char* const (&labels)[N], const char* const (&labels2)[M]) {
    for (std::size_t i = 0; i < N; ++i)
      for (std::size_t k = 0; k < M; ++k)
        Cell(Join(Join(name, labels[i]), labels2[k]), unit, (*values)[i][k]);
  }
  /// A variable array: one cell per label, T{} past its end.
  template <class T, std::size_t N>
  void Visit(const char* name, const char* unit, const std::vector<T>* values,
             const char* const (&labels)[N]) {
    for (std::size_t i = 0; i < N; ++i)
      Cell(Join(name, labels[i]), unit, i < values->size() ? (*values)[i] : T{});
  }
  /// A fixed byte array: one hex cell.
  template <std::size_t N>
  void Visit(const char* name, const char* unit, const std::uint8_t (*bytes)[N]) {
    std::string hex;
    for (std::size_t i = 0; i < N; ++i) {
      char b[3];
      std::snprintf(b, sizeof b, "%02x", (*bytes)[i]);
      hex += b;
    }
    Cell(std::string(name), unit, hex);
  }
  template <class S, std::size_t N>
  void Visit(const char* /*name*/, const S (*structs)[N], const char* const (&labels)[N]) {
    const std::string outer = prefix_;
    for (std::size_t i = 0; i < N; ++i) {
      prefix_ = outer + labels[i] + ".";
      Serialize(this, const_cast<S*>(&(*structs)[i]));
    }
    prefix_ = outer;
  }

 private:
  static std::string Join(std::string_view a, std::string_view b) {
    std::string s(a);
    s += '.';
    s += b;
    return s;
  }
  template <class T>
  void Cell(const std::string& name, const char* unit, const T& value) {
    if (!line_->empty()) *line_ += ',';
    if (header_) {
      *line_ += prefix_ + name + " (" + unit + ")";
    } else if constexpr (std::is_same_v<T, std::int8_t>) {
      if (std::string_view(unit) == "bool") {
        *line_ += value != 0 ? '1' : '0';
      } else {
        *line_ += std::to_string(static_cast<int>(value));
      }
    } else {
      Value(value);
    }
  }
  void Value(double v);
  void Value(std::int64_t v) { *line_ += std::to_string(v); }
  void Value(std::int32_t v) { *line_ += std::to_string(v); }
  void Value(std::int16_t v) { *line_ += std::to_string(v); }
  void Value(const std::string& s);

  bool header_;
  std::string* line_;
  std::string prefix_;
};

/// The header cells of message type T, comma-separated.
template <class T>
std::string CsvHeader() {
  T msg{};
  std::string line;
  CsvArchive a(true, &line);
  Serialize(&a, &msg);
  return line;
}

/// The cells of one message, comma-separated.
template <class T>
std::string CsvRow(const T& msg) {
  std::string line;
  CsvArchive a(false, &line);
  Serialize(&a, const_cast<T*>(&msg));  // CsvArchive only reads
  return line;
}

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

/// Sets *line to the cells of one message of `type`. False, with *line unchanged, when `data`
/// is not a well-formed `type` message (a length field out of range, bytes missing or left over).
bool RowCells(const RowType& type, std::span<const std::uint8_t> data, std::string* line);

}  // namespace hyq::lcm_export
