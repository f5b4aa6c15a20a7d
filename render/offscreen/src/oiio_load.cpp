// Opens the OpenImageIO module (facespace/oiio/module.h) once, on first use.
#include <dlfcn.h>
#include <unistd.h>

#include <mutex>
#include <string>
#include <vector>

#include "internal.h"

namespace facespace::offscreen {

namespace {

// Beside the executable (a copied or installed build), else where the build made it.
std::string ModulePathBesideExecutable() {
  char exe[4096];
  const ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (n <= 0) return "";
  std::string path(exe, static_cast<size_t>(n));
  return path.substr(0, path.rfind('/') + 1) + "libfacespace_oiio.so";
}

std::vector<std::string> Candidates() {
  return {ModulePathBesideExecutable(), FACESPACE_OIIO_MODULE};
}

}  // namespace

std::string LocateOiio() {
  for (const std::string& path : Candidates()) {
    if (!path.empty() && access(path.c_str(), R_OK) == 0) return path;
  }
  return "";
}

const oiio::Api* LoadOiio(std::string* error) {
  static std::once_flag once;
  static const oiio::Api* api = nullptr;
  static std::string failure;
  std::call_once(once, [] {
    void* handle = nullptr;
    for (const std::string& path : Candidates()) {
      if (!path.empty() && (handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL))) break;
      if (const char* e = dlerror()) failure = e;
    }
    if (!handle) return;
    using Entry = const oiio::Api* (*)();
    if (auto entry = reinterpret_cast<Entry>(dlsym(handle, "facespace_oiio_api")))
      api = entry();
    else
      failure = "libfacespace_oiio.so has no facespace_oiio_api";
  });
  if (!api && error) *error = "the image module is unavailable (" + failure + ")";
  return api;
}

}  // namespace facespace::offscreen
