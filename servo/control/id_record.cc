#include "servo/control/id_record.h"

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "qp/json_nesting.h"

namespace hyq::servo {
namespace {

using nlohmann::json;

[[noreturn]] void Fail(const std::string& key, const std::string& expected, const json& found) {
  std::string f = found.dump();
  if (f.size() > 60) f = f.substr(0, 57) + "...";
  throw IdRecordError("\"" + key + "\": expected " + expected + ", found " + f);
}

const json& Require(const json& j, const std::string& key) {
  const auto it = j.find(key);
  if (it == j.end()) throw IdRecordError("\"" + key + "\": missing (required)");
  return *it;
}

double Number(const json& v, const std::string& key) {
  if (!v.is_number()) Fail(key, "a number", v);
  const double x = v.get<double>();
  if (!std::isfinite(x)) Fail(key, "a finite number", v);
  return x;
}

template <class Vec>
void Array(const json& j, const std::string& key, Vec* out) {
  const json& v = Require(j, key);
  const int n = static_cast<int>(out->size());
  if (!v.is_array() || static_cast<int>(v.size()) != n)
    Fail(key, "an array of " + std::to_string(n) + " numbers", v);
  for (int i = 0; i < n; ++i) (*out)(i) = Number(v[i], key + "[" + std::to_string(i) + "]");
}

json Vector(const auto& v) {
  json a = json::array();
  for (int i = 0; i < v.size(); ++i) a.push_back(v(i));
  return a;
}

IdRecord FromJson(const json& j) {
  if (!j.is_object()) Fail("(line)", "a JSON object", j);
  IdRecord r;
  IdInput& in = r.input;
  Array(j, "q", &in.q);
  Array(j, "v", &in.v);
  Array(j, "qdd_des", &in.qdd_des);
  const double qn = in.q.segment<4>(3).norm();
  if (std::abs(qn - 1.0) > 1e-6)
    throw IdRecordError("\"q\": expected a unit quaternion in q[3..6] (w, x, y, z), found norm " +
                        std::to_string(qn));
  const json& stance = Require(j, "stance");
  if (!stance.is_array() || stance.size() != 4) Fail("stance", "an array of 4 booleans", stance);
  for (int f = 0; f < 4; ++f) {
    if (!stance[f].is_boolean()) Fail("stance[" + std::to_string(f) + "]", "a boolean", stance[f]);
    in.stance[f] = stance[f].get<bool>();
  }
  const json& mu = Require(j, "mu");
  if (!mu.is_array() || mu.size() != 4) Fail("mu", "an array of 4 numbers", mu);
  for (int f = 0; f < 4; ++f) {
    in.mu[f] = Number(mu[f], "mu[" + std::to_string(f) + "]");
    if (in.mu[f] < 0.0) Fail("mu[" + std::to_string(f) + "]", "a friction coefficient ≥ 0", mu[f]);
  }
  if (const auto it = j.find("normal"); it != j.end()) {
    if (!it->is_array() || it->size() != 4) Fail("normal", "an array of 4 three-vectors", *it);
    for (int f = 0; f < 4; ++f) {
      const std::string key = "normal[" + std::to_string(f) + "]";
      const json& n = (*it)[f];
      if (!n.is_array() || n.size() != 3) Fail(key, "an array of 3 numbers", n);
      for (int k = 0; k < 3; ++k) in.normal_W[f](k) = Number(n[k], key);
      if (in.normal_W[f].norm() < 1e-9) Fail(key, "a non-zero vector", n);
    }
  }
  in.dt = Number(Require(j, "h"), "h");
  if (!(in.dt > 0.0) || in.dt > 1.0) Fail("h", "a time step in (0, 1] s", j["h"]);
  const json& c = Require(j, "controller");
  if (!c.is_string()) Fail("controller", "\"two_stage\", \"stage1\" or \"noslip\"", c);
  const auto kind = ParseControllerKind(c.get<std::string>());
  if (!kind || *kind == ControllerKind::kPid || *kind == ControllerKind::kPdGravity)
    Fail("controller", "\"two_stage\", \"stage1\" or \"noslip\"", c);
  r.controller = *kind;
  return r;
}

}  // namespace

IdRecord ParseIdRecord(std::string_view line) {
  if (line.size() > kMaxIdRecordBytes)
    throw IdRecordError("expected a line of at most " + std::to_string(kMaxIdRecordBytes) +
                        " bytes, found " + std::to_string(line.size()));
  if (qp::JsonNestingDepth(line, kMaxIdRecordDepth) > kMaxIdRecordDepth)
    throw IdRecordError("expected arrays and objects nested at most " +
                        std::to_string(kMaxIdRecordDepth) + " deep, found more");
  json j;
  try {
    j = json::parse(line);
  } catch (const json::out_of_range& e) {
    // 1e999 is valid JSON, but no double holds it
    throw IdRecordError(std::string("expected numbers within the range of a double, found: ") +
                        e.what());
  } catch (const json::exception& e) {
    throw IdRecordError(std::string("not valid JSON: ") + e.what());
  }
  try {
    return FromJson(j);
  } catch (const json::exception& e) {
    throw IdRecordError(std::string("unexpected JSON content: ") + e.what());
  }
}

std::string FormatIdRecord(const IdRecord& record, const IdOutput* result) {
  const IdInput& in = record.input;
  json j;
  j["q"] = Vector(in.q);
  j["v"] = Vector(in.v);
  j["qdd_des"] = Vector(in.qdd_des);
  j["stance"] = json::array();
  j["mu"] = json::array();
  j["normal"] = json::array();
  for (int f = 0; f < 4; ++f) {
    j["stance"].push_back(in.stance[f]);
    j["mu"].push_back(in.mu[f]);
    j["normal"].push_back(Vector(in.normal_W[f]));
  }
  j["h"] = in.dt;
  j["controller"] = ToString(record.controller);
  if (result != nullptr) {
    json r;
    r["tau"] = Vector(result->tau_Nm);
    r["impulses"] = json::array();
    for (int f = 0; f < 4; ++f) {
      const ContactImpulse& c = result->impulses[f];
      if (!c.active) continue;
      r["impulses"].push_back({{"foot", dynamics::kLegNames[f]},
                               {"normal", c.normal_Ns},
                               {"tangent", Vector(c.tangent_Ns_W)}});
    }
    auto stage = [](const StageReport& s) {
      json o;
      o["status"] = s.ran ? qp::ToString(s.status) : "not_run";
      o["objective"] = s.objective;
      o["iterations"] = s.iterations;
      o["solve_time_s"] = s.solve_time_s;
      return o;
    };
    r["stage1"] = stage(result->stage1);
    r["stage2"] = stage(result->stage2);
    r["kinetic_energy"] = result->kinetic_energy_J;
    r["fallback"] = ToString(result->fallback);
    j["result"] = std::move(r);
  }
  return j.dump();
}

}  // namespace hyq::servo
