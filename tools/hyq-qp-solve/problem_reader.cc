#include "tools/hyq-qp-solve/problem_reader.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <nlohmann/json.hpp>

#include "qp/json_nesting.h"

namespace hyq::qp_solve {
namespace {

using nlohmann::json;
using qp::kInf;

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

  // a number of magnitude at most kMaxMagnitude (or null, standing for null_value)
  double Number(const json& v, const std::string& key, bool null_is = false,
                double null_value = 0.0) const {
    if (null_is && v.is_null()) return null_value;
    if (!v.is_number()) Fail(key, null_is ? "a number or null" : "a number", v);
    const double x = v.get<double>();
    if (!(std::fabs(x) <= kMaxMagnitude))
      Fail(key, null_is ? "a number of magnitude at most 1e150, or null for an infinite bound"
                        : "a number of magnitude at most 1e150",
           v);
    return x;
  }

  // an array of `size` numbers
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

qp::Problem FromJson(const json& root, const std::string& file) {
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
  if (n < 1 || n > qp::kMaxVariables)
    r.Fail("H", "an array of 1 to " + std::to_string(qp::kMaxVariables) +
                    " rows (arrays of numbers)", H);
  int m = 0;
  if (root.contains("A")) {
    const json& A = root["A"];
    m = A.is_array() ? static_cast<int>(A.size()) : -1;
    if (m < 0 || m > qp::kMaxConstraints)
      r.Fail("A", "an array of 0 to " + std::to_string(qp::kMaxConstraints) +
                      " rows (arrays of " + std::to_string(n) + " numbers)", A);
  } else if (root.contains("lbA") || root.contains("ubA")) {
    throw InputError(file + ": key \"lbA\"/\"ubA\" given without \"A\"");
  }
  qp::Problem p;
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

}  // namespace

qp::Problem ParseProblem(std::string_view text, const std::string& name) {
  if (text.size() > kMaxFileBytes)
    throw InputError(name + ": expected at most " + std::to_string(kMaxFileBytes >> 20) +
                     " MiB, found " + std::to_string(text.size()) + " bytes");
  if (qp::JsonNestingDepth(text, kMaxDepth) > kMaxDepth)
    throw InputError(name + ": expected arrays and objects nested at most " +
                     std::to_string(kMaxDepth) + " deep, found more");
  json root;
  try {
    root = json::parse(text);
  } catch (const json::out_of_range& e) {
    // 1e999 is valid JSON, but no double holds it
    throw InputError(name + ": expected numbers within the range of a double, found: " +
                     e.what());
  } catch (const json::exception& e) {
    throw InputError(name + ": not valid JSON: " + e.what());
  }
  try {
    return FromJson(root, name);
  } catch (const json::exception& e) {
    throw InputError(name + ": unexpected JSON content: " + e.what());
  }
}

qp::Problem ReadProblemFile(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_type type = fs::status(path, ec).type();
  if (type == fs::file_type::not_found) throw InputError(path + ": cannot open the file");
  // a directory opens as an empty stream and /dev/zero never ends
  if (type != fs::file_type::regular && type != fs::file_type::fifo)
    throw InputError(path + ": expected a regular file, found " +
                     (type == fs::file_type::directory   ? "a directory"
                      : type == fs::file_type::character ? "a character device"
                                                         : "another kind of file"));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the file");
  std::string text;
  char buf[65536];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    text.append(buf, static_cast<std::size_t>(in.gcount()));
    if (text.size() > kMaxFileBytes)
      throw InputError(path + ": expected at most " + std::to_string(kMaxFileBytes >> 20) +
                       " MiB, found more");
  }
  if (in.bad()) throw InputError(path + ": read error");
  return ParseProblem(text, path);
}

}  // namespace hyq::qp_solve
