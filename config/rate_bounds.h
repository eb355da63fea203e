// The keys whose upper bound scales with the loop rate (Key::MaxTimesRate: a gain that must stay
// stable at the loop rate, kd_acc · dt <= 0.5), checked on a struct already filled: the YAML
// archive checks them as it reads, config::ValidateServoConfig again after the command-line
// overrides, both with the bounds the keys' Serialize gives.
#pragma once

#include <cmath>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>

#include "config/yaml_reader.h"
#include "dynamics/model.h"
#include "hal/config_key.h"

namespace hyq::config::detail {

/// A rate-scaled key's upper bound, max · (1 / period)^power.
inline double RateScaledMax(double max, int power, double period_s) {
  return power == 0 ? max : max * std::pow(1.0 / period_s, power);
}

/// A rate-scaled key over its bound: the dotted key, the expectation and the value found.
struct RateBoundExcess {
  std::string key, expected, found;
};

/// Walks a Serialize (its sections and member structs; the period from its Period()) and keeps
/// the first rate-scaled key whose value (a number, or a per-joint vector's largest) exceeds
/// its bound.
class RateBoundArchive {
 public:
  RateBoundArchive(std::string prefix, const double** period_s,
                   std::optional<RateBoundExcess>* excess)
      : prefix_(std::move(prefix)), period_s_(period_s), excess_(excess) {}

  template <class S>
  void Visit(const char* name, S* member) {
    RateBoundArchive child(Join(name), period_s_, excess_);
    member->Serialize(&child);
  }
  template <class F>
  void Section(const char* name, F&& f, bool = false) {
    RateBoundArchive child(Join(name), period_s_, excess_);
    f(&child);
  }
  void Visit(const hal::RetiredKey&) {}
  template <class S>
  void Include(const std::string&, S*) {}
  void Period(const double* period_s) { *period_s_ = period_s; }

  template <class T>
  void Visit(const hal::Key<T>& k) {
    if (k.max_rate_power == 0 || excess_->has_value() || *period_s_ == nullptr) return;
    double value = 0.0;
    if constexpr (std::is_floating_point_v<T>) value = *k.value;
    else if constexpr (std::is_same_v<T, dynamics::VectorJ>) value = k.value->maxCoeff();
    else return;  // the YAML archive scales the bounds of these two types only
    const double period_s = **period_s_;
    if (value <= RateScaledMax(k.max, k.max_rate_power, period_s)) return;
    const int p = k.max_rate_power;
    *excess_ = RateBoundExcess{
        Join(k.name),
        std::string(k.name) + " · dt" + (p == 1 ? "" : p == 2 ? "²" : "^" + std::to_string(p)) +
            " <= " + FormatNumber(k.max) + " at " + FormatNumber(1.0 / period_s) + " Hz",
        FormatNumber(value)};
  }

 private:
  std::string Join(const char* name) const { return prefix_.empty() ? name : prefix_ + "." + name; }

  std::string prefix_;
  const double** period_s_;  // shared by the walk: Period() comes before the keys it bounds
  std::optional<RateBoundExcess>* excess_;
};

/// The first rate-scaled key of `config` (a copy: Serialize is not const) over its bound.
template <class T>
std::optional<RateBoundExcess> FindRateBoundExcess(T config) {
  const double* period_s = nullptr;
  std::optional<RateBoundExcess> excess;
  RateBoundArchive archive("", &period_s, &excess);
  config.Serialize(&archive);
  return excess;
}

}  // namespace hyq::config::detail
