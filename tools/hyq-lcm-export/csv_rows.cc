#include "tools/hyq-lcm-export/csv_rows.h"

#include <array>
#include <climits>
#include <cstddef>
#include <cstdio>
#include <exception>

namespace hyq::lcm_export {

void CsvArchive::Value(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.17g", v);
  *line_ += b;
}

void CsvArchive::Value(const std::string& s) {
  *line_ += '"';
  for (char c : s) {
    if (c == '"') *line_ += '"';
    *line_ += (c == '\n' || c == '\r') ? ' ' : c;
  }
  *line_ += '"';
}

namespace {

// The encoding after the fingerprint of the types whose size varies, field by field as lcm-gen
// writes it (lcmtypes/*.lcm). The generated decode trusts a string length (INT32_MIN copies 2 GB)
// and an array count (-1 resizes to SIZE_MAX), so those are checked first; the other types have
// fixed sizes, which the generated decode checks itself. tests/tools/lcm_export_test.cc keeps
// these layouts equal to the generated code.
enum class Wire : std::uint8_t { k1, k2, k8, kCount8, kCount32, kDoubles, kBytes, kMac, kString };
constexpr Wire kEventLayout[] = {Wire::k8,      Wire::k8, Wire::k1,      Wire::k1,
                                 Wire::kString, Wire::kString, Wire::k2, Wire::kString,
                                 Wire::k2,      Wire::k2, Wire::kString, Wire::k1, Wire::kString};
constexpr Wire kCommandLayout[] = {Wire::k8,      Wire::k8,      Wire::k1, Wire::kCount8,
                                   Wire::kDoubles, Wire::kString, Wire::k8, Wire::k8,
                                   Wire::k8,       Wire::k8,      Wire::k8};
constexpr Wire kSignedCommandLayout[] = {Wire::kString, Wire::kCount32, Wire::kBytes, Wire::kMac};

template <class T>
constexpr std::span<const Wire> kLayout{};
template <>
constexpr std::span<const Wire> kLayout<hyq_lcm::lcmt_hyq_event> = kEventLayout;
template <>
constexpr std::span<const Wire> kLayout<hyq_lcm::lcmt_hyq_command> = kCommandLayout;
template <>
constexpr std::span<const Wire> kLayout<hyq_lcm::lcmt_hyq_signed_command> = kSignedCommandLayout;

std::int32_t Be32(const std::uint8_t* b) {
  return static_cast<std::int32_t>((std::uint32_t{b[0]} << 24) | (std::uint32_t{b[1]} << 16) |
                                   (std::uint32_t{b[2]} << 8) | std::uint32_t{b[3]});
}

// true when every length field of `data` (fingerprint first) fits and nothing is left over
bool LengthsFit(std::span<const Wire> layout, std::span<const std::uint8_t> data) {
  std::size_t pos = 8;
  std::size_t count = 0;
  auto take = [&](std::size_t n) {
    if (data.size() - pos < n) return false;
    pos += n;
    return true;
  };
  for (const Wire w : layout) {
    bool ok = true;
    switch (w) {
      case Wire::k1: ok = take(1); break;
      case Wire::k2: ok = take(2); break;
      case Wire::k8: ok = take(8); break;
      case Wire::kCount8: {
        ok = take(1);
        const auto n = ok ? static_cast<std::int8_t>(data[pos - 1]) : std::int8_t{-1};
        ok = n >= 0;
        count = ok ? static_cast<std::size_t>(n) : 0;
        break;
      }
      case Wire::kCount32: {
        ok = take(4);
        const std::int32_t n = ok ? Be32(data.data() + pos - 4) : -1;
        ok = n >= 0;
        count = ok ? static_cast<std::size_t>(n) : 0;
        break;
      }
      case Wire::kDoubles: ok = count <= data.size() / 8 && take(8 * count); break;
      case Wire::kBytes: ok = take(count); break;
      case Wire::kMac: ok = take(32); break;
      case Wire::kString: {
        // int32 length including the terminating NUL, then the bytes
        ok = take(4);
        const std::int32_t n = ok ? Be32(data.data() + pos - 4) : 0;
        ok = n >= 1 && take(static_cast<std::size_t>(n));
        break;
      }
    }
    if (!ok) return false;
  }
  return pos == data.size();
}

template <class T>
bool Cells(std::span<const std::uint8_t> data, bool header, std::string* line) {
  T msg{};
  if (!header) {
    if (data.size() < 8 || data.size() > INT_MAX) return false;
    if (!kLayout<T>.empty() && !LengthsFit(kLayout<T>, data)) return false;
    const int size = static_cast<int>(data.size());
    try {
      if (msg.decode(data.data(), 0, size) != size) return false;
    } catch (const std::exception&) {  // std::bad_alloc, or a length the check above missed
      return false;
    }
  }
  *line = header ? CsvHeader<T>() : CsvRow(msg);
  return true;
}

template <class T>
RowType Type(const char* name) {
  return RowType{name, T::getHash(), &Cells<T>};
}

}  // namespace

const RowType* FindRowType(std::span<const std::uint8_t> data) {
  static const std::array<RowType, 12> kTypes = {
      Type<hyq_lcm::lcmt_hyq_joint_state>("lcmt_hyq_joint_state"),
      Type<hyq_lcm::lcmt_hyq_joint_torque>("lcmt_hyq_joint_torque"),
      Type<hyq_lcm::lcmt_hyq_base_state>("lcmt_hyq_base_state"),
      Type<hyq_lcm::lcmt_hyq_contact_state>("lcmt_hyq_contact_state"),
      Type<hyq_lcm::lcmt_hyq_friction_estimate>("lcmt_hyq_friction_estimate"),
      Type<hyq_lcm::lcmt_hyq_disturbance_estimate>("lcmt_hyq_disturbance_estimate"),
      Type<hyq_lcm::lcmt_hyq_servo_timing>("lcmt_hyq_servo_timing"),
      Type<hyq_lcm::lcmt_hyq_sim_truth>("lcmt_hyq_sim_truth"),
      Type<hyq_lcm::lcmt_hyq_health>("lcmt_hyq_health"),
      Type<hyq_lcm::lcmt_hyq_event>("lcmt_hyq_event"),
      Type<hyq_lcm::lcmt_hyq_command>("lcmt_hyq_command"),
      Type<hyq_lcm::lcmt_hyq_signed_command>("lcmt_hyq_signed_command"),
  };
  if (data.size() < 8) return nullptr;
  std::uint64_t h = 0;
  for (int i = 0; i < 8; ++i) h = (h << 8) | data[static_cast<std::size_t>(i)];
  for (const RowType& t : kTypes)
    if (t.fingerprint == static_cast<std::int64_t>(h)) return &t;
  return nullptr;
}

std::string HeaderCells(const RowType& type) {
  std::string line;
  type.cells({}, true, &line);
  return line;
}

bool RowCells(const RowType& type, std::span<const std::uint8_t> data, std::string* line) {
  return type.cells(data, false, line);
}

}  // namespace hyq::lcm_export
