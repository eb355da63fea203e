// One configuration key as a config struct lists it in its Serialize (house style §11, Drake's
// SimulatorConfig): the key's name in the file, the member it fills, its bounds, unit and a
// one-line description. The default is the member's initialiser, written nowhere else.
//
//   struct DeadlineConfig {
//     double budget_fraction = 0.9;
//     template <class A> void Serialize(A* a) {
//       a->Visit(hal::Key("budget_fraction", &budget_fraction).In(0.05, 1.0).Doc("..."));
//     }
//   };
//
// An archive of config/ walks that list: config/yaml_archive.h reads a YAML file (and refuses
// keys the list lacks), config/config_reference.h writes the table of keys in
// docs/configuration.md. Besides Visit(Key), a Serialize may call
//   a->Visit(name, &member)        a member struct with its own Serialize, as a map `name`
//   a->Section(name, fn[, true])   a map `name` whose keys fn(a) lists (members of this struct);
//                                  true: the map is required
//   a->Visit(RetiredKey{...})      a key no longer read, refused with a pointer to its successor
//   a->Include(path, &member)      a member read from another file (the HAL file of the servo's)
//   a->Period(&period_s)           the loop period that Key::MaxTimesRate bounds refer to
// A key whose value decides which other keys the map has (a joint's `actuator`) is marked
// Selects(): it is read before the map's keys are checked, so Serialize may branch on it.
// Modules include this header only: nothing here knows YAML.
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hyq::hal {

/// What a key's own check found wrong: the expectation, and (for a list) the element at fault.
struct Violation {
  std::string expected;
  int index = -1;        // >= 0: the list element the message names ("key[index]")
  std::string part = {};  // appended to the key in the message, e.g. " (group)"
};

/// A word the file may give for a value: an enum's name, or a special integer ('auto').
template <class T>
struct Choice {
  const char* name;
  T value;
};

template <class T>
struct Key {
  Key(const char* key_name, T* member) : name(key_name), value(member) {}

  /// Inclusive bounds; for a list, of each element.
  Key& In(double lo, double hi) {
    min = lo;
    max = hi;
    return *this;
  }
  /// The upper bound is max · rate^power, rate = 1 / the archive's Period() (a gain that must
  /// stay stable at the loop rate: kd · dt <= 0.5 is max 0.5, power 1).
  Key& MaxTimesRate(int power) {
    max_rate_power = power;
    return *this;
  }
  /// A list's elements each with their own upper bound (same length as the list).
  Key& MaxEach(std::vector<double> each) {
    max_each = std::move(each);
    return *this;
  }
  /// The file gives 1 / the member (a rate for a stored period).
  Key& Reciprocal() {
    reciprocal = true;
    return *this;
  }
  /// The member is the file's number times `factor` (degrees in the file, radians stored:
  /// Scale(kRadPerDeg)); for a list, each element. The bounds are the file's.
  Key& Scale(double factor) {
    scale = factor;
    return *this;
  }
  /// The key's value decides which keys follow it (Serialize branches on it): read first.
  Key& Selects() {
    selects = true;
    return *this;
  }
  /// A fixed array of maps given as a map from each element's name, name_of(index), to the
  /// element; every name must be present (joints.<joint name>).
  Key& Named(std::string_view (*name_of)(int)) {
    element_name = name_of;
    return *this;
  }
  Key& Required(bool r = true) {
    required = r;
    return *this;
  }
  /// A file path, relative to the configuration file's folder.
  Key& Path() {
    path = true;
    return *this;
  }
  /// A list that must not be empty.
  Key& NonEmpty() {
    non_empty = true;
    return *this;
  }
  /// A one-number list fills every element ("one number or 4 numbers").
  Key& Broadcast() {
    broadcast = true;
    return *this;
  }
  /// What a list's elements are, as the messages and the docs name them: "(lf, rf, lh, rh)",
  /// "buses"; for a key of names only, what the names are ("a joint name ...").
  Key& Elements(const char* e) {
    elements = e;
    return *this;
  }
  /// Words for values: all an enum may be; for an integer with bounds, accepted besides them.
  Key& Choices(std::vector<Choice<T>> c) {
    choices = std::move(c);
    return *this;
  }
  /// A rule on the value (after the type and the bounds), run on the default too when the key
  /// is absent (it may compare with keys listed before it); nullopt when the value is fine.
  Key& Check(std::function<std::optional<Violation>(const T&)> c) {
    check = std::move(c);
    return *this;
  }
  /// Interface overrides: a map from a list element's name to its interface.
  Key& ByName() {
    by_name = true;
    return *this;
  }
  Key& Unit(const char* u) {
    unit = u;
    return *this;
  }
  Key& Doc(const char* d) {
    doc = d;
    return *this;
  }

  const char* name;
  T* value;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  int max_rate_power = 0;
  std::vector<double> max_each;
  double scale = 1.0;
  std::string_view (*element_name)(int) = nullptr;
  bool reciprocal = false, selects = false, required = false, path = false, non_empty = false, broadcast = false,
       by_name = false;
  const char* elements = "";
  std::vector<Choice<T>> choices;
  std::function<std::optional<Violation>(const T&)> check;
  const char* unit = "";
  const char* doc = "";
};

/// A list in the file whose elements fill separate members (range_deg: [min, max] ->
/// q_min_rad, q_max_rad): Key("range_deg", &list) with list = {&q_min_rad, &q_max_rad}.
template <std::size_t N>
using MemberList = std::array<double*, N>;

/// A key the file may no longer give: refused with what to do instead (a renamed or moved key
/// must not be ignored silently).
struct RetiredKey {
  const char* name;
  const char* expected;  // e.g. "timing.max_held_cycles (renamed: ...)"
  const char* found;     // e.g. "the old name"
};

}  // namespace hyq::hal
