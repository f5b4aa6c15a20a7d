// libFuzzer: a sample maker's message as the batch reads it from the maker's pipe (DecodeMade),
// then written again (EncodeMade) and read back: the second reading must be the first, field for
// field.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string_view>

#include "maker.h"

namespace {

bool Same(const facespace::batch::MadeVariant& a, const facespace::batch::MadeVariant& b) {
  if (a.head != b.head || a.tail != b.tail || a.codes != b.codes || a.tar != b.tar ||
      a.files.size() != b.files.size())
    return false;
  if (std::memcmp(&a.sum, &b.sum, sizeof a.sum) != 0) return false;  // NaN too: the bits travel.
  for (size_t i = 0; i < a.files.size(); ++i) {
    const auto& [name, pieces] = a.files[i];
    if (name != b.files[i].first ||
        std::string(pieces[0]) + std::string(pieces[1]) !=
            std::string(b.files[i].second[0]) + std::string(b.files[i].second[1])) {
      return false;
    }
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace facespace::batch;
  MadeVariant first, second;
  const facespace::Status read =
      DecodeMade(std::string_view(reinterpret_cast<const char*>(data), size), first);
  const std::string again = EncodeMade(read, first);
  const facespace::Status reread = DecodeMade(again, second);
  if (reread.code != read.code || reread.message != read.message || reread.reason != read.reason)
    std::abort();
  if (read.ok() && !Same(first, second)) std::abort();
  return 0;
}
