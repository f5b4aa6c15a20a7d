// facespace mirror and facespace compress: tools that keep a face space small and whole.
#include <charconv>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "facespace/core/basis.h"
#include "facespace/core/blend.h"
#include "facespace/core/io.h"
#include "facespace/core/shape_tools.h"

namespace facespace::cli {

namespace {

const char kMirrorUsage[] =
    "usage: facespace mirror RIG SHAPE [--as NAME] [--axis x|y|z] [--tolerance T] -o OUT.glb\n"
    "  adds the mirror image of SHAPE (reflected across the middle plane of its mesh) as NAME\n"
    "  (default: SHAPE's left/right counterpart name, e.g. mouthSmile_L -> mouthSmile_R) and\n"
    "  writes the rig, every shape kept as a sparse morph target.\n";

int AxisOf(const std::string& a) { return a == "x" ? 0 : a == "y" ? 1 : a == "z" ? 2 : -1; }

}  // namespace

int Mirror(const std::vector<std::string>& args) {
  std::vector<std::string> positional;
  std::string as, out;
  DeriveOptions d;
  d.mirror = true;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "-h" || a == "--help") {
      std::fputs(kMirrorUsage, stdout);
      return 0;
    }
    if (a.rfind("--", 0) != 0 && a != "-o") {
      positional.push_back(a);
      continue;
    }
    if (i + 1 >= args.size()) {
      std::fprintf(stderr, "error: %s needs a value\n%s", a.c_str(), kMirrorUsage);
      return 2;
    }
    const std::string v = args[++i];
    if (a == "--as") as = v;
    else if (a == "-o" || a == "--output") out = v;
    else if (a == "--axis") {
      d.axis = AxisOf(v);
      if (d.axis < 0) {
        std::fprintf(stderr, "error: --axis must be x, y or z\n");
        return 2;
      }
    } else if (a == "--tolerance") {
      auto r = std::from_chars(v.data(), v.data() + v.size(), d.tolerance);
      if (r.ec != std::errc() || d.tolerance <= 0) {
        std::fprintf(stderr, "error: --tolerance must be a positive number (relative to the bounding-box diagonal)\n");
        return 2;
      }
    } else {
      std::fprintf(stderr, "error: unknown option '%s'\n%s", a.c_str(), kMirrorUsage);
      return 2;
    }
  }
  if (positional.size() != 2 || out.empty()) {
    std::fprintf(stderr, "error: %s\n%s", out.empty() ? "no output given (-o OUT.glb)" : "give RIG and SHAPE", kMirrorUsage);
    return 2;
  }
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
  if (r->unmatched) std::fprintf(stderr, "warning: mirror_unmatched: %zu moved vertices have no mirror image and stay still\n", r->unmatched);
  const Rig& result = rig.value();
  std::vector<float> weights(result.shapes.size(), 0.0f);
  for (size_t s = 0; s < weights.size(); ++s) weights[s] = result.shapes[s].default_weight;
  BlendedRig blended;
  BlendContext context;
  if (Status s = EvaluateRig(result, weights, {}, blended, context); !s.ok()) {
    PrintStatus(s);
    return 1;
  }
  ExportOptions eo;
  eo.keep_targets = true;
  if (int rc = WriteResult(out, ExportMesh(result, blended, weights, {}, MeshFormat::kGlb, eo))) return rc;
  std::fprintf(stderr, "mirror: '%s' -> '%s' (%zu vertices moved, %zu unmatched), %zu shapes in %s\n", shape.c_str(), as.c_str(),
               r->vertices_moved, r->unmatched, result.shapes.size(), out.c_str());
  return 0;
}

}  // namespace facespace::cli

namespace facespace::cli {

int Compress(const std::vector<std::string>& args) {
  static const char kUsage[] =
      "usage: facespace compress RIG [--error E] [--bits 8..16] [--json]\n"
      "  E: the largest vertex error allowed, relative to the bounding-box diagonal (default 0.001)\n";
  std::vector<std::string> paths;
  double error = 1e-3;
  int bits = 16;
  bool as_json = false;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--json") {
      as_json = true;
    } else if (a == "--error" || a == "--bits") {
      if (i + 1 >= args.size()) {
        std::fprintf(stderr, "error: %s needs a value\n%s", a.c_str(), kUsage);
        return 2;
      }
      const std::string v = args[++i];
      double d = 0;
      auto r = std::from_chars(v.data(), v.data() + v.size(), d);
      if (r.ec != std::errc() || r.ptr != v.data() + v.size() || (a == "--error" ? !(d >= 0 && d < 1) : !(d >= 8 && d <= 16))) {
        std::fprintf(stderr, "error: %s must be %s, not '%s'\n", a.c_str(), a == "--error" ? "in [0, 1)" : "8..16", v.c_str());
        return 2;
      }
      if (a == "--error") error = d;
      else bits = static_cast<int>(d);
    } else if (a.rfind("-", 0) == 0) {
      std::fprintf(stderr, "error: unknown option '%s'\n%s", a.c_str(), kUsage);
      return 2;
    } else {
      paths.push_back(a);
    }
  }
  if (paths.empty()) {
    std::fputs(kUsage, stderr);
    return 2;
  }
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
  if (as_json) {
    nlohmann::json j = {{"shapes", b.shapes},
                        {"moved_vertices", b.moved_vertices},
                        {"diagonal", b.diagonal},
                        {"pca", {{"error_bound", error * b.diagonal}, {"components", b.components}, {"max_error", b.max_error},
                                 {"rms_error", b.rms_error}, {"energy_kept", b.energy_kept}, {"bytes", b.basis_bytes}}},
                        {"sparse_bytes", b.sparse_bytes},
                        {"dense_bytes", b.dense_bytes},
                        {"quantized", {{"bits", q.bits}, {"max_error", q.max_error}, {"bytes", q.bytes}}}};
    std::printf("%s\n", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
    return 0;
  }
  std::printf("shapes          %zu over %zu moved vertices (bounding-box diagonal %.6g)\n", b.shapes, b.moved_vertices, b.diagonal);
  std::printf("stored (sparse) %zu bytes; dense would be %zu bytes\n", b.sparse_bytes, b.dense_bytes);
  std::printf("PCA basis       %zu of %zu components keep every vertex within %.3g (%.3g%% of the diagonal): max %.4g, rms %.4g,\n"
              "                %.4f%% of the energy; %zu bytes (%.1f%% of sparse)\n",
              b.components, b.shapes, error * b.diagonal, error * 100, b.max_error, b.rms_error, b.energy_kept * 100, b.basis_bytes,
              100.0 * b.basis_bytes / std::max<size_t>(b.sparse_bytes, 1));
  std::printf("quantised       %d-bit displacements: max error %.4g (%.3g%% of the diagonal), %zu bytes (%.1f%% of sparse)\n", q.bits,
              q.max_error, 100.0 * q.max_error / std::max(b.diagonal, 1e-30), q.bytes, 100.0 * q.bytes / std::max<size_t>(b.sparse_bytes, 1));
  return 0;
}

}  // namespace facespace::cli

namespace facespace::cli {

int Convert(const std::vector<std::string>& args) {
  static const char kUsage[] =
      "usage: facespace convert RIG [SHAPE.obj ...] [--targets DIR ... [--modifiers modeling_modifiers.json]\n"
      "         [--groups body,helper-...|*] [--metres]] -o OUT.glb\n"
      "  writes any rig we read (glTF, an OBJ sequence, a MakeHuman base.obj with --targets) as a .glb with\n"
      "  sparse morph targets, and OUT.manifest.json beside it (groups, ranges, partners, controls).\n";
  std::vector<std::string> paths;
  std::vector<std::string> targets;
  std::string out;
  MakeHumanOptions mh;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "-h" || a == "--help") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (a == "--metres" || a == "--meters") {
      mh.metres = true;
      continue;
    }
    if (a.rfind("--", 0) != 0 && a != "-o") {
      paths.push_back(a);
      continue;
    }
    if (i + 1 >= args.size()) {
      std::fprintf(stderr, "error: %s needs a value\n%s", a.c_str(), kUsage);
      return 2;
    }
    const std::string v = args[++i];
    if (a == "--targets") targets.push_back(v);
    else if (a == "--modifiers") mh.modifiers = v;
    else if (a == "--groups") mh.groups = SplitList(v); else if (a == "-o" || a == "--output") out = v;
    else {
      std::fprintf(stderr, "error: unknown option '%s'\n%s", a.c_str(), kUsage);
      return 2;
    }
  }
  if (paths.empty() || out.empty() || (!mh.modifiers.empty() && targets.empty())) {
    std::fprintf(stderr, "error: %s\n%s", paths.empty() ? "no rig given" : out.empty() ? "no output given (-o OUT.glb)" : "--modifiers needs --targets", kUsage);
    return 2;
  }
  Result<Rig> rig = targets.empty() ? LoadAndReport(paths) : LoadMakeHuman(paths[0], targets, mh);
  if (!rig.ok()) {
    if (!targets.empty()) PrintStatus(rig.status());
    return 1;
  }
  if (!targets.empty()) PrintWarnings(rig->load_warnings);
  const size_t slash = out.find_last_of('/');
  const std::string stem = out.substr(slash == std::string::npos ? 0 : slash + 1, out.rfind('.') - (slash == std::string::npos ? 0 : slash + 1));
  if (rig->name.empty() || !targets.empty()) rig->name = stem;
  std::vector<float> weights(rig->shapes.size(), 0.0f);
  for (size_t s = 0; s < weights.size(); ++s) weights[s] = rig->shapes[s].default_weight;
  BlendedRig blended;
  BlendContext context;
  if (Status s = EvaluateRig(rig.value(), weights, {}, blended, context); !s.ok()) {
    PrintStatus(s);
    return 1;
  }
  ExportOptions eo;
  eo.keep_targets = true;
  auto bytes = ExportMesh(rig.value(), blended, weights, {}, MeshFormat::kGlb, eo);
  if (!bytes.ok()) {
    PrintStatus(bytes.status());
    return 1;
  }
  const std::string manifest_path = out.substr(0, out.rfind('.')) + ".manifest.json";
  if (!WriteOutput(out, bytes.value()) || !WriteOutput(manifest_path, ManifestJson(rig.value()))) {
    std::fprintf(stderr, "error: cannot write '%s'\n", out.c_str());
    return 1;
  }
  size_t moved = 0;
  for (const Shape& s : rig->shapes) moved += s.vertices_moved;
  std::fprintf(stderr, "convert: %zu vertices, %zu triangles, %zu shapes (%zu moved vertices), %zu controls -> %s (%zu bytes), %s\n",
               rig->vertex_count(), rig->triangle_count(), rig->shapes.size(), moved, rig->controls.size(), out.c_str(),
               bytes->size(), manifest_path.c_str());
  return 0;
}

}  // namespace facespace::cli
