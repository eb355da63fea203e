// python-can `udp_multicast` datagrams: one CAN frame as one msgpack map.
//
// The map python-can 4.1 (can/interfaces/udp_multicast/utils.py) sends has 11 keys in this order
// (msgpack spec: https://github.com/msgpack/msgpack/blob/master/spec.md):
//   timestamp (float64, s), arbitration_id (uint), is_extended_id, is_remote_frame,
//   is_error_frame (bool), channel (str | nil), dlc (uint, data length in bytes, not the DLC
//   code), data (bin), is_fd, bitrate_switch, error_state_indicator (bool).
// The encoder writes exactly that; the decoder accepts any key order and any msgpack integer or
// float width, and applies python-can's own Message checks (ids in range, dlc == len(data) except
// for remote frames, no BRS/ESI without FD). Neither allocates nor throws.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "hal/can_channel.h"

namespace hyq::drivers {

/// Big enough for any frame the encoder writes (an FD frame with 64 bytes is 227 bytes).
inline constexpr std::size_t kMaxDatagramBytes = 256;

enum class [[nodiscard]] MsgpackError : std::uint8_t {
  kOk,
  kTruncated,      // the datagram ended inside a value
  kNotAMap,        // the top-level value is not a map
  kBadKey,         // a key that is not a string or not one python-can's Message accepts
  kBadType,        // a value of the wrong msgpack type for its key
  kBadValue,       // a value out of range (id, dlc, data length, FD length, flag combination)
  kMissingField,   // no arbitration_id
  kTrailingBytes,  // bytes after the map
  kTooDeep,        // nesting deeper than the decoder follows
};

const char* ToString(MsgpackError e) noexcept;

/// Writes `frame` as python-can's map into `out`; returns the byte count, 0 when `out` is too
/// small or the frame is not representable (bad id or length). `timestamp_s` fills the
/// timestamp key (receivers ignore it and use their own receive time).
std::size_t EncodeFrameDatagram(const hal::CanFrame& frame, double timestamp_s,
                                std::span<std::uint8_t> out) noexcept;

/// Decodes one datagram into `*frame` (timestamp_ns is left 0: the caller sets the receive
/// time). On error `*frame` is unspecified.
MsgpackError DecodeFrameDatagram(std::span<const std::uint8_t> in, hal::CanFrame* frame) noexcept;

/// True for the payload lengths a CAN FD frame can have: 0–8, 12, 16, 20, 24, 32, 48, 64.
bool IsValidFdLength(std::size_t len) noexcept;

/// True when `frame` is a well-formed classic or FD frame (id range, length, flag combination).
bool IsValidFrame(const hal::CanFrame& frame) noexcept;

}  // namespace hyq::drivers
