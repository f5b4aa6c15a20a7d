#include "facespace/net/websocket.h"

#include <openssl/evp.h>

#include <cstring>

#include "facespace/engine/utf8.h"

namespace facespace::net::ws {

namespace {

constexpr char kGuid[] = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11";

bool IsBase64(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' ||
         c == '/';
}

bool Known(uint8_t opcode) { return opcode <= 2 || (opcode >= 8 && opcode <= 10); }

}  // namespace

Parsed ParseClientFrame(std::span<char> buf, size_t max_payload, Frame& frame, FrameError& error) {
  if (buf.size() < 2) return Parsed::kNeedMore;
  const auto* b = reinterpret_cast<const uint8_t*>(buf.data());
  const bool fin = b[0] & 0x80;
  const uint8_t opcode = b[0] & 0x0F;
  auto fail = [&error](CloseCode code, const char* reason) {
    error = {code, reason};
    return Parsed::kError;
  };
  if (b[0] & 0x70)
    return fail(CloseCode::kProtocolError, "reserved bits set (no extension was agreed)");
  if (!Known(opcode)) return fail(CloseCode::kProtocolError, "unknown opcode");
  if (!(b[1] & 0x80)) return fail(CloseCode::kProtocolError, "a client frame must be masked");
  uint64_t length = b[1] & 0x7F;
  size_t at = 2;
  if (opcode >= 8 && (!fin || length > 125))
    return fail(CloseCode::kProtocolError, "a control frame must be whole and at most 125 bytes");
  if (length == 126) {
    if (buf.size() < 4) return Parsed::kNeedMore;
    length = static_cast<uint64_t>(b[2]) << 8 | b[3];
    at = 4;
    if (length < 126) return fail(CloseCode::kProtocolError, "a length not in its shortest form");
  } else if (length == 127) {
    if (buf.size() < 10) return Parsed::kNeedMore;
    length = 0;
    for (int i = 0; i < 8; ++i) length = length << 8 | b[2 + i];
    at = 10;
    if (length >> 63) return fail(CloseCode::kProtocolError, "a length with its top bit set");
    if (length < 65536) return fail(CloseCode::kProtocolError, "a length not in its shortest form");
  }
  if (length > max_payload) return fail(CloseCode::kTooBig, "message too big for this session");
  if (buf.size() < at + 4 + length) return Parsed::kNeedMore;
  const uint8_t* mask = b + at;
  char* payload = buf.data() + at + 4;
  for (size_t i = 0; i < length; ++i)
    payload[i] = static_cast<char>(payload[i] ^ static_cast<char>(mask[i & 3]));
  frame.fin = fin;
  frame.opcode = static_cast<Opcode>(opcode);
  frame.payload = std::string_view(payload, static_cast<size_t>(length));
  frame.size = at + 4 + static_cast<size_t>(length);
  return Parsed::kFrame;
}

bool ValidClientKey(std::string_view key) {
  if (key.size() != 24 || key.substr(22) != "==") return false;
  for (size_t i = 0; i < 22; ++i) {
    if (!IsBase64(key[i])) return false;
  }
  // 16 bytes: the last character before the padding carries 2 bits, the rest zero.
  return std::strchr("AQgw", key[21]) != nullptr;
}

std::string AcceptKey(std::string_view key) {
  std::string text(key);
  text += kGuid;
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  EVP_Digest(text.data(), text.size(), digest, &size, EVP_sha1(), nullptr);
  unsigned char out[4 * ((EVP_MAX_MD_SIZE + 2) / 3) + 1];
  const int n = EVP_EncodeBlock(out, digest, static_cast<int>(size));
  return std::string(reinterpret_cast<const char*>(out), static_cast<size_t>(n));
}

void AppendFrameHeader(std::string& out, Opcode opcode, uint64_t length) {
  out.push_back(static_cast<char>(0x80 | static_cast<uint8_t>(opcode)));
  if (length < 126) {
    out.push_back(static_cast<char>(length));
  } else if (length < 65536) {
    out.push_back(static_cast<char>(126));
    out.push_back(static_cast<char>(length >> 8));
    out.push_back(static_cast<char>(length));
  } else {
    out.push_back(static_cast<char>(127));
    for (int i = 7; i >= 0; --i) out.push_back(static_cast<char>(length >> (8 * i)));
  }
}

std::string ServerFrame(Opcode opcode, std::string_view payload) {
  std::string out;
  out.reserve(payload.size() + 10);
  AppendFrameHeader(out, opcode, payload.size());
  out.append(payload);
  return out;
}

std::string CloseFrame(CloseCode code, std::string_view reason) {
  std::string payload;
  payload.push_back(static_cast<char>(static_cast<uint16_t>(code) >> 8));
  payload.push_back(static_cast<char>(static_cast<uint16_t>(code)));
  size_t keep = std::min<size_t>(reason.size(), 123);
  while (keep > 0 && keep < reason.size() &&
         (static_cast<unsigned char>(reason[keep]) & 0xC0) == 0x80)
    --keep;  // Whole characters.
  payload.append(reason.substr(0, keep));
  return ServerFrame(Opcode::kClose, payload);
}

bool ValidUtf8(std::string_view s) {
  for (size_t i = 0; i < s.size();) {
    char32_t cp;
    const size_t n = DecodeUtf8(s, i, cp);
    if (n == 0) return false;
    i += n;
  }
  return true;
}

}  // namespace facespace::net::ws
