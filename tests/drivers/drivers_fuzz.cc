// libFuzzer target for the two decoders that read bytes from outside: python-can datagrams
// (DecodeFrameDatagram) and candump logs (ParseCandumpLine / ReadCandumpText). The first input
// byte picks the decoder; the rest is the input. Malformed input must come back as an error (a
// counted fault), never a crash, an out-of-bounds access or UB; accepted input must be a valid
// frame that survives its encoder and decoder unchanged.
//
// Built with clang++ -fsanitize=fuzzer,address,undefined by tests/drivers/CMakeLists.txt when
// clang++ is found, and run for ~20 s by the ctest drivers_fuzz (labels drivers;fuzz).
#include <array>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string_view>

#include "drivers/candump.h"
#include "drivers/msgpack_frame.h"

namespace {

using hyq::hal::CanFrame;

bool SameFrame(const CanFrame& a, const CanFrame& b) {
  if (a.id != b.id || a.flags != b.flags || a.len != b.len) return false;
  if ((a.flags & CanFrame::kRemote) != 0) return true;
  return std::memcmp(a.data.data(), b.data.data(), a.len) == 0;
}

void Check(bool ok) {
  if (!ok) std::abort();  // a property failed: libFuzzer reports it as a crash
}

void FuzzDatagram(const std::uint8_t* data, std::size_t size) {
  CanFrame f;
  if (hyq::drivers::DecodeFrameDatagram({data, size}, &f) != hyq::drivers::MsgpackError::kOk)
    return;
  Check(hyq::drivers::IsValidFrame(f));
  std::array<std::uint8_t, hyq::drivers::kMaxDatagramBytes> buf;
  const std::size_t n = hyq::drivers::EncodeFrameDatagram(f, 1.0, buf);
  Check(n > 0);
  CanFrame g;
  Check(hyq::drivers::DecodeFrameDatagram({buf.data(), n}, &g) == hyq::drivers::MsgpackError::kOk);
  Check(SameFrame(f, g));
}

void FuzzCandump(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const hyq::drivers::CandumpLog log = hyq::drivers::ReadCandumpText(
      text, "fuzz", hyq::drivers::MalformedLines::kSkipAndCount);
  for (const hyq::drivers::CandumpRecord& r : log.records) {
    Check(hyq::drivers::IsValidFrame(r.frame));
    char line[hyq::drivers::kMaxCandumpLine];
    const std::size_t n = hyq::drivers::FormatCandumpLine(r.frame, r.iface_name(), line);
    Check(n > 0);
    hyq::drivers::CandumpRecord back;
    const char* why = "";
    Check(hyq::drivers::ParseCandumpLine({line, n}, &back, &why));
    Check(SameFrame(r.frame, back.frame));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  if ((data[0] & 1) == 0) {
    FuzzDatagram(data + 1, size - 1);
  } else {
    FuzzCandump(data + 1, size - 1);
  }
  return 0;
}
