#include "zip.h"

#include <zlib.h>

namespace facespace::http {

namespace {

void Put16(std::string& s, uint32_t v) {
  s += static_cast<char>(v & 0xff);
  s += static_cast<char>((v >> 8) & 0xff);
}
void Put32(std::string& s, uint32_t v) {
  Put16(s, v & 0xffff);
  Put16(s, v >> 16);
}

constexpr uint16_t kDosDate = (0 << 9) | (1 << 5) | 1;  // 1980-01-01: reproducible archives.
constexpr uint16_t kUtf8Names = 0x0800;

}  // namespace

std::string Deflate(std::string_view data, int window_bits) {
  z_stream z{};
  if (deflateInit2(&z, 6, Z_DEFLATED, window_bits, 8, Z_DEFAULT_STRATEGY) != Z_OK) return {};
  std::string out(deflateBound(&z, static_cast<uLong>(data.size())), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  z.avail_in = static_cast<uInt>(data.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  return rc == Z_STREAM_END ? out : std::string();
}

// The fields a local file header and its central directory entry share, from "version needed"
// to "extra field length".
void ZipStream::PutSharedFields(std::string& out, const Central& c) {
  Put16(out, 20);  // Version needed: 2.0 (deflate).
  Put16(out, kUtf8Names);
  Put16(out, c.method);
  Put16(out, 0);  // Time 00:00.
  Put16(out, kDosDate);
  Put32(out, c.crc);
  Put32(out, c.compressed);
  Put32(out, c.size);
  Put16(out, static_cast<uint32_t>(c.name.size()));
  Put16(out, 0);  // No extra field.
}

std::string ZipStream::Entry(const std::string& name, std::string_view data, bool compress) {
  if (failed_ || data.size() >= 0xffffffffull || entries_.size() >= 0xffff) {
    failed_ = true;
    return {};
  }
  Central c;
  c.name = name;
  c.size = static_cast<uint32_t>(data.size());
  c.crc = static_cast<uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(data.data()), static_cast<uInt>(data.size())));
  std::string deflated = compress ? Deflate(data, -15) : std::string() /* Raw, as zip wants. */;
  const bool deflate = compress && !deflated.empty() && deflated.size() < data.size();
  c.method = deflate ? 8 : 0;
  const std::string_view body = deflate ? std::string_view(deflated) : data;
  c.compressed = static_cast<uint32_t>(body.size());
  if (offset_ + 30 + name.size() + body.size() >= 0xffffffffull) {
    failed_ = true;
    return {};
  }
  c.offset = static_cast<uint32_t>(offset_);
  std::string out;
  out.reserve(30 + name.size() + body.size());
  Put32(out, 0x04034b50);
  PutSharedFields(out, c);
  out += name;
  out.append(body.data(), body.size());
  offset_ += out.size();
  entries_.push_back(std::move(c));
  return out;
}

std::string ZipStream::Finish() {
  std::string out;
  for (const Central& c : entries_) {
    Put32(out, 0x02014b50);
    Put16(out, (3 << 8) | 20);  // Made by Unix, zip 2.0.
    PutSharedFields(out, c);
    Put16(out, 0);
    Put16(out, 0);
    Put16(out, 0);
    Put32(out, 0100644u << 16);  // -rw-r--r--
    Put32(out, c.offset);
    out += c.name;
  }
  const uint32_t count = static_cast<uint32_t>(entries_.size());
  const uint32_t directory_size = static_cast<uint32_t>(out.size());
  Put32(out, 0x06054b50);
  Put16(out, 0);
  Put16(out, 0);
  Put16(out, count);
  Put16(out, count);
  Put32(out, directory_size);
  Put32(out, static_cast<uint32_t>(offset_));
  Put16(out, 0);
  return out;
}

}  // namespace facespace::http
