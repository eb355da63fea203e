// hyq-qp-solve FILE.json: solve one QP with hyq::qp and print the result as JSON (docs/qp.md).
//
//   problem: {"H": [[..]], "g": [..], "A": [[..]], "lbA": [..], "ubA": [..], "lb": [..], "ub": [..]}
//            H and g required; A, lbA, ubA, lb, ub optional; null is an infinite bound
//   result:  {"status": .., "x": [..], "objective": f, "iterations": k, "kkt": {..}, ..}
//   exit:    0 optimal, 1 another solver status (the result is still printed),
//            2 usage error or malformed file (a message on stderr names the file and the key)
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "qp/solver.h"

namespace {

using hyq::qp::kInf;
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

Exit status: 0 optimal; 1 any other solver status (the result is still printed);
2 usage error or malformed file (the message names the file, the key, what was expected and
what was found).
)";

// Thrown for a malformed file; main() prints "hyq-qp-solve: <what>" and exits with 2.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

std::string Found(const json& v) {
  std::string s = v.dump();
  if (s.size() > 40) s = s.substr(0, 37) + "...";
  return std::string(v.type_name()) + " " + s;
}

class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void Fail(const std::string& key, const std::string& expected,
                         const json& found) const {
    throw InputError(file_ + ": key \"" + key + "\": expected " + expected + ", found " +
                     Found(found));
  }

  double Number(const json& v, const std::string& key, bool null_is = false,
                double null_value = 0.0) const {
    if (null_is && v.is_null()) return null_value;
    if (!v.is_number())
      Fail(key, null_is ? "a number or null" : "a number", v);
    return v.get<double>();
  }

  // an array of `size` numbers (size < 0: any size up to max_size)
  template <class Vec>
  void Vector(const json& v, const std::string& key, int size, Vec* out, bool null_is = false,
              double null_value = 0.0) const {
    const std::string what = "an array of " + std::to_string(size) +
                             (null_is ? " numbers or nulls" : " numbers");
    if (!v.is_array() || static_cast<int>(v.size()) != size) Fail(key, what, v);
    out->resize(size);
    for (int i = 0; i < size; ++i)
      (*out)(i) = Number(v[i], key + "[" + std::to_string(i) + "]", null_is, null_value);
  }

 private:
  std::string file_;
};

json Finite(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

template <class Vec>
json Array(const Vec& v, int size) {
  json a = json::array();
  for (int i = 0; i < size; ++i) a.push_back(Finite(v(i)));
  return a;
}

hyq::qp::Problem ReadProblem(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw InputError(file + ": cannot open the file");
  json root;
  try {
    root = json::parse(in);
  } catch (const json::parse_error& e) {
    throw InputError(file + ": not valid JSON: " + e.what());
  }
  const Reader r(file);
  if (!root.is_object())
    throw InputError(file + ": expected a JSON object at the top level, found " + Found(root));
  for (const auto& [key, value] : root.items()) {
    static const char* kKeys[] = {"H", "g", "A", "lbA", "ubA", "lb", "ub"};
    bool known = false;
    for (const char* k : kKeys) known = known || key == k;
    if (!known)
      throw InputError(file + ": unknown key \"" + key +
                       "\": expected one of H, g, A, lbA, ubA, lb, ub");
  }
  if (!root.contains("H")) throw InputError(file + ": key \"H\" is missing (required)");
  if (!root.contains("g")) throw InputError(file + ": key \"g\" is missing (required)");
  const json& H = root["H"];
  const int n = H.is_array() ? static_cast<int>(H.size()) : -1;
  if (n < 1 || n > hyq::qp::kMaxVariables)
    r.Fail("H", "an array of 1 to " + std::to_string(hyq::qp::kMaxVariables) +
                    " rows (arrays of numbers)", H);
  int m = 0;
  if (root.contains("A")) {
    const json& A = root["A"];
    m = A.is_array() ? static_cast<int>(A.size()) : -1;
    if (m < 0 || m > hyq::qp::kMaxConstraints)
      r.Fail("A", "an array of 0 to " + std::to_string(hyq::qp::kMaxConstraints) +
                      " rows (arrays of " + std::to_string(n) + " numbers)", A);
  } else if (root.contains("lbA") || root.contains("ubA")) {
    throw InputError(file + ": key \"lbA\"/\"ubA\" given without \"A\"");
  }
  hyq::qp::Problem p;
  p.Resize(n, m);
  for (int i = 0; i < n; ++i) {
    const std::string key = "H[" + std::to_string(i) + "]";
    if (!H[i].is_array() || static_cast<int>(H[i].size()) != n)
      r.Fail(key, "an array of " + std::to_string(n) + " numbers (H is n × n)", H[i]);
    for (int j = 0; j < n; ++j)
      p.H(i, j) = r.Number(H[i][j], key + "[" + std::to_string(j) + "]");
  }
  r.Vector(root["g"], "g", n, &p.g);
  if (root.contains("lb")) r.Vector(root["lb"], "lb", n, &p.lb, true, -kInf);
  if (root.contains("ub")) r.Vector(root["ub"], "ub", n, &p.ub, true, kInf);
  for (int k = 0; k < m; ++k) {
    const json& row = root["A"][k];
    const std::string key = "A[" + std::to_string(k) + "]";
    if (!row.is_array() || static_cast<int>(row.size()) != n)
      r.Fail(key, "an array of " + std::to_string(n) + " numbers (A has n columns)", row);
    for (int j = 0; j < n; ++j)
      p.A(k, j) = r.Number(row[j], key + "[" + std::to_string(j) + "]");
  }
  if (root.contains("lbA")) r.Vector(root["lbA"], "lbA", m, &p.lbA, true, -kInf);
  if (root.contains("ubA")) r.Vector(root["ubA"], "ubA", m, &p.ubA, true, kInf);
  return p;
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
  if (argc == 2 && (std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0)) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  if (argc != 2 || argv[1][0] == '-') {
    std::fputs(kUsage, stderr);
    return 2;
  }
  const std::string file = argv[1];
  hyq::qp::Problem problem;
  try {
    problem = ReadProblem(file);
  } catch (const InputError& e) {
    std::fprintf(stderr, "hyq-qp-solve: %s\n", e.what());
    return 2;
  }
  hyq::qp::Solver solver;
  hyq::qp::Solution solution;
  const hyq::qp::Status status = solver.Solve(problem, hyq::qp::Budget{}, &solution);
  std::cout << ToJson(problem, solution).dump(2) << "\n";
  return status == hyq::qp::Status::kOptimal ? 0 : 1;
}
