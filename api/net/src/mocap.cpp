#include "facespace/net/mocap.h"

#include <array>
#include <charconv>
#include <cmath>
#include <cstring>

namespace facespace::net {

namespace {

Status At(size_t offset, const std::string& what) {
  return InvalidArgument("OSC packet, byte " + std::to_string(offset) + ": " + what);
}

uint32_t BigEndian32(const char* p) {
  const auto* u = reinterpret_cast<const unsigned char*>(p);
  return (uint32_t{u[0]} << 24) | (uint32_t{u[1]} << 16) | (uint32_t{u[2]} << 8) | u[3];
}

// An OSC string at `at`: up to its NUL, padded to four bytes; `at` moves past the padding.
bool ReadString(std::string_view p, size_t& at, std::string_view& out) {
  const size_t end = p.find('\0', at);
  if (end == std::string_view::npos) return false;
  out = p.substr(at, end - at);
  const size_t next = (end + 4) & ~size_t{3};
  if (next > p.size()) return false;
  at = next;
  return true;
}

// The argument tagged `tag` at `at`, moving past it.
bool ReadArgument(std::string_view p, char tag, size_t& at, OscArgument& a) {
  a = OscArgument{};
  a.tag = tag;
  const size_t left = p.size() - at;
  switch (tag) {
    case 'i':
    case 'f':
      if (left < 4) return false;
      a.i = static_cast<int32_t>(BigEndian32(p.data() + at));
      std::memcpy(&a.f, &a.i, 4);
      at += 4;
      return true;
    case 'h':
    case 'd':
    case 't': {
      if (left < 8) return false;
      const uint64_t u =
          (uint64_t{BigEndian32(p.data() + at)} << 32) | BigEndian32(p.data() + at + 4);
      a.i64 = static_cast<int64_t>(u);
      std::memcpy(&a.d, &u, 8);
      at += 8;
      return true;
    }
    case 's':
    case 'S': return ReadString(p, at, a.s);
    case 'b': {
      if (left < 4) return false;
      const uint32_t n = BigEndian32(p.data() + at);
      if (n > left - 4) return false;
      const size_t padded = (size_t{n} + 3) & ~size_t{3};
      if (padded > left - 4) return false;
      a.s = p.substr(at + 4, n);
      at += 4 + padded;
      return true;
    }
    case 'T': a.i = 1; return true;
    case 'F':
    case 'N':
    case 'I': return true;
    default: return false;  // A tag whose size this reader cannot know: the rest is unreadable.
  }
}

Status ReadMessage(std::string_view p, size_t base,
                   const std::function<void(const OscMessage&)>& each) {
  size_t at = 0;
  OscMessage m;
  std::string_view tags;
  if (!ReadString(p, at, m.address) || m.address.empty() || m.address[0] != '/')
    return At(base, "an OSC message starts with an address ('/...') ending in NUL and padding");
  if (!ReadString(p, at, tags) || tags.empty() || tags[0] != ',')
    return At(base + at, "the type tags (',...') are missing or unterminated");
  tags.remove_prefix(1);
  if (tags.size() > kMaxOscArguments)
    return At(base + at, "more than " + std::to_string(kMaxOscArguments) + " arguments");
  std::array<OscArgument, kMaxOscArguments> args;
  for (size_t k = 0; k < tags.size(); ++k) {
    const size_t start = at;
    if (!ReadArgument(p, tags[k], at, args[k]))
      return At(base + start, std::string("argument ") + std::to_string(k + 1) + " (tag '" +
                                  (tags[k] >= 32 && tags[k] < 127 ? std::string(1, tags[k]) : "?") +
                                  "') is unknown or runs past the packet");
  }
  if (at != p.size()) return At(base + at, "bytes after the message's last argument");
  m.arguments = std::span<const OscArgument>(args.data(), tags.size());
  each(m);
  return Status::Ok();
}

Status ReadElement(std::string_view p, size_t base, int depth,
                   const std::function<void(const OscMessage&)>& each) {
  if (p.empty() || p.size() % 4) return At(base, "an OSC element's size is a multiple of 4");
  if (p[0] != '#') return ReadMessage(p, base, each);
  if (depth >= kMaxOscDepth)
    return At(base, "bundles nest more than " + std::to_string(kMaxOscDepth) + " deep");
  if (p.size() < 16 || p.substr(0, 8) != std::string_view("#bundle\0", 8))
    return At(base, "a bundle starts with \"#bundle\" and its time tag");
  size_t at = 16;
  while (at < p.size()) {
    if (p.size() - at < 4) return At(base + at, "an element's size is cut off");
    const uint32_t n = BigEndian32(p.data() + at);
    if (n == 0 || n % 4 || n > p.size() - at - 4)
      return At(base + at, "an element's size (" + std::to_string(n) +
                               ") is zero, not a multiple of 4, or past the bundle");
    if (Status s = ReadElement(p.substr(at + 4, n), base + at + 4, depth + 1, each); !s.ok())
      return s;
    at += 4 + n;
  }
  return Status::Ok();
}

void PutBigEndian32(std::string& out, uint32_t v) {
  const char b[4] = {static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                     static_cast<char>(v >> 8), static_cast<char>(v)};
  out.append(b, 4);
}

void PutString(std::string& out, std::string_view s) {
  out.append(s);
  out.append(4 - s.size() % 4, '\0');  // At least one NUL, to four bytes.
}

}  // namespace

Status ReadOsc(std::string_view packet, const std::function<void(const OscMessage&)>& each) {
  return ReadElement(packet, 0, 0, each);
}

void AppendOscMessage(std::string& out, std::string_view address, std::string_view name,
                      float value) {
  PutString(out, address);
  PutString(out, ",sf");
  PutString(out, name);
  uint32_t bits;
  std::memcpy(&bits, &value, 4);
  PutBigEndian32(out, bits);
}

void AppendOscMessage(std::string& out, std::string_view address) {
  PutString(out, address);
  PutString(out, ",");
}

void BeginOscBundle(std::string& out) {
  out.append("#bundle\0", 8);
  PutBigEndian32(out, 0);
  PutBigEndian32(out, 1);  // The time tag "immediately".
}

void AppendOscElement(std::string& bundle, std::string_view message) {
  PutBigEndian32(bundle, static_cast<uint32_t>(message.size()));
  bundle.append(message);
}

namespace {

Status ItemError(size_t index, std::string_view item, const std::string& what) {
  return InvalidArgument("iFacialMocap item " + std::to_string(index + 1) + " ('" +
                         std::string(item.substr(0, 40)) + "'): " + what);
}

bool ReadFloat(std::string_view s, float& out) {
  if (s.empty()) return false;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && std::isfinite(out);
}

// "head#-21.4,-6.0,-6.6,-0.03,-0.1,-0.65": at most 6 numbers.
Status ReadPose(size_t index, std::string_view item, size_t hash,
                const std::function<void(std::string_view, std::span<const float>)>& pose) {
  std::string_view name = item.substr(0, hash);
  if (!name.empty() && name[0] == '=') name.remove_prefix(1);
  std::array<float, 6> v{};
  size_t n = 0, at = hash + 1;
  while (at <= item.size()) {
    size_t end = item.find(',', at);
    if (end == std::string_view::npos) end = item.size();
    if (n == v.size() || !ReadFloat(item.substr(at, end - at), v[n]))
      return ItemError(index, item, "a pose is at most 6 finite numbers after '#'");
    ++n;
    at = end + 1;
  }
  pose(name, std::span<const float>(v.data(), n));
  return Status::Ok();
}

}  // namespace

Status ReadIFacialMocap(std::string_view text,
                        const std::function<void(std::string_view, float)>& blend,
                        const std::function<void(std::string_view, std::span<const float>)>& pose) {
  size_t at = 0, index = 0;
  while (at < text.size()) {
    size_t end = text.find('|', at);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view item = text.substr(at, end - at);
    at = end + 1;
    if (item.empty()) continue;
    const size_t hash = item.find('#');
    const size_t sep = item.find_first_of("-&");
    const size_t name_end = std::min(hash, sep);
    if (name_end == 0 || name_end == std::string_view::npos || name_end > 64)
      return ItemError(index, item, "an item is name-value or name#numbers, a name of 1-64 bytes");
    if (hash < sep) {
      if (Status s = ReadPose(index, item, hash, pose); !s.ok()) return s;
    } else {
      float v = 0;
      if (!ReadFloat(item.substr(sep + 1), v))
        return ItemError(index, item, "the value after the name is not a finite number");
      blend(item.substr(0, sep), v);
    }
    ++index;
  }
  return Status::Ok();
}

}  // namespace facespace::net
