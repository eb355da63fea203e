// Reads a configuration struct from YAML through its Serialize (house style §11): the keys, their
// defaults and bounds are the struct's list (hal/config_key.h); this archive turns each into a
// lookup whose error names the file, the line, the key (a dotted path), what was expected and
// what was found. Each map's keys are checked against the list before any value is read (but those
// marked Selects(), which decide the rest of the list): a key the list lacks, or one given twice,
// is an error.
#pragma once

#include <yaml-cpp/yaml.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "config/rate_bounds.h"
#include "config/yaml_reader.h"
#include "dynamics/model.h"
#include "hal/config_key.h"
#include "hal/hal_config.h"

namespace hyq::config {

hal::HalConfig LoadHalConfig(const std::filesystem::path& path);  // config/hal_config_loader.h

namespace detail {

/// The names a Serialize lists, for the check of a map's keys.
class KeyNames {
 public:
  template <class T>
  void Visit(const hal::Key<T>& k) { names.push_back(k.name); }
  void Visit(const hal::RetiredKey& k) { retired.push_back(k); }
  template <class S>
  void Visit(const char* name, S*) { names.push_back(name); }
  template <class F>
  void Section(const char* name, F&&, bool = false) { names.push_back(name); }
  template <class S>
  void Include(const std::string&, S*) {}
  void Period(const double*) {}

  std::vector<const char*> names;
  std::vector<hal::RetiredKey> retired;
};

template <class T>
concept Serializable = requires(T t, KeyNames a) { t.Serialize(&a); };

template <class T>
struct IsStdArray : std::false_type {};
template <class T, std::size_t N>
struct IsStdArray<std::array<T, N>> : std::true_type {};

/// What a key of this type is, as "expected ..." says when it is missing.
template <class T>
const char* TypeExpectation() {
  if constexpr (std::is_same_v<T, bool>) return "true or false";
  else if constexpr (std::is_same_v<T, std::string>) return "a string";
  else if constexpr (std::is_enum_v<T>) return "a string";
  else if constexpr (std::is_integral_v<T>) return "an integer";
  else if constexpr (std::is_floating_point_v<T>) return "a number";
  else if constexpr (Serializable<T>) return "a map";
  else return "a list";
}

/// " (0.5/dt)": how a bound scales with the loop rate.
inline std::string RateSuffix(double max, int power) {
  if (power == 0) return "";
  return " (" + FormatNumber(max) + "/dt" + (power == 2 ? "²" : power == 1 ? "" : "^" + std::to_string(power)) + ")";
}

/// "one of 'a' 'b'"
template <class T>
std::string ChoiceList(const std::vector<hal::Choice<T>>& choices) {
  std::string s = "one of";
  for (const auto& c : choices) s.append(" '").append(c.name).append("'");
  return s;
}

/// The value a check found wrong when its key was absent.
template <class T>
std::string DescribeDefault(const T& v) {
  if constexpr (std::is_same_v<T, bool>) return v ? "true (the default)" : "false (the default)";
  else if constexpr (std::is_floating_point_v<T>) return FormatNumber(v) + " (the default)";
  else if constexpr (std::is_integral_v<T>) return std::to_string(static_cast<long long>(v)) + " (the default)";
  else if constexpr (std::is_same_v<T, std::string>) return "'" + v + "' (the default)";
  else return "the default";
}

class YamlArchive {
 public:
  struct Context {
    const Reader* reader;
    std::filesystem::path base_dir;   // relative paths resolve against it
    const double* period_s = nullptr;  // Period(): the bounds that scale with the loop rate
  };

  YamlArchive(Context* context, YAML::Node map, std::string path)
      : ctx_(context), r_(*context->reader), map_(std::move(map)), path_(std::move(path)) {}

  /// Checks the map's keys against the list `f` gives (f(archive) calls Visit and Section),
  /// then reads them.
  template <class F>
  void Read(F&& f) {
    selecting_ = true;  // the keys the list depends on (Key::Selects) first
    f(this);
    selecting_ = false;
    KeyNames names;
    f(&names);
    for (const auto& k : names.retired)
      if (map_[k.name].IsDefined()) r_.Fail(map_[k.name], Reader::Join(path_, k.name), k.expected, k.found);
    r_.Keys(map_, path_, names.names);
    f(this);
  }

  template <class S>
  void Visit(const char* name, S* member) {
    if (selecting_) return;
    Section(name, [member](auto* a) { member->Serialize(a); });
  }

  template <class F>
  void Section(const char* name, F&& f, bool required = false) {
    if (selecting_) return;
    const std::string p = Reader::Join(path_, name);
    const YAML::Node n = map_[name];
    if (!n.IsDefined() && required) r_.Fail(map_, p, "a map", "nothing (the key is missing)");
    if (n.IsDefined() && !n.IsMap()) r_.Fail(n, p, "a map", Describe(n));
    // an absent section: its keys keep their defaults (and their checks still run)
    YamlArchive child(ctx_, n.IsDefined() ? n : YAML::Node(YAML::NodeType::Map), p);
    child.Read(f);
  }

  void Visit(const hal::RetiredKey&) {}  // refused in Read

  template <class S>
  void Include(const std::string& path, S* member) {
    if (selecting_) return;
    static_assert(std::is_same_v<S, hal::HalConfig>, "Include reads HAL files only");
    *member = LoadHalConfig(path);
  }

  void Period(const double* period_s) { ctx_->period_s = period_s; }

  template <class T>
  void Visit(const hal::Key<T>& k) {
    if (selecting_ && !k.selects) return;
    const std::string p = Reader::Join(path_, k.name);
    const YAML::Node n = map_[k.name];
    if (n.IsDefined()) {
      ReadValue(n, p, k);
    } else if (k.required) {
      const bool list = std::string_view(TypeExpectation<T>()) == "a list" && *k.elements;
      r_.Fail(map_, p, list ? std::string("a list of ") + k.elements : TypeExpectation<T>(),
              "nothing (the key is missing)");
    }
    if (k.check) {
      if (const auto v = k.check(*k.value)) {
        // the element at fault, when the check names one (a copy binds; assigning would not)
        const bool element = v->index >= 0 && n.IsDefined() && n.IsSequence();
        const YAML::Node at = element ? n[static_cast<std::size_t>(v->index)] : n;
        const std::string ap = v->index >= 0 ? p + "[" + std::to_string(v->index) + "]" : p;
        r_.Fail(at, ap + v->part, v->expected,
                !at.IsDefined()    ? DescribeDefault(*k.value)
                : at.IsSequence() ? DescribeElements(at)
                                  : Describe(at));
      }
    }
  }

 private:
  double Max(double max, int power) const {
    if (power == 0) return max;
    if (ctx_->period_s == nullptr) throw hal::ConfigError("a rate-scaled bound without a Period()");
    return RateScaledMax(max, power, *ctx_->period_s);
  }

  // a number within the key's bounds
  double Bounded(const YAML::Node& n, const std::string& p, double lo, double hi,
                 const std::string& suffix) const {
    const double x = r_.ToNumber(n, p);
    if (x < lo || x > hi) {
      std::string expected;
      if (std::isinf(lo) && std::isinf(hi)) expected = "a finite number";
      else if (std::isinf(hi)) expected = "a number >= " + FormatNumber(lo);
      else if (std::isinf(lo)) expected = "a number <= " + FormatNumber(hi);
      else expected = "a number in [" + FormatNumber(lo) + ", " + FormatNumber(hi) + "]";
      r_.Fail(n, p, expected + suffix, Describe(n));
    }
    return x;
  }

  // "'25', '-70'": a list's elements, for a check on the list as a whole
  static std::string DescribeElements(const YAML::Node& n) {
    std::string s;
    for (std::size_t i = 0; i < n.size(); ++i) s += (i ? ", " : "") + Describe(n[i]);
    return s;
  }

  // a fixed array of maps given as a map from each element's name (Key::Named)
  template <class T>
  void ReadNamed(const YAML::Node& n, const std::string& p, const hal::Key<T>& k) const {
    if (!n.IsMap()) r_.Fail(n, p, "a map", Describe(n));
    T& v = *k.value;
    auto index = [&](const std::string& name) {
      for (std::size_t i = 0; i < v.size(); ++i)
        if (k.element_name(static_cast<int>(i)) == name) return static_cast<int>(i);
      return -1;
    };
    for (const auto& kv : n) {
      const std::string name = kv.first.as<std::string>();
      if (index(name) < 0) r_.Fail(kv.first, p + "." + name, std::string("a ") + k.elements, "'" + name + "'");
    }
    for (std::size_t i = 0; i < v.size(); ++i) {
      const std::string name(k.element_name(static_cast<int>(i)));
      const std::string ep = p + "." + name;
      const YAML::Node e = n[name];
      if (!e.IsDefined())
        r_.Fail(n, ep, std::string("an entry for every ") + k.elements, "nothing (the key is missing)");
      if (!e.IsMap()) r_.Fail(e, ep, "a map", Describe(e));
      typename T::value_type element;
      YamlArchive child(ctx_, e, ep);
      child.Read([&element](auto* a) { element.Serialize(a); });
      v[i] = element;
    }
  }

  std::string NonEmptyString(const YAML::Node& n, const std::string& p) const {
    if (!n.IsScalar() || n.Scalar().empty()) r_.Fail(n, p, "a non-empty string", Describe(n));
    return n.Scalar();
  }

  // the servo file's bus interfaces: a map from a bus name to its interface, replacing the HAL
  // file's
  template <class S>
  void ReadByName(const YAML::Node& n, const std::string& p, std::vector<S>& v) const {
    if (!n.IsMap()) r_.Fail(n, p, "a map from a name to an interface", Describe(n));
    for (const auto& kv : n) {
      const std::string name = kv.first.as<std::string>();
      bool found = false;
      for (auto& e : v)
        if (e.name == name) {
          e.interface = NonEmptyString(kv.second, p + "." + name);
          found = true;
        }
      if (!found) {
        std::string names;
        for (const auto& e : v) names += (names.empty() ? "" : ", ") + e.name;
        r_.Fail(kv.first, p + "." + name, "a bus of the HAL file (" + names + ")", "'" + name + "'");
      }
    }
  }

  template <class T>
  void ReadValue(const YAML::Node& n, const std::string& p, const hal::Key<T>& k) {
    T& v = *k.value;
    if constexpr (std::is_same_v<T, bool>) {
      bool b = false;
      if (!n.IsScalar() || !YAML::convert<bool>::decode(n, b)) r_.Fail(n, p, "true or false", Describe(n));
      v = b;
    } else if constexpr (std::is_enum_v<T>) {
      const std::string s = NonEmptyString(n, p);
      for (const auto& c : k.choices)
        if (s == c.name) {
          v = c.value;
          return;
        }
      r_.Fail(n, p, ChoiceList(k.choices), "'" + s + "'");
    } else if constexpr (std::is_integral_v<T>) {
      for (const auto& c : k.choices)
        if (n.IsScalar() && n.Scalar() == c.name) {
          v = c.value;
          return;
        }
      if (!k.choices.empty() && std::isinf(k.min))  // names only
        r_.Fail(n, p, *k.elements ? std::string(k.elements) : ChoiceList(k.choices), Describe(n));
      const auto lo = std::isinf(k.min) ? static_cast<long long>(std::numeric_limits<T>::min())
                                        : static_cast<long long>(k.min);
      const auto hi = std::isinf(k.max) ? static_cast<long long>(std::numeric_limits<T>::max())
                                        : static_cast<long long>(k.max);
      std::string expected = "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
      for (const auto& c : k.choices) expected.append(" or '").append(c.name).append("'");
      long long x = 0;
      if (!n.IsScalar() || !YAML::convert<long long>::decode(n, x) || x < lo || x > hi)
        r_.Fail(n, p, expected, Describe(n));
      v = static_cast<T>(x);
    } else if constexpr (std::is_floating_point_v<T>) {
      const double x = Bounded(n, p, k.min, Max(k.max, k.max_rate_power),
                               RateSuffix(k.max, k.max_rate_power));
      v = k.reciprocal ? 1.0 / x : k.scale * x;
    } else if constexpr (std::is_same_v<T, std::string>) {
      const std::string s = NonEmptyString(n, p);
      if (!k.path) {
        v = s;
      } else {
        const std::filesystem::path fp(s);
        v = (fp.is_absolute() ? fp : ctx_->base_dir / fp).lexically_normal().string();
      }
    } else if constexpr (std::is_same_v<T, std::optional<std::chrono::nanoseconds>>) {
      const double us = Bounded(n, p, k.min, k.max, "");
      v = std::chrono::nanoseconds(static_cast<std::int64_t>(1000.0 * us));
    } else if constexpr (std::is_same_v<T, dynamics::VectorJ>) {
      // one value per joint: one number (all joints), three (haa, hfe, kfe of every leg) or 12
      const double hi = Max(k.max, k.max_rate_power);
      const std::string range = "a value in [" + FormatNumber(k.min) + ", " + FormatNumber(hi) +
                                "] " + k.unit + RateSuffix(k.max, k.max_rate_power);
      auto element = [&](const YAML::Node& e, const std::string& ep) {
        const double x = r_.ToNumber(e, ep);
        if (x < k.min || x > hi) r_.Fail(e, ep, range, Describe(e));
        return x;
      };
      if (n.IsScalar()) {
        v.setConstant(element(n, p));
      } else if (n.IsSequence() && (n.size() == 3 || n.size() == 12)) {
        const std::size_t m = n.size();
        for (int j = 0; j < v.size(); ++j) {
          const std::size_t i = static_cast<std::size_t>(j) % m;
          v(j) = element(n[i], p + "[" + std::to_string(i) + "]");
        }
      } else {
        r_.Fail(n, p,
                "one number, 3 numbers (haa, hfe, kfe of every leg) or 12 numbers (lf, rf, lh, rh x "
                "haa, hfe, kfe)",
                Describe(n));
      }
    } else if constexpr (IsStdArray<T>::value) {
      using E = typename T::value_type;
      if constexpr (Serializable<E>) {
        ReadNamed(n, p, k);
      } else {
        // an element: the array's own, or the member a MemberList points to
        auto slot = [&v](std::size_t i) -> double& {
          if constexpr (std::is_pointer_v<E>) return *v[i];
          else return v[i];
        };
        const std::size_t size = v.size();
        const std::string count = std::to_string(size) + " numbers" +
                                  (*k.elements ? std::string(" ") + k.elements : std::string());
        auto element = [&](const YAML::Node& e, const std::string& ep, std::size_t i) {
          const double hi = k.max_each.empty() ? k.max : k.max_each[i];
          const double x = Bounded(e, ep, k.min, hi, "");
          return k.scale * x;
        };
        if (k.broadcast && n.IsScalar()) {
          const double x = element(n, p, 0);
          for (std::size_t i = 0; i < size; ++i) slot(i) = x;
        } else if (n.IsSequence() && n.size() == size) {
          for (std::size_t i = 0; i < size; ++i)
            slot(i) = element(n[i], p + "[" + std::to_string(i) + "]", i);
        } else {
          r_.Fail(n, p,
                  k.broadcast ? "one number or " + count
                              : count + (*k.unit ? std::string(" in ") + k.unit : std::string()),
                  Describe(n));
        }
      }
    } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
      if (!n.IsSequence()) r_.Fail(n, p, "a list of strings", Describe(n));
      v.clear();
      for (std::size_t i = 0; i < n.size(); ++i)
        v.push_back(NonEmptyString(n[i], p + "[" + std::to_string(i) + "]"));
    } else if constexpr (Serializable<typename T::value_type>) {
      using S = typename T::value_type;
      if constexpr (requires(S e) { e.interface; }) {
        if (k.by_name) {
          ReadByName(n, p, v);
          return;
        }
      }
      const std::string list = std::string(k.non_empty ? "a non-empty list of " : "a list of ") +
                               (*k.elements ? k.elements : "maps");
      if (!n.IsSequence() || (k.non_empty && n.size() == 0)) r_.Fail(n, p, list, Describe(n));
      v.clear();
      for (std::size_t i = 0; i < n.size(); ++i) {
        const std::string ep = p + "[" + std::to_string(i) + "]";
        if (!n[i].IsMap()) r_.Fail(n[i], ep, "a map", Describe(n[i]));
        S element;
        YamlArchive child(ctx_, n[i], ep);
        child.Read([&element](auto* a) { element.Serialize(a); });
        v.push_back(std::move(element));
      }
    } else {
      static_assert(sizeof(T) == 0, "a key type the YAML archive cannot read");
    }
  }

  Context* ctx_;
  const Reader& r_;
  const YAML::Node map_;
  std::string path_;
  bool selecting_ = false;  // Read's first pass: only the keys marked Selects()
};

}  // namespace detail

/// Fills `out` (its defaults in place) from the YAML map `root` through out->Serialize.
/// Throws hal::ConfigError naming `r`'s source, the line, the key, the expectation and the find.
template <class T>
void ReadYaml(const detail::Reader& r, const YAML::Node& root, const std::filesystem::path& base_dir,
              T* out) {
  if (!root.IsMap()) r.Fail(root, "(top level)", "a map", detail::Describe(root));
  detail::YamlArchive::Context context{&r, base_dir};
  detail::YamlArchive archive(&context, root, "");
  archive.Read([out](auto* a) { out->Serialize(a); });
}

/// The same from text; `source_name` stands for the file in messages.
template <class T>
T ParseConfigYaml(std::string_view yaml_text, std::string_view source_name,
            const std::filesystem::path& base_dir = {}) {
  const detail::Reader r{std::string(source_name)};
  const YAML::Node root = detail::ParseYaml(r, std::string(yaml_text));
  T out;
  try {
    ReadYaml(r, root, base_dir, &out);
  } catch (const YAML::Exception& e) {
    throw hal::ConfigError(r.source() + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  return out;
}

}  // namespace hyq::config
