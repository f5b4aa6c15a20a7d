#include "facespace/api/jobs.h"
#include "facespace/api/store.h"

namespace facespace::api {

bool IsValidRigId(const std::string& id) {
  if (id.empty() || id.size() > 64) return false;
  auto lower_digit = [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9'); };
  if (!lower_digit(id[0])) return false;
  for (char c : id) {
    if (!lower_digit(c) && c != '_' && c != '-') return false;
  }
  return true;
}

bool IsValidJobId(const std::string& id) {
  if (id.size() != 32) return false;
  for (char c : id) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

}  // namespace facespace::api
