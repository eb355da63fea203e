// The python-can datagram codec: byte-for-byte against python-can's own packer, round trips of
// every frame kind, and rejection of malformed input.
#include "drivers/msgpack_frame.h"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "tests/drivers/test_util.h"

namespace hyq::drivers::testing {
namespace {

using hal::CanFrame;

std::vector<std::uint8_t> FromHex(const std::string& hex) {
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2)
    out.push_back(static_cast<std::uint8_t>(std::stoul(hex.substr(i, 2), nullptr, 16)));
  return out;
}

std::vector<std::uint8_t> Encode(const CanFrame& f, double t = 0.0) {
  std::vector<std::uint8_t> buf(kMaxDatagramBytes);
  const std::size_t n = EncodeFrameDatagram(f, t, buf);
  buf.resize(n);
  return buf;
}

// Produced by python-can 4.1.0 (Debian python3-can) utils.pack_message:
//   Message(timestamp=1.5, arbitration_id=0x123, is_extended_id=False, data=de ad be ef)
const char* kPythonClassic =
    "8ba974696d657374616d70cb3ff8000000000000ae6172626974726174696f6e5f6964cd0123ae69735f6578"
    "74656e6465645f6964c2af69735f72656d6f74655f6672616d65c2ae69735f6572726f725f6672616d65c2a7"
    "6368616e6e656cc0a3646c6304a464617461c404deadbeefa569735f6664c2ae626974726174655f73776974"
    "6368c2b56572726f725f73746174655f696e64696361746f72c2";
//   Message(timestamp=0.0, arbitration_id=0x1ABCDEF0, is_extended_id=True, is_fd=True,
//           bitrate_switch=True, data=bytes(range(12)))
const char* kPythonFd =
    "8ba974696d657374616d70cb0000000000000000ae6172626974726174696f6e5f6964ce1abcdef0ae69735f"
    "657874656e6465645f6964c3af69735f72656d6f74655f6672616d65c2ae69735f6572726f725f6672616d65"
    "c2a76368616e6e656cc0a3646c630ca464617461c40c000102030405060708090a0ba569735f6664c3ae6269"
    "74726174655f737769746368c3b56572726f725f73746174655f696e64696361746f72c2";

TEST(MsgpackFrame, EncoderMatchesPythonCanBytes) {
  EXPECT_EQ(Encode(Classic(0x123, {0xde, 0xad, 0xbe, 0xef}), 1.5), FromHex(kPythonClassic));
  CanFrame fd = Fd(0x1ABCDEF0, 12, 0, true, false, true);
  for (std::size_t i = 0; i < 12; ++i) fd.data[i] = static_cast<std::uint8_t>(i);
  EXPECT_EQ(Encode(fd, 0.0), FromHex(kPythonFd));
}

TEST(MsgpackFrame, DecodesPythonCanBytes) {
  CanFrame f;
  ASSERT_EQ(DecodeFrameDatagram(FromHex(kPythonClassic), &f), MsgpackError::kOk);
  EXPECT_TRUE(SameFrame(f, Classic(0x123, {0xde, 0xad, 0xbe, 0xef})));
  ASSERT_EQ(DecodeFrameDatagram(FromHex(kPythonFd), &f), MsgpackError::kOk);
  EXPECT_EQ(f.id, 0x1ABCDEF0u);
  EXPECT_EQ(f.len, 12);
  EXPECT_TRUE(f.is_fd() && f.is_extended() && (f.flags & CanFrame::kBitrateSwitch));
}

TEST(MsgpackFrame, RoundTripsEveryFrameKind) {
  const std::vector<CanFrame> frames = {
      Classic(0x000, {}),
      Classic(0x7FF, {1, 2, 3, 4, 5, 6, 7, 8}),
      Classic(0x1FFFFFFF, {0xAA}, true),
      Classic(0x80, {0}, true),  // extended id with a small value stays extended
      Remote(0x701, 0),
      Remote(0x12345, 8, true),
      Error(0x40, {0, 0, 0, 0, 0, 0, 0, 0}),
      Error(0x00000204, {0, 0x10, 0, 0, 0, 0, 0x80, 0x7F}),
      Fd(0x181, 0, 1),
      Fd(0x181, 8, 2, false),
      Fd(0x181, 64, 3, true, true),
      Fd(0x1F000181, 48, 4, false, true, true),
  };
  for (const CanFrame& in : frames) {
    const std::vector<std::uint8_t> bytes = Encode(in, 12345.678);
    ASSERT_FALSE(bytes.empty()) << testing::Describe(in);
    ASSERT_LE(bytes.size(), kMaxDatagramBytes);
    CanFrame out;
    ASSERT_EQ(DecodeFrameDatagram(bytes, &out), MsgpackError::kOk) << testing::Describe(in);
    EXPECT_TRUE(SameFrame(in, out));
  }
}

TEST(MsgpackFrame, RefusesToEncodeInvalidFrames) {
  std::vector<std::uint8_t> buf(kMaxDatagramBytes);
  CanFrame f = Classic(0x800, {});  // 11-bit id out of range
  EXPECT_EQ(EncodeFrameDatagram(f, 0, buf), 0u);
  f = Classic(0x20000000, {}, true);
  EXPECT_EQ(EncodeFrameDatagram(f, 0, buf), 0u);
  f = Classic(0x1, {});
  f.len = 9;
  EXPECT_EQ(EncodeFrameDatagram(f, 0, buf), 0u);
  f = Fd(0x1, 13, 0);
  EXPECT_EQ(EncodeFrameDatagram(f, 0, buf), 0u);
  f = Classic(0x1, {1});
  f.flags |= CanFrame::kBitrateSwitch;
  EXPECT_EQ(EncodeFrameDatagram(f, 0, buf), 0u);
  f = Fd(0x1, 8, 0);
  std::vector<std::uint8_t> small(20);
  EXPECT_EQ(EncodeFrameDatagram(f, 0, small), 0u);  // buffer too small
}

TEST(MsgpackFrame, AcceptsOtherKeyOrdersAndWidths) {
  // {"data": bin8 [1,2], "arbitration_id": uint64 0x10, "is_extended_id": false,
  //  "timestamp": float32 1.0, "is_rx": true} as a map16; dlc omitted -> len(data)
  const std::vector<std::uint8_t> bytes = {
      0xDE, 0x00, 0x05,
      0xA4, 'd', 'a', 't', 'a', 0xC4, 0x02, 0x01, 0x02,
      0xAE, 'a', 'r', 'b', 'i', 't', 'r', 'a', 't', 'i', 'o', 'n', '_', 'i', 'd',
      0xCF, 0, 0, 0, 0, 0, 0, 0, 0x10,
      0xAE, 'i', 's', '_', 'e', 'x', 't', 'e', 'n', 'd', 'e', 'd', '_', 'i', 'd', 0xC2,
      0xA9, 't', 'i', 'm', 'e', 's', 't', 'a', 'm', 'p', 0xCA, 0x3F, 0x80, 0x00, 0x00,
      0xA5, 'i', 's', '_', 'r', 'x', 0xC3};
  CanFrame f;
  ASSERT_EQ(DecodeFrameDatagram(bytes, &f), MsgpackError::kOk);
  EXPECT_TRUE(SameFrame(f, Classic(0x10, {1, 2})));
}

TEST(MsgpackFrame, DefaultsFollowPythonCan) {
  // {"arbitration_id": 0x10} alone: python-can's Message defaults to an extended id, no data
  const std::vector<std::uint8_t> bytes = {
      0x81, 0xAE, 'a', 'r', 'b', 'i', 't', 'r', 'a', 't', 'i', 'o', 'n', '_', 'i', 'd', 0x10};
  CanFrame f;
  ASSERT_EQ(DecodeFrameDatagram(bytes, &f), MsgpackError::kOk);
  EXPECT_TRUE(SameFrame(f, Classic(0x10, {}, true)));
}

TEST(MsgpackFrame, RejectsMalformedDatagrams) {
  const std::vector<std::uint8_t> good = Encode(Fd(0x181, 16, 9));
  CanFrame f;
  // every strict prefix is truncated or otherwise invalid; none may decode
  for (std::size_t n = 0; n < good.size(); ++n)
    EXPECT_NE(DecodeFrameDatagram({good.data(), n}, &f), MsgpackError::kOk) << n;
  std::vector<std::uint8_t> extra = good;
  extra.push_back(0xC0);
  EXPECT_EQ(DecodeFrameDatagram(extra, &f), MsgpackError::kTrailingBytes);
  EXPECT_EQ(DecodeFrameDatagram(std::vector<std::uint8_t>{0x93, 1, 2, 3}, &f),
            MsgpackError::kNotAMap);
  EXPECT_EQ(DecodeFrameDatagram(std::vector<std::uint8_t>{0x80}, &f),
            MsgpackError::kMissingField);
  // unknown key
  EXPECT_EQ(DecodeFrameDatagram(std::vector<std::uint8_t>{0x81, 0xA1, 'x', 0x01}, &f),
            MsgpackError::kBadKey);
  // non-string key
  EXPECT_EQ(DecodeFrameDatagram(std::vector<std::uint8_t>{0x81, 0x01, 0x01}, &f),
            MsgpackError::kBadKey);
  // map count larger than the datagram
  EXPECT_EQ(DecodeFrameDatagram(std::vector<std::uint8_t>{0xDF, 0xFF, 0xFF, 0xFF, 0xFF}, &f),
            MsgpackError::kTruncated);
  // dlc disagrees with data
  std::vector<std::uint8_t> bad = Encode(Classic(0x1, {1, 2, 3}));
  for (std::size_t i = 0; i + 4 < bad.size(); ++i) {
    if (bad[i] == 0xA3 && bad[i + 1] == 'd' && bad[i + 2] == 'l' && bad[i + 3] == 'c') {
      bad[i + 4] = 2;
      break;
    }
  }
  EXPECT_EQ(DecodeFrameDatagram(bad, &f), MsgpackError::kBadValue);
  // FD length that a real FD frame cannot have (python-can allows 10, CAN FD does not)
  std::vector<std::uint8_t> fd10 = Encode(Fd(0x1, 12, 0));
  std::size_t bin = 0;
  for (std::size_t i = 0; i + 4 < fd10.size(); ++i) {
    if (fd10[i] == 0xA3 && fd10[i + 1] == 'd' && fd10[i + 2] == 'l' && fd10[i + 3] == 'c')
      fd10[i + 4] = 10;
    if (fd10[i] == 0xC4 && fd10[i + 1] == 12) bin = i;
  }
  ASSERT_NE(bin, 0u);
  fd10[bin + 1] = 10;
  const auto payload_end = fd10.begin() + static_cast<std::ptrdiff_t>(bin + 2 + 12);
  fd10.erase(payload_end - 2, payload_end);
  EXPECT_EQ(DecodeFrameDatagram(fd10, &f), MsgpackError::kBadValue);
}

TEST(MsgpackFrame, RandomBytesNeverCrash) {
  std::mt19937 rng(6);
  std::vector<std::uint8_t> buf;
  const std::vector<std::uint8_t> good = Encode(Fd(0x181, 64, 9));
  int ok = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    buf = good;
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int k = 0; k < flips; ++k) buf[rng() % buf.size()] = static_cast<std::uint8_t>(rng());
    buf.resize(rng() % (buf.size() + 1));
    CanFrame f;
    if (DecodeFrameDatagram(buf, &f) == MsgpackError::kOk) {
      ++ok;
      EXPECT_TRUE(IsValidFrame(f));
    }
  }
  SUCCEED() << ok << " mutated datagrams still decoded to valid frames";
}

}  // namespace
}  // namespace hyq::drivers::testing
