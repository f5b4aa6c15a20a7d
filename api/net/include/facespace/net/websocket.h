// RFC 6455 framing for the live route (the HTTP layer's GET /v1/rigs/{id}/live): the handshake's
// accept key, client frames parsed strictly (masked, no reserved bits or unknown opcodes, control
// frames short and whole, lengths within the caller's cap before any payload is held), server
// frames built (unmasked, whole). Pure functions over bytes: what tests/fuzz feed hostile input to.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace facespace::net::ws {

enum class Opcode : uint8_t {
  kContinuation = 0,
  kText = 1,
  kBinary = 2,
  kClose = 8,
  kPing = 9,
  kPong = 10
};

// The close codes this server sends (RFC 6455, 7.4.1).
enum class CloseCode : uint16_t {
  kNormal = 1000,
  kGoingAway = 1001,      // The server stops, or the session's time is up.
  kProtocolError = 1002,  // Framing broken: unmasked, reserved bits, a control frame split or long.
  kUnsupportedData = 1003,  // Binary audio without {"listen": ...} first.
  kInvalidPayload = 1007,   // A text message that is not UTF-8.
  kPolicy = 1008,           // A flood past the session's message rate; a client that does not read.
  kTooBig = 1009,           // A message over the session's cap.
  kInternal = 1011,
};

struct Frame {
  bool fin = false;
  Opcode opcode = Opcode::kContinuation;
  std::string_view payload;  // Unmasked in place, within the buffer parsed.
  size_t size = 0;           // Bytes of the buffer the frame took (header and payload).
};

struct FrameError {
  CloseCode code = CloseCode::kProtocolError;
  std::string reason;  // For the close frame: short, ASCII.
};

enum class Parsed { kNeedMore, kFrame, kError };

// One client frame at the start of `buf`, its payload unmasked in place. A frame whose declared
// payload is over `max_payload` is an error (1009) as soon as its header is read: nothing of it is
// held.
Parsed ParseClientFrame(std::span<char> buf, size_t max_payload, Frame& frame, FrameError& error);

// Whether `key` (Sec-WebSocket-Key) is the base64 of 16 bytes, as RFC 6455 asks.
bool ValidClientKey(std::string_view key);
// Sec-WebSocket-Accept for a client's key: base64(SHA-1(key + the RFC's GUID)).
std::string AcceptKey(std::string_view key);

// A server frame (fin, unmasked): its header appended to `out` for a payload of `length` bytes.
void AppendFrameHeader(std::string& out, Opcode opcode, uint64_t length);
// A whole server frame.
std::string ServerFrame(Opcode opcode, std::string_view payload);
// A close frame with its code and reason (cut to fit a control frame's 125 bytes).
std::string CloseFrame(CloseCode code, std::string_view reason);

// Whether `s` is well-formed UTF-8 (a text message must be).
bool ValidUtf8(std::string_view s);

}  // namespace facespace::net::ws
