// The exception every driver throws at configuration time (opening a channel, parsing a spec,
// reading a log). The message names the input, what was expected and what was found.
#pragma once

#include <stdexcept>
#include <string>

namespace hyq::drivers {

class ChannelError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// "<what>: <strerror(err)>" for a failed system call during set-up.
std::string SystemErrorText(const std::string& what, int err);

}  // namespace hyq::drivers
