// hyq-qp-solve FILE.json: solve one QP with hyq::qp and print the result as JSON (docs/qp.md).
//
//   problem: {"H": [[..]], "g": [..], "A": [[..]], "lbA": [..], "ubA": [..], "lb": [..], "ub": [..]}
//            H and g required; A, lbA, ubA, lb, ub optional; null is an infinite bound
//   result:  {"status": .., "x": [..], "objective": f, "iterations": k, "kkt": {..}, ..}
//   exit:    0 optimal, 1 another solver status (the result is still printed),
//            2 usage error or malformed file (a message on stderr names the file and the key)
#include <cmath>
#include <cstdio>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "qp/solver.h"
#include "tools/cli/command_line.h"
#include "tools/hyq-qp-solve/problem_reader.h"

namespace {

using nlohmann::json;

constexpr const char* kUsage = R"(usage: hyq-qp-solve FILE.json
       hyq-qp-solve --help

Solves  min ½ xᵀHx + gᵀx  s.t.  lb ≤ x ≤ ub,  lbA ≤ A x ≤ ubA  with the servo's dense QP solver
(hyq::qp, docs/qp.md) and prints the result as JSON on stdout.

FILE.json is one object:
  "H"    n arrays of n numbers, symmetric positive semi-definite   (required, 1 ≤ n ≤ 40)
  "g"    n numbers                                                 (required)
  "A"    m arrays of n numbers                                     (optional, m ≤ 80)
  "lbA", "ubA"  m numbers or null (= -inf / +inf); lbA = ubA is an equality  (optional)
  "lb", "ub"    n numbers or null                                  (optional)

The result: {"status": "optimal" | "infeasible" | "unbounded" | "iteration_limit" | "deadline" |
"bad_input", "x", "objective", "iterations", "outer_iterations", "solve_time_s",
"kkt": {"stationarity", "primal", "dual", "complementarity"}, "y_bounds", "y_constraints"
(multipliers, H x + g + y_bounds + Aᵀ y_constraints = 0; for "infeasible" a Farkas
certificate), "active_bounds", "active_constraints" (-1 lower, 1 upper, 2 equality, 0 inactive),
"direction" (for "unbounded")}.

Every number in H, g, A and the bounds has magnitude at most 1e150 (larger would let H x
overflow); a file is at most 16 MiB, nested at most 64 deep, and a regular file or a pipe.

Exit status: 0 optimal; 1 any other solver status (the result is still printed);
2 usage error or malformed file (the message names the file, the key, what was expected and
what was found).
)";

json Finite(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

template <class Vec>
json Array(const Vec& v, int size) {
  json a = json::array();
  for (int i = 0; i < size; ++i) a.push_back(Finite(v(i)));
  return a;
}

json ToJson(const hyq::qp::Problem& p, const hyq::qp::Solution& s) {
  const int n = p.n(), m = p.m();
  json out;
  out["status"] = hyq::qp::ToString(s.status);
  out["x"] = Array(s.x, static_cast<int>(s.x.size()));
  out["objective"] = Finite(s.objective);
  out["iterations"] = s.iterations;
  out["outer_iterations"] = s.outer_iterations;
  out["solve_time_s"] = s.solve_time_s;
  out["regularisation"] = s.regularisation;
  out["kkt"] = {{"stationarity", s.kkt.stationarity},
                {"primal", s.kkt.primal},
                {"dual", s.kkt.dual},
                {"complementarity", s.kkt.complementarity}};
  out["y_bounds"] = Array(s.y_bounds, static_cast<int>(s.y_bounds.size()));
  out["y_constraints"] = Array(s.y_constraints, static_cast<int>(s.y_constraints.size()));
  json ab = json::array(), ac = json::array();
  for (int i = 0; i < n && s.status != hyq::qp::Status::kBadInput; ++i)
    ab.push_back(static_cast<int>(s.active_bounds[i]));
  for (int k = 0; k < m && s.status != hyq::qp::Status::kBadInput; ++k)
    ac.push_back(static_cast<int>(s.active_constraints[k]));
  out["active_bounds"] = ab;
  out["active_constraints"] = ac;
  if (s.status == hyq::qp::Status::kUnbounded)
    out["direction"] = Array(s.direction, static_cast<int>(s.direction.size()));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> files;
  hyq::cli::CommandLine cl(argc, argv, "hyq-qp-solve", kUsage);
  while (cl.Next()) {
    if (cl.IsOption()) cl.Unknown();
    files.push_back(cl.arg());
  }
  if (files.size() != 1)
    cl.Fail("expected one FILE.json, found " + std::to_string(files.size()) + " argument(s)");
  const std::string& file = files[0];
  hyq::qp::Problem problem;
  try {
    problem = hyq::qp_solve::ReadProblemFile(file);
  } catch (const std::exception& e) {  // InputError, or bad_alloc
    std::fprintf(stderr, "hyq-qp-solve: %s\n", e.what());
    return 2;
  }
  hyq::qp::Solver solver;
  hyq::qp::Solution solution;
  const hyq::qp::Status status = solver.Solve(problem, hyq::qp::Budget{}, &solution);
  std::cout << ToJson(problem, solution).dump(2) << "\n";
  return status == hyq::qp::Status::kOptimal ? 0 : 1;
}
