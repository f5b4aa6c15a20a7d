// facespace mirror and facespace compress: tools that keep a face space small and whole.
#include <charconv>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "commands/cli.h"
#include "commands/flags.h"
#include "facespace/engine/basis.h"
#include "facespace/engine/shape_tools.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/formats/io.h"

namespace facespace::cli {

namespace {

int AxisOf(const std::string& a) { return a == "x" ? 0 : a == "y" ? 1 : a == "z" ? 2 : -1; }

}  // namespace

// The rig itself as glb (every shape a sparse morph target), its default weights as the mesh's.
Result<std::string> RigAsGlb(const std::shared_ptr<const evaluator::StoredRig>& rig) {
  return evaluator::RigGlb(evaluator::Evaluator(), rig);
}

namespace {

// Whether a rig file is a glb whose JSON names EXT_meshopt_compression (its JSON chunk only).
bool UsesMeshopt(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  unsigned char head[20];
  if (!f.read(reinterpret_cast<char*>(head), 20) || std::memcmp(head, "glTF", 4) != 0) return false;
  uint32_t json_len = 0;
  std::memcpy(&json_len, head + 12, 4);
  std::string text(std::min<uint32_t>(json_len, 64u << 20), '\0');
  f.read(text.data(), static_cast<std::streamsize>(text.size()));
  return text.find("\"EXT_meshopt_compression\"") != std::string::npos;
}

// --compress meshopt|none, and the default: as the input had it.
void CompressFlag(Flags& flags, int& mode) {
  flags.Value(
      "--compress", "meshopt|none",
      "EXT_meshopt_compression (lossless) on the written glb (default: as the input glb has it)",
      [&mode](const std::string& v) {
        if (v != "meshopt" && v != "none")
          return std::fprintf(stderr, "error: --compress must be meshopt or none, not '%s'\n",
                              v.c_str()),
                 2;
        mode = v == "meshopt" ? 1 : 0;
        return 0;
      });
}

// The glb, compressed when `mode` says (-1: when `input` was).
Result<std::string> MaybeCompress(Result<std::string> glb, int mode, const std::string& input) {
  if (!glb.ok() || mode == 0 || (mode < 0 && !UsesMeshopt(input))) return glb;
  const auto& s = glb.value();
  auto packed = formats::EncodeMeshoptGlb(
      std::span<const unsigned char>(reinterpret_cast<const unsigned char*>(s.data()), s.size()));
  if (!packed.ok()) return packed.status();
  return std::string(packed->begin(), packed->end());
}

}  // namespace

int Mirror(const std::vector<std::string>& args) {
  std::vector<std::string> positional;
  std::string as, out;
  DeriveOptions d;
  d.mirror = true;
  Flags flags(
      "usage: facespace mirror RIG SHAPE [--as NAME] [--axis x|y|z] [--tolerance T] -o OUT.glb\n",
      "Adds the mirror image of SHAPE (reflected across the middle plane of its mesh) as NAME "
      "(default:\n"
      "SHAPE's left/right counterpart name, e.g. mouthSmile_L -> mouthSmile_R) and writes the rig, "
      "every\n"
      "shape kept as a sparse morph target, with OUT.manifest.json beside it (name, credit, "
      "groups, ranges).\n");
  flags.Text("--as", "NAME", "the new shape's name", &as);
  flags.Value(
      "--axis", "x|y|z", "the axis across which to mirror (default x)", [&d](const std::string& v) {
        d.axis = AxisOf(v);
        return d.axis >= 0 ? 0 : (std::fprintf(stderr, "error: --axis must be x, y or z\n"), 2);
      });
  flags.Value(
      "--tolerance", "T",
      "how far a mirrored vertex may be from its match, relative to the bounding-box diagonal",
      [&d](const std::string& v) {
        double t = 0;
        if (!NumberIn("--tolerance", v, 1e-12, 1, &t)) return 2;
        d.tolerance = static_cast<float>(t);
        return 0;
      });
  int compress = -1;
  CompressFlag(flags, compress);
  flags.Text("-o, --output", "OUT.glb", "output", &out);
  if (int rc = flags.Parse(args, positional); rc >= 0) return rc;
  if (positional.size() != 2 || out.empty())
    return flags.UsageError(out.empty() ? "no output given (-o OUT.glb)" : "give RIG and SHAPE");
  Result<Rig> rig = LoadAndReport({positional[0]});
  if (!rig.ok()) return 1;
  const std::string& shape = positional[1];
  if (as.empty()) as = CounterpartName(shape);
  if (as.empty() || FindShape(rig.value(), as) >= 0) as = shape + "_mirror";
  auto r = DeriveShape(rig.value(), as, shape, d);
  if (!r.ok()) {
    PrintStatus(r.status());
    return 1;
  }
  if (r->unmatched)
    PrintWarnings(
        {{"mirror_unmatched",
          std::to_string(r->unmatched) + " moved vertices have no mirror image and stay still", as,
          0.0, false}});
  const auto stored = evaluator::Unstored(std::move(rig.value()));
  const Rig& result = stored->rig;
  auto glb = MaybeCompress(RigAsGlb(stored), compress, positional[0]);
  if (!glb.ok()) {
    PrintStatus(glb.status());
    return 1;
  }
  if (int rc = WriteResult(out, glb.value())) return rc;
  // The manifest beside it, as convert writes one: the rig's name, credit, groups, ranges and
  // partners (the new shape's group and range are its source's) come back with the glb.
  const std::string manifest_path = out.substr(0, out.rfind('.')) + ".manifest.json";
  if (int rc = WriteResult(manifest_path, formats::ManifestJson(result))) return rc;
  std::fprintf(stderr,
               "mirror: '%s' -> '%s' (%zu vertices moved, %zu unmatched), %zu shapes in %s (%zu "
               "bytes) and %s\n",
               shape.c_str(), as.c_str(), r->vertices_moved, r->unmatched, result.shapes.size(),
               out.c_str(), glb->size(), manifest_path.c_str());
  return 0;
}

}  // namespace facespace::cli

namespace facespace::cli {

namespace {

// "418 KB = 418320 bytes": a size people read at a glance, and exactly.
std::string Bytes(size_t n) {
  char s[64];
  if (n < 10000)
    std::snprintf(s, sizeof s, "%zu bytes", n);
  else if (n < 1000000)
    std::snprintf(s, sizeof s, "%.0f KB = %zu bytes", n / 1e3, n);
  else
    std::snprintf(s, sizeof s, "%.2f MB = %zu bytes", n / 1e6, n);
  return s;
}

}  // namespace

int Compress(const std::vector<std::string>& args) {
  std::vector<std::string> paths;
  double error = 1e-3;
  int bits = 16;
  bool as_json = false;
  Flags flags("usage: facespace compress RIG [--error E] [--bits 8..16] [--json]\n",
              "An orthogonal (PCA) basis of the shapes within an error bound, and quantised "
              "displacements: sizes\n"
              "and errors.\n");
  flags.Value(
      "--error", "E",
      "the largest vertex error allowed, relative to the bounding-box diagonal (default 0.001)",
      [&error](const std::string& v) {
        return NumberIn("--error", v, 0, 0.999999, &error) ? 0 : 2;
      });
  flags.Value("--bits", "8..16", "bits per quantised displacement (default 16)",
              [&bits](const std::string& v) {
                long long n = 0;
                if (!IntIn("--bits", v, 8, 16, &n)) return 2;
                bits = static_cast<int>(n);
                return 0;
              });
  flags.Switch("--json", "machine-readable output", [&] { as_json = true; });
  if (int rc = flags.Parse(args, paths); rc >= 0) return rc;
  if (paths.empty()) return flags.UsageError("no rig given");
  Result<Rig> rig = LoadAndReport(paths);
  if (!rig.ok()) return 1;
  BasisReport b;
  // The bound is relative; the diagonal comes from a first report.
  CompressShapes(rig.value(), 1e300, &b);
  auto basis = CompressShapes(rig.value(), error * b.diagonal, &b);
  if (!basis.ok()) {
    PrintStatus(basis.status());
    return 1;
  }
  const QuantizeReport q = QuantizeDisplacements(rig.value(), bits, nullptr);
  // Lengths as the scene shows them (glTF's metres): the shapes live in their meshes' own space,
  // which a node may scale (FaceCap's head: 1e-5). The scale of the first mesh with shapes.
  double to_scene = 1.0;
  const auto world = PrimitiveWorldMatrices(rig.value());
  for (size_t p = 0; p < rig->primitives.size(); ++p) {
    if (rig->primitives[p].targets.empty()) continue;
    const auto& m = world[p];
    const double det = m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) +
                       m[8] * (m[1] * m[6] - m[5] * m[2]);
    if (std::isfinite(det) && det != 0.0) to_scene = std::cbrt(std::abs(det));
    break;
  }
  if (as_json) {  // Lengths in the shapes' mesh space; scene_scale takes them to the scene's.
    nlohmann::json j = {
        {"shapes", b.shapes},
        {"moved_vertices", b.moved_vertices},
        {"diagonal", b.diagonal},
        {"scene_scale", to_scene},
        {"pca",
         {{"error_bound", error * b.diagonal},
          {"components", b.components},
          {"max_error", b.max_error},
          {"rms_error", b.rms_error},
          {"energy_kept", b.energy_kept},
          {"bytes", b.basis_bytes}}},
        {"sparse_bytes", b.sparse_bytes},
        {"dense_bytes", b.dense_bytes},
        {"quantized", {{"bits", q.bits}, {"max_error", q.max_error}, {"bytes", q.bytes}}}};
    std::printf("%s\n", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
    return 0;
  }
  const char* unit = "scene units (glTF's are metres)";
  auto len = [&](double v) {
    char s[32];
    std::snprintf(s, sizeof s, "%.3g", v * to_scene);
    return std::string(s);
  };
  std::printf("shapes          %zu over %zu moved vertices; bounding-box diagonal %s %s\n",
              b.shapes, b.moved_vertices, len(b.diagonal).c_str(), unit);
  if (std::abs(to_scene - 1.0) > 1e-6)
    std::printf(
        "                (the shapes' mesh is scaled by %.3g in the scene: lengths here are the "
        "scene's)\n",
        to_scene);
  std::printf("stored (sparse) %s; dense would be %s\n", Bytes(b.sparse_bytes).c_str(),
              Bytes(b.dense_bytes).c_str());
  std::printf(
      "PCA basis       %zu of %zu components keep every vertex within %s (%.3g%% of the diagonal): "
      "max %s, rms %s,\n"
      "                %.4f%% of the energy; %s, %.1f%% of sparse\n",
      b.components, b.shapes, len(error * b.diagonal).c_str(), error * 100,
      len(b.max_error).c_str(), len(b.rms_error).c_str(), b.energy_kept * 100,
      Bytes(b.basis_bytes).c_str(), 100.0 * b.basis_bytes / std::max<size_t>(b.sparse_bytes, 1));
  std::printf(
      "quantised       %d-bit displacements: max error %s (%.3g%% of the diagonal), %s, %.1f%% of "
      "sparse\n",
      q.bits, len(q.max_error).c_str(), 100.0 * q.max_error / std::max(b.diagonal, 1e-30),
      Bytes(q.bytes).c_str(), 100.0 * q.bytes / std::max<size_t>(b.sparse_bytes, 1));
  return 0;
}

}  // namespace facespace::cli

namespace facespace::cli {

int Convert(const std::vector<std::string>& args) {
  std::vector<std::string> paths;
  std::vector<std::string> targets;
  std::string out;
  formats::MakeHumanOptions mh;
  Flags flags(
      "usage: facespace convert RIG [SHAPE.obj ...] [--targets DIR ... [--modifiers "
      "modeling_modifiers.json]\n"
      "         [--groups body,helper-...|*] [--metres] [--proxy FILE.mhclo ...]] -o OUT.glb\n",
      "Writes any rig we read (glTF, an OBJ sequence, a MakeHuman base.obj with --targets) as a "
      ".glb with\n"
      "sparse morph targets, and OUT.manifest.json beside it (groups, ranges, partners, "
      "controls).\n");
  flags.Texts("--targets", "DIR", "a folder of MakeHuman .target files (repeatable)", &targets);
  flags.Text("--modifiers", "FILE", "MakeHuman's modeling_modifiers.json: controls, groups, ranges",
             &mh.modifiers);
  flags.Value("--groups", "G,...", "the MakeHuman groups of the base mesh to keep",
              [&mh](const std::string& v) {
                mh.groups = SplitList(v);
                return 0;
              });
  flags.Switch("--metres, --meters", "scale MakeHuman's decimetres to metres",
               [&] { mh.metres = true; });
  flags.Value("--proxy", "FILE.mhclo",
              "a MakeHuman proxy (eyes, teeth, ...) fitted to the base mesh and moved by every "
              "target (repeatable)",
              [&mh](const std::string& v) {
                mh.proxies.push_back(v);
                return 0;
              });
  int compress = -1;
  CompressFlag(flags, compress);
  flags.Text("-o, --output", "OUT.glb", "output", &out);
  if (int rc = flags.Parse(args, paths); rc >= 0) return rc;
  if (paths.empty() || out.empty() ||
      ((!mh.modifiers.empty() || !mh.proxies.empty()) && targets.empty())) {
    return flags.UsageError(paths.empty()           ? "no rig given"
                            : out.empty()           ? "no output given (-o OUT.glb)"
                            : !mh.modifiers.empty() ? "--modifiers needs --targets"
                                                    : "--proxy needs --targets");
  }
  Result<Rig> rig = targets.empty() ? LoadAndReport(paths) : LoadMakeHuman(paths[0], targets, mh);
  if (!rig.ok()) {
    if (!targets.empty()) PrintStatus(rig.status());
    return 1;
  }
  if (!targets.empty()) PrintWarnings(rig->load_warnings);
  const size_t slash = out.find_last_of('/');
  const std::string stem =
      out.substr(slash == std::string::npos ? 0 : slash + 1,
                 out.rfind('.') - (slash == std::string::npos ? 0 : slash + 1));
  if (rig->name.empty() || !targets.empty()) rig->name = stem;
  const auto stored = evaluator::Unstored(std::move(rig.value()));
  auto bytes = MaybeCompress(RigAsGlb(stored), compress, paths[0]);
  if (!bytes.ok()) {
    PrintStatus(bytes.status());
    return 1;
  }
  const std::string manifest_path = out.substr(0, out.rfind('.')) + ".manifest.json";
  if (!WriteOutput(out, bytes.value()) ||
      !WriteOutput(manifest_path, formats::ManifestJson(stored->rig))) {
    std::fprintf(stderr, "error: cannot write '%s'\n", out.c_str());
    return 1;
  }
  size_t moved = 0;
  for (const Shape& s : stored->rig.shapes) moved += s.vertices_moved;
  std::fprintf(stderr,
               "convert: %zu vertices, %zu triangles, %zu shapes (%zu moved vertices), %zu "
               "controls -> %s (%zu bytes), %s\n",
               stored->rig.vertex_count(), stored->rig.triangle_count(), stored->rig.shapes.size(),
               moved, stored->rig.controls.size(), out.c_str(), bytes->size(),
               manifest_path.c_str());
  return 0;
}

}  // namespace facespace::cli
