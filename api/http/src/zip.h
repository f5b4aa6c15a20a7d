// A zip archive written as a stream, entry by entry (no Zip64: each entry and the whole
// archive under 4 GiB). Deterministic: fixed timestamps, entries in the order added.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace facespace::http {

// `data` deflated by zlib at level 6, in the wrapper `window_bits` names (-15: raw, as zip wants;
// 15 + 16: gzip). Empty on failure: a deflated stream is never empty.
std::string Deflate(std::string_view data, int window_bits);

class ZipStream {
 public:
  // The local header and data of one entry, deflated when `compress` (and smaller), else stored.
  // Returns "" and sets failed() when the archive would pass 4 GiB.
  std::string Entry(const std::string& name, std::string_view data, bool compress);
  // The central directory and its end record: the last bytes of the archive.
  std::string Finish();
  bool failed() const { return failed_; }

 private:
  struct Central {
    std::string name;
    uint32_t crc = 0, compressed = 0, size = 0, offset = 0;
    uint16_t method = 0;
  };
  static void PutSharedFields(std::string& out, const Central& c);
  std::vector<Central> entries_;
  uint64_t offset_ = 0;
  bool failed_ = false;
};

}  // namespace facespace::http
