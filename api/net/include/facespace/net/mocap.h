// The wire formats the apps people stream faces with speak (issue 64), as pure functions over the
// bytes of one datagram: OSC 1.0 (the VMC protocol's carrier: messages and bundles of int32,
// float32, string, blob and the argument-less tags) and iFacialMocap's text
// ("jawOpen-72|eyeBlink_L-25|...|=head#pitch,yaw,roll,x,y,z|rightEye#p,y,r|leftEye#p,y,r|").
// A datagram comes from anyone who can reach the port: every length, padding and type tag is
// checked against the bytes there are, bundles nest at most kMaxOscDepth deep, and a message has
// at most kMaxOscArguments arguments, so a packet costs time linear in its size.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>

#include "facespace/engine/status.h"

namespace facespace::net {

inline constexpr int kMaxOscDepth = 4;
inline constexpr size_t kMaxOscArguments = 16;

// One argument: its type tag and value (i: int32, f: float32, s: string, b: blob bytes in `s`,
// h: int64 in `i64`, d: float64, T/F: true/false in `i`, N/I: nothing).
struct OscArgument {
  char tag = 0;
  int32_t i = 0;
  int64_t i64 = 0;
  double d = 0;
  float f = 0;
  std::string_view s;
};

struct OscMessage {
  std::string_view address;  // "/VMC/Ext/Blend/Val"
  std::span<const OscArgument> arguments;
};

// Calls `each` for every message of `packet` (one message, or a bundle of messages and bundles),
// in their order. An error (InvalidArgument naming the byte where the packet stops making sense)
// ends the reading; the messages before it have been given.
Status ReadOsc(std::string_view packet, const std::function<void(const OscMessage&)>& each);

// Writing: a message of a string and a float, as VMC's /VMC/Ext/Blend/Val "A" 0.5; one without
// arguments (/VMC/Ext/Blend/Apply); and a bundle ("#bundle", the immediate time tag) whose
// elements are appended one by one.
void AppendOscMessage(std::string& out, std::string_view address, std::string_view name,
                      float value);
void AppendOscMessage(std::string& out, std::string_view address);
void BeginOscBundle(std::string& out);
void AppendOscElement(std::string& bundle, std::string_view message);

// One iFacialMocap datagram: `blend(name, value)` for every "name-value" (or "name&value") item,
// value as sent (0-100); `pose(name, values)` for every "name#a,b,c..." item (head: 6 numbers,
// eyes: 3), with "=head" read as "head". Errors name the item (InvalidArgument); items before it
// have been given. Names are at most 64 bytes, values finite decimals.
Status ReadIFacialMocap(std::string_view text,
                        const std::function<void(std::string_view, float)>& blend,
                        const std::function<void(std::string_view, std::span<const float>)>& pose);

}  // namespace facespace::net
