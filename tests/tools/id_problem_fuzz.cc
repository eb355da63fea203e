// libFuzzer target for hyq-id's problem-line parser (servo/control/id_record.h): any bytes come
// back as a record or an IdRecordError, never another exception, a crash or UB; an accepted line
// survives FormatIdRecord and ParseIdRecord unchanged (the replay files hyq-id writes are read
// back by the same parser).
//
// Built with clang++ -fsanitize=fuzzer,address,undefined by tests/tools/CMakeLists.txt when
// clang++ is found, and run for 30 s by the ctest tools.fuzz_id_problem_30s (label fuzz).
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "servo/control/id_record.h"

namespace hyq::servo {

// FormatIdRecord names the fallback of a result; the solver file that defines this
// (two_stage_id.cc) is not compiled in, and no result is formatted here.
const char* ToString(Fallback) noexcept { return "none"; }

}  // namespace hyq::servo

namespace {

void Check(bool ok) {
  if (!ok) std::abort();  // a property failed: libFuzzer reports it as a crash
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace hyq::servo;
  IdRecord r;
  try {
    r = ParseIdRecord(std::string_view(reinterpret_cast<const char*>(data), size));
  } catch (const IdRecordError&) {
    return 0;
  }
  const IdRecord back = ParseIdRecord(FormatIdRecord(r));  // throws (a crash) if not accepted
  Check(back.input.q == r.input.q && back.input.v == r.input.v &&
        back.input.qdd_des == r.input.qdd_des && back.input.stance == r.input.stance &&
        back.input.mu == r.input.mu && back.input.dt == r.input.dt &&
        back.controller == r.controller);
  for (int f = 0; f < 4; ++f) Check(back.input.normal_W[f] == r.input.normal_W[f]);
  return 0;
}
