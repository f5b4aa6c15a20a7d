// libFuzzer: datagrams from anyone who can reach a session's UDP port (issue 64), as the inlets
// read them: the first byte picks OSC (VMC) or iFacialMocap's text. Every argument read lies within
// the packet, a string within its bytes, and a message read twice reads the same.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "facespace/net/mocap.h"

using facespace::net::OscArgument;
using facespace::net::OscMessage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string packet(reinterpret_cast<const char*>(data) + 1, size - 1);
  const char* lo = packet.data();
  const char* hi = packet.data() + packet.size();
  auto inside = [&](std::string_view s) {
    if (!s.empty() && (s.data() < lo || s.data() + s.size() > hi)) std::abort();
  };
  if (data[0] % 2 == 0) {
    std::vector<std::string> first, second;
    auto keep = [&](std::vector<std::string>& into) {
      return [&, into_ptr = &into](const OscMessage& m) {
        inside(m.address);
        if (m.address.empty() || m.address[0] != '/') std::abort();
        std::string seen(m.address);
        for (const OscArgument& a : m.arguments) {
          inside(a.s);
          seen += a.tag;
          seen.append(a.s);
        }
        into_ptr->push_back(seen);
      };
    };
    const auto s1 = facespace::net::ReadOsc(packet, keep(first));
    const auto s2 = facespace::net::ReadOsc(packet, keep(second));
    if (first != second || s1.ok() != s2.ok() || (!s1.ok() && s1.message.empty())) std::abort();
  } else {
    size_t items = 0;
    const auto s = facespace::net::ReadIFacialMocap(
        packet,
        [&](std::string_view name, float) {
          inside(name);
          if (name.empty() || name.size() > 64) std::abort();
          ++items;
        },
        [&](std::string_view name, std::span<const float> v) {
          inside(name);
          if (v.empty() || v.size() > 6) std::abort();
          ++items;
        });
    if (!s.ok() && s.message.empty()) std::abort();
    if (items > packet.size()) std::abort();
  }
  return 0;
}
