// libFuzzer target for hyq-qp-solve's problem reader (tools/hyq-qp-solve/problem_reader.h) and
// the solver behind it: any bytes come back as a problem or an InputError, never another
// exception, a crash or UB; an accepted problem is solved, and "optimal" means a finite x whose
// KKT residuals are within tolerance.
//
// Built with clang++ -fsanitize=fuzzer,address,undefined by tests/tools/CMakeLists.txt when
// clang++ is found, and run for 30 s by the ctest tools.fuzz_qp_problem_30s (label fuzz).
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "qp/solver.h"
#include "tools/hyq-qp-solve/problem_reader.h"

namespace {

void Check(bool ok) {
  if (!ok) std::abort();  // a property failed: libFuzzer reports it as a crash
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  hyq::qp::Problem p;
  try {
    p = hyq::qp_solve::ParseProblem(std::string_view(reinterpret_cast<const char*>(data), size),
                                    "fuzz");
  } catch (const hyq::qp_solve::InputError&) {
    return 0;
  }
  static hyq::qp::Solver solver;
  hyq::qp::Solution s;
  hyq::qp::Budget budget;
  budget.max_iterations = 200;  // a bound on the time per input
  const hyq::qp::Status st = solver.Solve(p, budget, &s);
  Check(st == s.status);
  if (st == hyq::qp::Status::kOptimal) {
    Check(s.x.size() == p.n() && s.x.allFinite() && std::isfinite(s.objective));
    Check(s.kkt.max() <= solver.settings().kkt_tolerance);
  }
  return 0;
}
