// One registry of the rig formats: how each is told (extension, magic) and read (from bytes, and
// from a file with what lies beside it). LoadRigFile, LoadRigMemory and the format helpers read
// this table alone; a new format is a row.
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string_view>

#include "common/image_file.h"
#include "facespace/engine/face.h"
#include "facespace/formats/io.h"
#include "fbx/fbx_tree.h"

namespace facespace::formats {

namespace {

bool EndsWith(const std::string& s, const std::string& t) {
  if (s.size() < t.size()) return false;
  for (size_t i = 0; i < t.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(s[s.size() - t.size() + i])) != t[i]) return false;
  }
  return true;
}

std::string Stem(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const std::string file = slash == std::string::npos ? path : path.substr(slash + 1);
  return file.substr(0, file.rfind('.'));
}

Result<std::vector<unsigned char>> ReadFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return NotFound("cannot open '" + path + "'");
  return std::vector<unsigned char>((std::istreambuf_iterator<char>(f)),
                                    std::istreambuf_iterator<char>());
}

std::string_view Head(std::span<const unsigned char> bytes) {
  return {reinterpret_cast<const char*>(bytes.data()), std::min<size_t>(bytes.size(), 4096)};
}

Result<Rig> GltfMemory(std::span<const unsigned char> bytes, const std::string&) {
  return LoadGltfMemory(bytes, "", {.allow_external_files = false, .read_manifest = false});
}
Result<Rig> Md5Memory(std::span<const unsigned char> bytes, const std::string& name) {
  return LoadMd5Memory(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                       name + ".md5mesh", {});
}

// A format read whole from the file's bytes (FBX, COLLADA, PMX, PMD), then what lies beside it:
// images (COLLADA, MMD) and motions (MMD).
template <Result<Rig> (*Load)(std::span<const unsigned char>, const std::string&), bool kImages,
          bool kMotions>
Result<Rig> FromBytes(const std::string& path, const LoadOptions&) {
  Result<std::vector<unsigned char>> bytes = ReadFile(path);
  if (!bytes.ok()) return bytes.status();
  Result<Rig> rig = Load(bytes.value(), Stem(path));
  if (!rig.ok()) return rig;
  rig->name = Stem(path);
  if (kImages) LoadImagesBeside(rig.value(), path);
  if (kMotions) AddVmdMotions(rig.value(), path);
  return rig;
}

Result<Rig> GltfFile(const std::string& path, const LoadOptions& options) {
  return LoadGltfFile(path, options);
}
Result<Rig> Md5File(const std::string& path, const LoadOptions&) { return LoadMd5File(path); }

struct FormatEntry {
  RigFormat format;
  const char* extension;
  bool (*sniff)(std::string_view head);
  Result<Rig> (*load_memory)(std::span<const unsigned char> bytes, const std::string& name);
  Result<Rig> (*load_file)(const std::string& path, const LoadOptions& options);
};

// Sniffed in this order: the binary magics first, glTF JSON (which only says "asset") last.
constexpr FormatEntry kFormats[] = {
    {RigFormat::kGlb, ".glb", [](std::string_view h) { return h.substr(0, 4) == "glTF"; },
     GltfMemory, GltfFile},
    {RigFormat::kPmx, ".pmx", [](std::string_view h) { return h.substr(0, 4) == "PMX "; },
     LoadPmxMemory, FromBytes<LoadPmxMemory, true, true>},
    {RigFormat::kPmd, ".pmd", [](std::string_view h) { return h.substr(0, 3) == "Pmd"; },
     LoadPmdMemory, FromBytes<LoadPmdMemory, true, true>},
    {RigFormat::kFbx, ".fbx",
     [](std::string_view h) {
       return fbx::LooksLikeFbx({reinterpret_cast<const unsigned char*>(h.data()), h.size()});
     },
     LoadFbxMemory, FromBytes<LoadFbxMemory, false, false>},
    {RigFormat::kCollada, ".dae",
     [](std::string_view h) { return h.find("<COLLADA") != std::string_view::npos; },
     LoadColladaMemory, FromBytes<LoadColladaMemory, true, false>},
    {RigFormat::kMd5, ".md5mesh",
     [](std::string_view h) { return h.find("MD5Version") != std::string_view::npos; }, Md5Memory,
     Md5File},
    {RigFormat::kGltf, ".gltf",
     [](std::string_view h) {
       return h.find("\"asset\"") != std::string_view::npos &&
              h.find('{') != std::string_view::npos;
     },
     GltfMemory, GltfFile},
};

const FormatEntry& Entry(RigFormat format) {
  for (const FormatEntry& e : kFormats) {
    if (e.format == format) return e;
  }
  return kFormats[0];  // Every RigFormat has a row.
}

}  // namespace

bool RigFormatFromPath(const std::string& path, RigFormat* format) {
  for (const FormatEntry& e : kFormats) {
    if (EndsWith(path, e.extension)) {
      *format = e.format;
      return true;
    }
  }
  return false;
}

bool SniffRigFormat(std::span<const unsigned char> bytes, RigFormat* format) {
  for (const FormatEntry& e : kFormats) {
    if (e.sniff(Head(bytes))) {
      *format = e.format;
      return true;
    }
  }
  return false;
}

const char* RigFormatExtension(RigFormat format) { return Entry(format).extension; }

Result<Rig> LoadRigMemory(std::span<const unsigned char> bytes, RigFormat format,
                          const std::string& name) {
  Result<Rig> rig = Entry(format).load_memory(bytes, name);
  if (!rig.ok()) return rig;
  rig->name = name;
  DeriveFace(rig.value());  // A manifest applied after replaces what it names.
  return rig;
}

namespace {

// `rel` (a path with '/') under `dir`, matching each component's letter case loosely; empty when
// there is none, or when `rel` would leave `dir`.
std::filesystem::path FindBeside(const std::filesystem::path& dir, const std::string& rel) {
  namespace fs = std::filesystem;
  if (rel.empty() || rel[0] == '/' || rel.find(':') != std::string::npos) return {};
  fs::path at = dir;
  size_t start = 0;
  while (start <= rel.size()) {
    size_t end = rel.find('/', start);
    if (end == std::string::npos) end = rel.size();
    const std::string part = rel.substr(start, end - start);
    start = end + 1;
    if (part.empty() || part == ".") continue;
    if (part == "..") return {};
    std::error_code ec;
    if (fs::exists(at / part, ec)) {
      at /= part;
      continue;
    }
    auto lower = [](std::string t) {
      for (char& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      return t;
    };
    fs::path found;
    for (const auto& e : fs::directory_iterator(at, ec)) {
      if (lower(e.path().filename().string()) == lower(part)) found = e.path();
    }
    if (found.empty()) return {};
    at = found;
  }
  return at;
}

}  // namespace

int AddImageBeside(Rig& rig, const std::string& path) {
  rig.images.push_back({path, "", {}});
  rig.load_warnings.push_back(
      {"texture_not_loaded",
       "texture '" + path + "' is not read (a model read from bytes has no folder)", path, 0.0,
       false});
  return static_cast<int>(rig.images.size()) - 1;
}

std::string ReadImageFile(const std::filesystem::path& file, Image& image) {
  namespace fs = std::filesystem;
  constexpr std::uintmax_t kMaxImageBytes = std::uintmax_t{64} << 20;
  std::error_code ec;
  const std::uintmax_t size = file.empty() ? 0 : fs::file_size(file, ec);
  if (file.empty() || ec || !fs::is_regular_file(file, ec)) return "no such file";
  if (size == 0 || size > kMaxImageBytes) return "empty or over 64 MiB";
  std::ifstream f(file, std::ios::binary);
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)),
                                   std::istreambuf_iterator<char>());
  std::string ext = file.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  std::string mime;
  if (bytes.size() > 8 && bytes[0] == 0x89 && bytes[1] == 'P' && bytes[2] == 'N' && bytes[3] == 'G')
    mime = "image/png";
  else if (bytes.size() > 3 && bytes[0] == 0xFF && bytes[1] == 0xD8)
    mime = "image/jpeg";
  else if (bytes.size() > 2 && bytes[0] == 'B' && bytes[1] == 'M')
    mime = "image/bmp";
  else if (ext == ".tga")
    mime = "image/x-tga";
  else
    return "not a PNG, JPEG, BMP or TGA image";
  image.bytes = std::move(bytes);
  image.mime_type = std::move(mime);
  return "";
}

void LoadImagesBeside(Rig& rig, const std::string& model_path) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(model_path).parent_path().empty()
                           ? fs::path(".")
                           : fs::path(model_path).parent_path();
  std::vector<std::string> loaded;
  for (Image& im : rig.images) {
    if (!im.bytes.empty() || im.name.empty()) continue;
    std::string why = ReadImageFile(FindBeside(dir, im.name), im);
    if (why == "no such file") why = "no such file in the model's folder";
    for (Warning& w : rig.load_warnings) {
      if (w.code == "texture_not_loaded" && w.shape == im.name)
        w.message = "texture '" + im.name + "' is not read: " + why;
    }
    if (!why.empty()) continue;
    loaded.push_back(im.name);
  }
  std::erase_if(rig.load_warnings, [&](const Warning& w) {
    return w.code == "texture_not_loaded" &&
           std::find(loaded.begin(), loaded.end(), w.shape) != loaded.end();
  });
}

Result<Rig> LoadRigFile(const std::string& path, const LoadOptions& options) {
  RigFormat format = RigFormat::kGltf;
  const bool known = RigFormatFromPath(path, &format);
  // A single .obj is a rig without shapes; a name we do not know is tried as glTF (by its content).
  Result<Rig> rig = EndsWith(path, ".obj") ? LoadObjSequence(std::span<const std::string>(&path, 1))
                    : known                ? Entry(format).load_file(path, options)
                                           : LoadGltfFile(path, options);
  if (!rig.ok()) return rig;
  if (rig->name.empty()) rig->name = Stem(path);
  if (options.read_manifest) {
    const size_t dot = path.rfind('.');
    const std::string manifest =
        (dot == std::string::npos ? path : path.substr(0, dot)) + ".manifest.json";
    std::ifstream f(manifest, std::ios::binary);
    if (f) {
      std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
      if (Status s = ApplyManifest(rig.value(), text); !s.ok()) {
        return Prefixed(s, manifest + ": ");
      }
    }
  }
  DeriveFace(rig.value());  // The presets the manifest left out, from the shapes' names.
  return rig;
}

}  // namespace facespace::formats
