// The reference table of a configuration file's keys, written from the structs' Serialize (house
// style §11): the key, its type and bounds, its default (the member's initialiser), its unit and
// its description. docs/configuration.md holds ConfigReference()'s output between two markers;
// tools/hyq-config-reference rewrites it, and tests/servo/config_archive_test.cc fails when the
// two differ.
#pragma once

#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "config/yaml_reader.h"
#include "dynamics/model.h"
#include "hal/config_key.h"
#include "hal/hal_config.h"

namespace hyq::config {

namespace detail {

struct KeyRow {
  std::string key, type, default_value, unit, doc;
};

/// Lists each key of a Serialize as a table row (descending into sections and member structs).
class MarkdownArchive {
 public:
  MarkdownArchive(std::string prefix, std::vector<KeyRow>* rows)
      : prefix_(std::move(prefix)), rows_(rows) {}

  template <class S>
  void Visit(const char* name, S* member) {
    MarkdownArchive child(Join(name), rows_);
    member->Serialize(&child);
  }
  template <class F>
  void Section(const char* name, F&& f, bool = false) {
    MarkdownArchive child(Join(name), rows_);
    f(&child);
  }
  void Visit(const hal::RetiredKey&) {}
  template <class S>
  void Include(const std::string&, S*) {}
  void Period(const double*) {}

  template <class T>
  void Visit(const hal::Key<T>& k) {
    KeyRow row{Join(k.name), TypeText(k), k.required ? "required" : DefaultText(k), k.unit, k.doc};
    rows_->push_back(row);
    if constexpr (IsVectorOfStructs<T>()) {
      if (!k.by_name) {
        typename T::value_type element;
        MarkdownArchive child(Join(k.name) + "[]", rows_);
        element.Serialize(&child);
      }
    }
    if constexpr (IsNamedArray<T>()) {
      // every element's keys, each once: elements of different kinds list different keys
      std::vector<KeyRow> element_rows;
      for (auto element : *k.value) {
        MarkdownArchive child(Join(k.name) + ".<name>", &element_rows);
        element.Serialize(&child);
      }
      for (const KeyRow& r : element_rows) {
        bool listed = false;
        for (const KeyRow& l : *rows_) listed = listed || l.key == r.key;
        if (!listed) rows_->push_back(r);
      }
    }
  }

 private:
  template <class T>
  static constexpr bool IsVectorOfStructs() {
    if constexpr (requires { typename T::value_type; typename T::allocator_type; })
      return std::is_class_v<typename T::value_type> &&
             !std::is_same_v<typename T::value_type, std::string>;
    else
      return false;
  }

  template <class T>
  static constexpr bool IsNamedArray() {
    if constexpr (requires { std::tuple_size<T>::value; typename T::value_type; })
      return std::is_class_v<typename T::value_type>;
    else
      return false;
  }

  std::string Join(const char* name) const { return prefix_.empty() ? name : prefix_ + "." + name; }

  static std::string Range(double lo, double hi, int rate_power = 0, bool integer = false) {
    auto number = [integer](double x) {
      return integer ? std::to_string(static_cast<long long>(x)) : FormatNumber(x);
    };
    const std::string h = number(hi) + (rate_power == 0   ? ""
                                        : rate_power == 1 ? "/dt"
                                        : rate_power == 2 ? "/dt²"
                                                          : "/dt^" + std::to_string(rate_power));
    if (std::isinf(lo) && std::isinf(hi)) return "";
    if (std::isinf(hi)) return " ≥ " + number(lo);
    if (std::isinf(lo)) return " ≤ " + h;
    return " in [" + number(lo) + ", " + h + "]";
  }

  template <class T>
  static std::string ChoiceNames(const std::vector<hal::Choice<T>>& choices) {
    std::string s;
    if (choices.size() > 6)
      return std::string(choices.front().name) + " … " + choices.back().name;
    for (const auto& c : choices) s += (s.empty() ? "" : ", ") + std::string(c.name);
    return s;
  }

  template <class T>
  static std::string TypeText(const hal::Key<T>& k) {
    if constexpr (std::is_same_v<T, bool>) {
      return "true or false";
    } else if constexpr (std::is_enum_v<T>) {
      return ChoiceNames(k.choices);
    } else if constexpr (std::is_integral_v<T>) {
      if (!k.choices.empty() && std::isinf(k.min)) return *k.elements ? k.elements : ChoiceNames(k.choices);
      std::string s = "integer" + Range(k.min, k.max, 0, true);
      for (const auto& c : k.choices) s.append(" or ").append(c.name);
      return s;
    } else if constexpr (std::is_floating_point_v<T>) {
      return "number" + Range(k.min, k.max, k.max_rate_power);
    } else if constexpr (std::is_same_v<T, std::string>) {
      return k.path ? "path (relative to the file)" : "string";
    } else if constexpr (std::is_same_v<T, std::optional<std::chrono::nanoseconds>>) {
      return "number" + Range(k.min, k.max);
    } else if constexpr (std::is_same_v<T, dynamics::VectorJ>) {
      return "1, 3 or 12 numbers" + Range(k.min, k.max, k.max_rate_power);
    } else if constexpr (IsNamedArray<T>()) {
      return std::string("map: ") + k.elements + " → its keys (below)";
    } else if constexpr (requires { std::tuple_size<T>::value; }) {
      const std::string n = std::to_string(std::tuple_size<T>::value);
      std::string s = (k.broadcast ? "1 or " + n : n) + " numbers" +
                      (*k.elements ? std::string(" ") + k.elements : std::string());
      if (k.max_each.empty()) return s + Range(k.min, k.max);
      s += " in ";
      for (std::size_t i = 0; i < k.max_each.size(); ++i)
        s += (i ? ", " : "") + std::string("[") + FormatNumber(k.min) + ", " + FormatNumber(k.max_each[i]) + "]";
      return s;
    } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
      return "list of strings";
    } else {
      return k.by_name ? "map: bus name → interface" : "list of maps (keys below)";
    }
  }

  template <class T>
  static std::string DefaultText(const hal::Key<T>& k) {
    const T& v = *k.value;
    if constexpr (std::is_same_v<T, bool>) {
      return v ? "true" : "false";
    } else if constexpr (std::is_enum_v<T> || std::is_integral_v<T>) {
      for (const auto& c : k.choices)
        if (c.value == v) return c.name;
      if constexpr (std::is_enum_v<T>) return "";
      else return std::to_string(static_cast<long long>(v));
    } else if constexpr (std::is_floating_point_v<T>) {
      return FormatNumber(k.reciprocal ? 1.0 / v : v / k.scale);
    } else if constexpr (std::is_same_v<T, std::string>) {
      return v.empty() ? "" : "`" + v + "`";
    } else if constexpr (std::is_same_v<T, std::optional<std::chrono::nanoseconds>>) {
      return v ? FormatNumber(1e-3 * static_cast<double>(v->count())) : "none";
    } else if constexpr (std::is_same_v<T, dynamics::VectorJ>) {
      if (v.maxCoeff() == v.minCoeff()) return FormatNumber(v(0));
      std::string s;
      for (int j = 0; j < v.size(); ++j) s += (j ? ", " : "[") + FormatNumber(v(j));
      return s + "]";
    } else if constexpr (IsNamedArray<T>()) {
      return "";
    } else if constexpr (requires { std::tuple_size<T>::value; }) {
      std::vector<double> x;  // in the file's unit
      for (const auto& e : v) {
        if constexpr (std::is_pointer_v<typename T::value_type>) x.push_back(*e / k.scale);
        else x.push_back(e / k.scale);
      }
      bool same = true;
      for (const double e : x) same = same && e == x[0];
      if (same && k.broadcast) return FormatNumber(x[0]);
      std::string s;
      for (std::size_t i = 0; i < x.size(); ++i) s += (i ? ", " : "[") + FormatNumber(x[i]);
      return s + "]";
    } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
      std::string s;
      for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "[") + v[i];
      return v.empty() ? "[]" : s + "]";
    } else {
      return "";
    }
  }

  std::string prefix_;
  std::vector<KeyRow>* rows_;
};

std::string MarkdownTable(const std::vector<KeyRow>& rows);

}  // namespace detail

/// The markdown table of T's keys, with T's defaults (or those of `defaults`).
template <class T>
std::string KeyTable(T defaults = T{}) {
  std::vector<detail::KeyRow> rows;
  detail::MarkdownArchive archive("", &rows);
  defaults.Serialize(&archive);
  return detail::MarkdownTable(rows);
}

/// Every key of `config` with its present value as the reference table writes it ("key" →
/// "value"), e.g. to compare two loaded files key by key.
template <class T>
std::vector<std::pair<std::string, std::string>> KeyValues(T config) {
  std::vector<detail::KeyRow> rows;
  detail::MarkdownArchive archive("", &rows);
  config.Serialize(&archive);
  std::vector<std::pair<std::string, std::string>> out;
  out.reserve(rows.size());
  for (auto& r : rows) out.emplace_back(std::move(r.key), std::move(r.default_value));
  return out;
}

/// The servo file's table and the HAL file's, with their headings: the generated part of
/// docs/configuration.md.
std::string ConfigReference();

/// The markers around the generated part of docs/configuration.md.
inline constexpr const char* kReferenceBegin =
    "<!-- BEGIN generated by hyq-config-reference from the structs' Serialize; do not edit -->";
inline constexpr const char* kReferenceEnd = "<!-- END generated -->";

}  // namespace hyq::config
