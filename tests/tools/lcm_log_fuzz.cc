// libFuzzer target for hyq-lcm-export's log reader and decoders (tools/hyq-lcm-export/lcm_log.h,
// csv_rows.h): any bytes, as a log, give events inside the input and counted damage, never a
// crash, an exception or UB; every decoded row has as many cells as its header, and every
// channel name becomes a safe file name.
//
// Built with clang++ -fsanitize=fuzzer,address,undefined by tests/tools/CMakeLists.txt when
// clang++ is found, and run for 30 s by the ctest tools.fuzz_lcm_log_30s (label fuzz).
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "tools/hyq-lcm-export/csv_rows.h"
#include "tools/hyq-lcm-export/lcm_log.h"

namespace {

void Check(bool ok) {
  if (!ok) std::abort();  // a property failed: libFuzzer reports it as a crash
}

bool SafeName(const std::string& s) {
  if (s.empty() || s.size() > 200 || s[0] == '.') return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
           c == '_' || c == '-' || c == '.';
  });
}

std::size_t Commas(const std::string& s) {
  return static_cast<std::size_t>(std::count(s.begin(), s.end(), ','));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace hyq::lcm_export;
  const std::span<const std::uint8_t> log(data, size);
  LogReader reader(log);
  LogEvent ev;
  std::size_t read = 0, last_end = 0;
  std::string cells;
  while (reader.Next(&ev)) {
    // in order, inside the input, not overlapping
    Check(ev.offset >= last_end && ev.data.data() + ev.data.size() <= data + size);
    Check(reinterpret_cast<const std::uint8_t*>(ev.channel.data()) == data + ev.offset + 28);
    last_end = reader.position();
    read += kLogHeaderBytes + ev.channel.size() + ev.data.size();
    Check(SafeName(SafeFileName(ev.channel)));
    (void)Printable(ev.channel);
    if (const RowType* type = FindRowType(ev.data)) {
      if (RowCells(*type, ev.data, &cells)) {
        const std::string header = HeaderCells(*type);
        // a text cell may hold commas, inside quotes: count only outside them
        std::string unquoted;
        bool quoted = false;
        for (const char c : cells) {
          if (c == '"') quoted = !quoted;
          else if (!quoted) unquoted += c;
        }
        Check(Commas(unquoted) == Commas(header));
      }
    }
  }
  Check(reader.position() == size);
  Check(read + reader.damage().skipped_bytes == size);
  return 0;
}
