// libFuzzer: bytes from a live client (GET /v1/rigs/{id}/live) through the WebSocket framing as the
// hub reads them: frames parsed one after the other from a buffer (payloads unmasked in place),
// within a 64 KiB cap, text checked for UTF-8, and each frame found the same when its bytes come in
// two pieces.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "facespace/net/websocket.h"

using facespace::net::ws::Frame;
using facespace::net::ws::FrameError;
using facespace::net::ws::Opcode;
using facespace::net::ws::ParseClientFrame;
using facespace::net::ws::Parsed;
using facespace::net::ws::ValidUtf8;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const size_t cap = data[0] % 2 ? 65536 : 125;
  std::string buf(reinterpret_cast<const char*>(data) + 1, size - 1);
  std::string copy = buf;
  size_t at = 0;
  while (at < buf.size()) {
    Frame f;
    FrameError e;
    const Parsed p = ParseClientFrame(std::span<char>(buf.data() + at, buf.size() - at), cap, f, e);
    if (p != Parsed::kFrame) {
      if (p == Parsed::kError && e.reason.empty()) std::abort();
      break;
    }
    if (f.size == 0 || f.size > buf.size() - at || f.payload.size() > cap) std::abort();
    if (f.opcode == Opcode::kText) (void)ValidUtf8(f.payload);
    // The same frame from its first half: more wanted, never another answer.
    std::string half = copy.substr(at, f.size / 2);
    Frame g;
    FrameError h;
    if (!half.empty() && ParseClientFrame(half, cap, g, h) == Parsed::kFrame) std::abort();
    at += f.size;
  }
  return 0;
}
