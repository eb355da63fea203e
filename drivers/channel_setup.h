// Throwing wrappers around the noexcept per-cycle calls, for configuration-time code (bus
// bring-up, NMT commands, tools), as lely pairs `stop(std::error_code&) noexcept` with `stop()`.
// Never use these in the cycle: they throw, and building the message allocates.
#pragma once

#include <span>

#include "hal/can_channel.h"

namespace hyq::drivers {

/// Sends every frame or throws ChannelError("<channel>: send of frame k of n failed: <status>
/// (errno e)"). kWouldBlock is retried for up to `retry_ms` milliseconds first.
void SendAllOrThrow(hal::CanChannel& channel, std::span<const hal::CanFrame> frames,
                    int retry_ms = 100);

/// Receives what is pending into `out`; throws ChannelError on any status but kOk.
std::size_t ReceiveOrThrow(hal::CanChannel& channel, std::span<hal::CanFrame> out);

}  // namespace hyq::drivers
