// The error every configuration-time check in hal/ and config/ throws (house style §5): the
// message names the input, what was expected and what was found. Never thrown by the cycle.
#pragma once

#include <stdexcept>
#include <string>

namespace hyq::hal {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace hyq::hal
