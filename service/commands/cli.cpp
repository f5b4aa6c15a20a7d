#include "commands/cli.h"

#include <unistd.h>

#include <charconv>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>

#include "commands/flags.h"
#include "facespace/engine/blend.h"
#include "facespace/engine/skeleton.h"
#include "facespace/engine/weights.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/formats/io.h"
#include "facespace/formats/lod.h"
#include "facespace/http/describe.h"
#include "facespace/offscreen/render.h"

namespace facespace::cli {

namespace {

bool EndsWith(const std::string& s, const char* t) {
  const size_t n = std::strlen(t);
  return s.size() >= n && s.compare(s.size() - n, n, t) == 0;
}

// The rig named by the positional arguments: one glTF file, or an OBJ sequence.
Result<Rig> LoadFromArgs(const std::vector<std::string>& paths) {
  if (paths.empty()) return InvalidArgument("no rig given");
  if (paths.size() > 1 || EndsWith(paths[0], ".obj") || EndsWith(paths[0], ".OBJ")) {
    for (const std::string& p : paths) {
      if (!EndsWith(p, ".obj") && !EndsWith(p, ".OBJ")) {
        return InvalidArgument("several rig files given, but '" + p +
                               "' is not an .obj (only OBJ sequences take several)");
      }
    }
    if (paths.size() == 1) return formats::LoadRigFile(paths[0]);
    return formats::LoadObjSequence(paths);
  }
  return formats::LoadRigFile(paths[0]);
}

}  // namespace

void PrintStatus(const Status& s) {
  // What the message adds after its fields (the names a client may use, listed once): a line of its
  // own.
  const size_t valid = s.message.find("; valid ");
  const std::string names = valid == std::string::npos ? "" : s.message.substr(valid + 2);
  if (s.fields.size() == 1 && !s.fields[0].pointer.empty() &&
      s.message.rfind(s.fields[0].pointer, 0) != 0) {
    std::fprintf(stderr, "error: %s: %s\n", s.fields[0].pointer.c_str(),
                 s.fields[0].message.c_str());
  } else if (s.fields.size() <= 1) {
    std::fprintf(stderr, "error: %s\n", s.message.c_str());
    return;
  } else {
    std::fprintf(stderr, "error: %zu problems\n", s.fields.size());
    for (const FieldError& f : s.fields)
      std::fprintf(stderr, "error: %s: %s\n", f.pointer.c_str(), f.message.c_str());
  }
  if (!names.empty()) std::fprintf(stderr, "%s\n", names.c_str());
}

void PrintWarnings(const std::vector<Warning>& warnings) {
  if (Quiet()) return;
  // A kind that comes more than once is one line, its first and how many more (Uka's 37 motions
  // that name bones she lacks are one line); --verbose prints each. In the order each kind first
  // came.
  std::map<std::string, size_t> count;
  for (const Warning& w : warnings) ++count[w.code];
  std::set<std::string> said;
  for (const Warning& w : warnings) {
    const size_t n = count[w.code];
    if (!Verbose() && n > 1 && !said.insert(w.code).second) continue;
    // The message of an extrapolation warning already names its code (after a "cell N: " or
    // "t=T: " prefix when it has one).
    const std::string line =
        w.message.find(w.code + ": ") != std::string::npos ? w.message : w.code + ": " + w.message;
    if (Verbose() || n == 1)
      std::fprintf(stderr, "warning: %s\n", line.c_str());
    else
      std::fprintf(stderr, "warning: %s (and %zu more %s warnings: --verbose lists them)\n",
                   line.c_str(), n - 1, w.code.c_str());
  }
}

// LoadFromArgs, with its error or load warnings on stderr.
Result<Rig> LoadAndReport(const std::vector<std::string>& paths) {
  Result<Rig> loaded = LoadFromArgs(paths);
  if (!loaded.ok())
    PrintStatus(loaded.status());
  else
    PrintWarnings(loaded->load_warnings);
  return loaded;
}

// Writes atomically: a temporary file beside the target, then rename.
bool WriteOutput(const std::string& path, const std::string& data) {
  if (path == "-")
    return std::fwrite(data.data(), 1, data.size(), stdout) == data.size() &&
           std::fflush(stdout) == 0;
  const std::string tmp = path + ".tmp" + std::to_string(getpid());
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f || !f.write(data.data(), static_cast<std::streamsize>(data.size())) || !f.flush()) {
      std::remove(tmp.c_str());
      return false;
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    return false;
  }
  return true;
}

int WriteResult(const std::string& path, const Result<std::string>& bytes) {
  if (!bytes.ok()) {
    PrintStatus(bytes.status());
    return 1;
  }
  if (!WriteOutput(path, bytes.value())) {
    std::fprintf(stderr, "error: cannot write '%s'\n", path.c_str());
    return 1;
  }
  return 0;
}

int Info(const std::vector<std::string>& args) {
  std::vector<std::string> paths;
  bool as_json = false;
  Flags flags("usage: facespace info RIG [SHAPE.obj ...] [--json]\n",
              "Shapes (names, groups, ranges, vertices moved, partners), meshes, skeleton and "
              "animations of a rig.\n");
  flags.Switch("--json", "machine-readable output", [&] { as_json = true; });
  if (int rc = flags.Parse(args, paths); rc >= 0) return rc;
  if (paths.empty()) return flags.UsageError("no rig given");
  Result<Rig> loaded = LoadAndReport(paths);
  if (!loaded.ok()) return 1;
  const Rig& rig = loaded.value();
  if (as_json) {  // The rig route's document (without the store's id and version).
    std::printf("%s\n", http::DescribeRig(rig)
                            .dump(2, ' ', false, nlohmann::json::error_handler_t::replace)
                            .c_str());
    return 0;
  }
  std::printf("rig        %s\n", rig.name.c_str());
  if (!rig.credit.empty()) std::printf("credit     %s\n", rig.credit.c_str());
  std::printf("vertices   %zu\ntriangles  %zu\nmeshes     %zu (%zu primitives)\n",
              rig.vertex_count(), rig.triangle_count(), rig.meshes.size(), rig.primitives.size());
  if (rig.skin_count)
    std::printf("skeleton   %zu skin(s), %zu joints\n", rig.skin_count, rig.joint_count);
  else
    std::printf("skeleton   none\n");
  for (size_t m = 0; m < rig.meshes.size(); ++m) {
    const Mesh& mesh = rig.meshes[m];
    size_t v = 0;
    for (int p : mesh.primitives) v += rig.primitives[p].vertex_count();
    std::printf("mesh %-3zu   %-20s %zu primitive(s), %zu vertices, %zu targets\n", m,
                mesh.name.empty() ? "(unnamed)" : mesh.name.c_str(), mesh.primitives.size(), v,
                mesh.target_shapes.size());
  }
  for (size_t a = 0; a < rig.animations.size(); ++a) {
    const AnimationInfo& an = rig.animations[a];
    std::printf("animation %-2zu %-20s %.3f s, %zu channel(s)%s\n", a,
                an.name.empty() ? "(unnamed)" : an.name.c_str(), an.duration, an.channels,
                an.has_weights ? ", morph weights" : "");
  }
  // Numbers for reading (4 significant digits: a float's 0.32136002 reads 0.3214); --json has them
  // whole.
  auto brief = [](float v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.4g", static_cast<double>(v));
    return std::string(b);
  };
  std::printf("shapes     %zu\n", rig.shapes.size());
  if (!rig.shapes.empty()) {
    std::printf("  %5s  %-28s %-12s %-14s %8s %7s  %s\n", "index", "name", "group", "range",
                "default", "moved", "partner");
  }
  for (size_t i = 0; i < rig.shapes.size(); ++i) {
    const Shape& s = rig.shapes[i];
    const std::string range = "[" + brief(s.min) + ", " + brief(s.max) + "]";
    std::printf("  %5zu  %-28s %-12s %-14s %8s %7zu  %s\n", i, s.name.c_str(), s.group.c_str(),
                range.c_str(), brief(s.default_weight).c_str(), s.vertices_moved,
                s.partner >= 0 ? rig.shapes[s.partner].name.c_str() : "-");
  }
  if (!rig.controls.empty()) {  // The rig's sliders (c.NAME=VALUE): each drives one or two shapes.
    std::printf("controls   %zu\n  %-40s %-10s %-10s %s\n", rig.controls.size(), "name", "group",
                "range", "shapes (below 0 | above 0)");
    for (const Control& c : rig.controls) {
      const std::string range = "[" + brief(c.min) + ", " + brief(c.max) + "]";
      const std::string shapes = (c.negative >= 0 ? rig.shapes[c.negative].name + " | " : "") +
                                 rig.shapes[c.positive].name;
      std::printf("  %-40s %-10s %-10s %s\n", c.name.c_str(), c.group.c_str(), range.c_str(),
                  shapes.c_str());
    }
  }
  return 0;
}

void AddBlendOptionFlags(Flags& flags, BlendOptions& options) {
  flags.Value("--mode", "relative|absolute", "how weights combine (default relative)",
              [&options](const std::string& v) {
                if (evaluator::ParseBlendMode(v, &options.mode)) return 0;
                return std::fprintf(stderr,
                                    "error: --mode must be relative or absolute, not '%s'\n",
                                    v.c_str()),
                       2;
              });
  flags.Value("--normals", "blend|recompute",
              "blend the shapes' normals, or recompute them (default blend)",
              [&options](const std::string& v) {
                if (evaluator::ParseNormalMode(v, &options.normals)) return 0;
                return std::fprintf(stderr,
                                    "error: --normals must be blend or recompute, not '%s'\n",
                                    v.c_str()),
                       2;
              });
}

namespace {

// The flags blend, render and sheet share: weights, controls, blend options and the skeleton.
void AddMeshFlags(Flags& flags, evaluator::MeshRequest& r, bool& weights_given) {
  auto pose_setting = [&r](const std::string& flag) {
    return [&r, flag](const std::string& value) {
      std::string v = value;
      if ((flag == "--pose" || flag == "--blend" || flag == "--layers") &&
          !ReadAtFile(flag, value, v))
        return 1;
      bool known = false;
      if (std::string e = evaluator::ApplyPoseSetting(flag.substr(2), v, r, &known); !e.empty()) {
        std::fprintf(stderr, "error: %s: %s\n", flag.c_str(), e.c_str());
        return 2;
      }
      return 0;
    };
  };
  auto weights_json = [](const std::string& flag, std::vector<WeightEntry>& into) {
    return [flag, &into](const std::string& value) {
      std::string text;
      if (!ReadAtFile(flag, value, text)) return 1;
      auto parsed = evaluator::ParseWeightsJson(text, flag);
      if (!parsed.ok()) {
        PrintStatus(parsed.status());
        return 1;
      }
      into.insert(into.end(), parsed->begin(), parsed->end());
      return 0;
    };
  };
  auto weights = weights_json("--weights", r.weights);
  flags.Value("--weights", "JSON|@FILE",
              "weights: [0.5, 0, 1] in shape order, or {\"jawOpen\": 0.5}",
              [&weights_given, weights](const std::string& value) {
                if (weights_given) return std::fprintf(stderr, "error: --weights given twice\n"), 2;
                weights_given = true;
                return weights(value);
              });
  // NAME=VALUE, repeatable, into `into` (a shape's weight, an expression's value); `metavar` names
  // it in errors.
  auto name_value = [](const std::string& flag, const std::string& metavar,
                       std::vector<WeightEntry>& into) {
    return [flag, metavar, &into](const std::string& v) {
      const size_t eq = v.rfind('=');
      if (eq == std::string::npos || eq == 0)
        return std::fprintf(stderr, "error: %s takes %s, got '%s'\n", flag.c_str(), metavar.c_str(),
                            v.c_str()),
               2;
      WeightEntry e;
      e.name = v.substr(0, eq);
      e.pointer = flag + " " + e.name;
      const std::string num = v.substr(eq + 1);
      auto res = std::from_chars(num.data(), num.data() + num.size(), e.value);
      if (res.ec != std::errc() || res.ptr != num.data() + num.size()) {
        return std::fprintf(stderr, "error: %s %s: '%s' is not a number\n", flag.c_str(),
                            e.name.c_str(), num.c_str()),
               1;
      }
      into.push_back(e);
      return 0;
    };
  };
  flags.Value("--set", "NAME=W", "one weight, by shape name, alias or index (repeatable)",
              name_value("--set", "NAME=W", r.weights));
  flags.Value("--controls", "JSON|@FILE",
              "control values, {\"nose/nose-trans-down|up\": -0.4} (rigs with controls)",
              weights_json("--controls", r.controls));
  flags.Value("--expression", "NAME=V",
              "an expression by name: VRM's happy, aa, blink, lookLeft, ... or the rig's own "
              "(repeatable; GET /v1/rigs/ID lists them)",
              name_value("--expression", "NAME=V", r.pose.expressions));
  flags.Value("--gaze", "YAW,PITCH|X,Y,Z|JSON",
              "where the eyes look: degrees (yaw > 0 to the character's left, pitch > 0 up), or a "
              "point of the rig's world",
              pose_setting("--gaze"));
  AddBlendOptionFlags(flags, r.options);
  flags.Value("--pose", "JSON|@FILE",
              "joint rotations, translations, scales: {\"JOINT\": {\"euler\": [x, y, z]}}",
              pose_setting("--pose"));
  flags.Value("--animation", "NAME|INDEX", "a clip of the rig, sampled at --time",
              pose_setting("--animation"));
  flags.Value("--time", "SECONDS", "the time in --animation (default 0)", pose_setting("--time"));
  flags.Value("--motion", "NAME|INDEX",
              "a clip by its MMD word: a .vmd motion of a PMX/PMD rig (as --animation)",
              pose_setting("--motion"));
  flags.Value("--frame", "N", "the time in MMD frames, 30 a second (instead of --time)",
              pose_setting("--frame"));
  flags.Switch("--loop", "wrap --time around the clip", [&r] {
    bool known = false;
    evaluator::ApplyPoseSetting("loop", "true", r, &known);
  });
  flags.Value("--blend", "JSON|@FILE",
              "several clips blended: [{\"animation\", \"time\", \"weight\", \"mask\"}]",
              pose_setting("--blend"));
  flags.Value("--layers", "JSON|@FILE",
              "motions stacked: a base, then overlays replacing what they move: [{\"motion\", "
              "\"frame\", \"weight\", \"fade_in\"}]",
              pose_setting("--layers"));
  flags.Value("--skinning", "linear|dual_quaternion", "skinning method (default linear)",
              pose_setting("--skinning"));
  flags.Value("--lod", "0-4",
              "level of detail: about 1/2^L of the triangles (default 0: the whole mesh)",
              pose_setting("--lod"));
}

// Says what the level of detail `lod` of `rig` kept (0: nothing to say); false (reported) when it
// cannot be made.
bool ReportLod(const evaluator::Evaluator& evaluator,
               const std::shared_ptr<const evaluator::StoredRig>& rig, int lod) {
  if (lod == 0) return true;
  const auto derived = evaluator.Derived(rig, lod);
  if (!derived) {
    std::fprintf(stderr, "error: the level of detail %d cannot be made\n", lod);
    return false;
  }
  const Rig& at = *derived->rig;
  std::fprintf(stderr, "lod %d: %zu of %zu triangles, %zu of %zu vertices\n", lod,
               at.triangle_count(), rig->rig.triangle_count(), at.vertex_count(),
               rig->rig.vertex_count());
  return true;
}

// A pipeline result: its warnings on stderr, then its bytes to `path` (WriteResult's exit code).
int WriteProduced(const std::string& path, Result<evaluator::Output> out) {
  if (!out.ok()) return WriteResult(path, out.status());
  PrintWarnings(out->warnings);
  return WriteResult(path, std::move(out->bytes));
}

// The image format from --format or the output's extension (PNG for stdout).
bool ImageFormatFor(const std::string& out_path, const std::string& format_name,
                    picture::ImageFormat* format) {
  if (!format_name.empty()) return picture::ParseImageFormat(format_name, format);
  if (out_path == "-") {
    *format = picture::ImageFormat::kPng;
    return true;
  }
  const size_t dot = out_path.rfind('.');
  return dot != std::string::npos && picture::ParseImageFormat(out_path.substr(dot + 1), format);
}

}  // namespace

int Blend(const std::vector<std::string>& args) {
  std::vector<std::string> paths;
  std::string out_path, format_name;
  bool weights_given = false;
  evaluator::MeshRequest request;
  Flags flags(
      "usage: facespace blend RIG [SHAPE.obj ...] [weights, pose and blend flags] [--format "
      "glb|obj|json|f32|vrm|vrm0] -o OUT\n",
      "The blended mesh. The format comes from OUT's extension or --format; -o - writes to "
      "stdout.\n"
      "RIG is any rig we read, told by its bytes: glTF 2.0 (.glb, .gltf), FBX (.fbx, binary or "
      "ASCII),\n"
      "COLLADA (.dae), Doom 3 MD5 (.md5mesh, with the .md5anim files beside it), MikuMikuDance "
      "(.pmx,\n"
      ".pmd, with the .vmd motions beside it or in motion/), or an OBJ sequence: a .obj file\n"
      "followed by more .obj files (the first is the base, each other one a shape named after its "
      "file).\n"
      "A manifest (RIG's name with .manifest.json) beside it is read too. MakeHuman's base.obj "
      "and\n"
      ".target folders become a rig with facespace convert.\n");
  AddMeshFlags(flags, request, weights_given);
  flags.Switch("--keep-targets",
               "glb: keep the rig's morph targets, with these weights as defaults",
               [&] { request.keep_targets = true; });
  flags.Value("--space", "world|mesh",
              "json, obj, f32: world space (default) or each mesh's own, before its node",
              [&request](const std::string& v) {
                if (v != "world" && v != "mesh")
                  return std::fprintf(stderr, "error: --space must be world or mesh, not '%s'\n",
                                      v.c_str()),
                         2;
                request.mesh_space = v == "mesh";
                return 0;
              });
  flags.Text("--format", "glb|obj|json|f32|vrm|vrm0",
             "output format (default: from OUT's extension; vrm: a VRM 1.0 avatar of a humanoid "
             "rig, vrm0: VRM 0.x, named .vrm too)",
             &format_name);
  flags.Text("-o, --output", "OUT", "output file, or - for stdout", &out_path);
  if (int rc = flags.Parse(args, paths); rc >= 0) return rc;
  if (paths.empty() || out_path.empty())
    return flags.UsageError(paths.empty() ? "no rig given" : "no output given (-o OUT or -o -)");
  formats::MeshFormat format = formats::MeshFormat::kJson;
  if (!format_name.empty()) {
    if (!ParseMeshFormat(format_name, &format)) {
      std::fprintf(stderr, "error: --format must be glb, obj, json, f32, vrm or vrm0, not '%s'\n",
                   format_name.c_str());
      return 2;
    }
    const size_t dot = out_path.rfind('.');
    const bool vrm0_as_vrm = format == formats::MeshFormat::kVrm0 && out_path.ends_with(".vrm");
    if (formats::MeshFormat named; out_path != "-" && dot != std::string::npos &&
                                   ParseMeshFormat(out_path.substr(dot + 1), &named) &&
                                   named != format && !vrm0_as_vrm) {
      std::fprintf(
          stderr,
          "error: --format %s does not match the output name '%s': name it .%s, or drop --format\n",
          format_name.c_str(), out_path.c_str(), MeshFormatName(format));
      return 2;
    }
  } else if (out_path != "-") {
    const size_t dot = out_path.rfind('.');
    const std::string ext = dot == std::string::npos ? "" : out_path.substr(dot + 1);
    if (!ParseMeshFormat(ext, &format)) {
      std::fprintf(
          stderr,
          "error: cannot tell the format from '%s': use .glb, .obj, .json, .f32 or --format\n",
          out_path.c_str());
      return 2;
    }
  }

  Result<Rig> loaded = LoadAndReport(paths);
  if (!loaded.ok()) return 1;
  const auto rig = evaluator::Unstored(std::move(loaded.value()));
  // A VRM's meta carries a thumbnail of the face: the evaluator draws it.
  const bool avatar = format == formats::MeshFormat::kVrm || format == formats::MeshFormat::kVrm0;
  std::optional<offscreen::OsMesaRenderer> renderer;
  if (avatar) renderer.emplace(1);
  const evaluator::Evaluator evaluator =
      avatar ? evaluator::Evaluator(*renderer) : evaluator::Evaluator();
  if (!ReportLod(evaluator, rig, request.lod)) return 1;
  if (std::string e = evaluator::FinishPoseSettings(request); !e.empty()) {
    std::fprintf(stderr, "error: --animation: %s\n", e.c_str());
    return 2;
  }
  evaluator::Workspace ws;
  return WriteProduced(out_path, evaluator::ProduceMesh(evaluator, rig, request, format, ws));
}

namespace {

// The render settings (evaluator::ApplyRenderSetting) as flags, each with its values and default.
void AddRenderFlags(Flags& flags, evaluator::RenderRequest& r, bool sheet) {
  const std::string size = sheet ? "a cell's " : "the image's ";
  const std::string size_default = sheet ? " (default 256)" : " (default 512)";
  const std::tuple<const char*, const char*, std::string> kSettings[] = {
      {"view", "shaded|wireframe|heatmap|normals|clay",
       "what is drawn: the materials lit, edges over them, displacement as colour, normals, grey "
       "clay (default shaded)"},
      {"width", "PIXELS", size + "width, 1-8192" + size_default},
      {"height", "PIXELS", size + "height, 1-8192" + size_default},
      {"camera", "JSON",
       "the camera as one object: {\"yaw\", \"pitch\", \"zoom\", \"distance\", \"fov\", \"frame\": "
       "\"auto|all|shapes|joint:NAME\"}, "
       "or a look-at {\"eye\": [x,y,z], \"target\": [x,y,z], \"up\": [x,y,z]}; frame auto "
       "(default) shows the face where the shapes act on a small part"},
      {"yaw", "DEGREES", "turn around the vertical axis; 0 looks at the front (default 0)"},
      {"pitch", "DEGREES", "look from above (positive) or below, in degrees (default 0)"},
      {"zoom", "Z", "divides the distance, 0.01-100: 2 is twice as close (default 1)"},
      {"distance", "D",
       "from the framed centre, in the rig's units (default: the framed part fills the image)"},
      {"fov", "DEGREES", "vertical field of view, 1-170 (default 30)"},
      {"background", "#rrggbb|transparent", "the colour behind the model (default #dbdee3)"},
      {"supersample", "1-4", "render N x N larger and filter down, for smoother edges (default 1)"},
      {"quality", "1-100", "JPEG and WebP quality; WebP 100 is lossless (default 90)"},
      {"exposure", "STOPS", "brighter (positive) or darker, in stops (default 0)"}};
  for (const auto& [key, metavar, help] : kSettings) {
    const std::string flag = std::string("--") + key;
    flags.Value(flag, metavar, help, [&r, key = std::string(key), flag](const std::string& v) {
      bool known = false;
      if (std::string e = evaluator::ApplyRenderSetting(key, v, r, &known); !e.empty()) {
        std::fprintf(stderr, "error: %s: %s\n", flag.c_str(), e.c_str());
        return 2;
      }
      return 0;
    });
  }
}

}  // namespace

int Render(const std::vector<std::string>& args, bool sheet) {
  std::vector<std::string> paths;
  evaluator::RenderRequest r;
  std::string out_path, format_name, cells_text;
  int columns = 4;
  bool weights_given = false;
  if (sheet) r.render.width = r.render.height = 256;
  Flags flags(
      sheet ? "usage: facespace sheet RIG --cells JSON|@FILE|shapes[:GROUP] [--columns N] [render "
              "flags] -o OUT\n"
            : "usage: facespace render RIG [weights, pose and render flags] [--format "
              "png|jpeg|exr|tiff|webp] -o OUT\n",
      sheet ? "A labelled contact sheet: one render per cell. Cells: a JSON array, or JSON lines, "
              "of\n"
              "{\"weights\": ..., \"label\": \"...\"}; or \"shapes\" (one cell per shape at 1), "
              "\"shapes:GROUP\" (those of a group).\n"
            : "An offscreen render (OSMesa). The format comes from OUT's extension or --format.\n");
  AddMeshFlags(flags, r.mesh, weights_given);
  AddRenderFlags(flags, r, sheet);
  if (sheet) {
    flags.Value("--cells", "JSON|@FILE|shapes[:GROUP]",
                "the cells; shapes: one per shape (of GROUP) at 1",
                [&cells_text](const std::string& v) {
                  return ReadAtFile("--cells", v, cells_text) ? 0 : 1;
                });
    flags.Value("--columns", "N", "cells per row (default 4)", [&columns](const std::string& v) {
      long long n = 0;
      if (!IntIn("--columns", v, 1, 64, &n)) return 2;
      columns = static_cast<int>(n);
      return 0;
    });
  }
  flags.Text("--format", "png|jpeg|exr|tiff|webp", "image format (default: from OUT's extension)",
             &format_name);
  flags.Text("-o, --output", "OUT", "output file, or - for stdout (PNG)", &out_path);
  if (int rc = flags.Parse(args, paths); rc >= 0) return rc;
  picture::ImageFormat format;
  if (paths.empty() || out_path.empty() || (sheet && cells_text.empty())) {
    return flags.UsageError(paths.empty()      ? "no rig given"
                            : out_path.empty() ? "no output given (-o OUT)"
                                               : "no --cells given");
  }
  if (!ImageFormatFor(out_path, format_name, &format)) {
    if (!format_name.empty())
      std::fprintf(stderr, "error: --format must be png, jpeg, exr, tiff or webp, not '%s'\n",
                   format_name.c_str());
    else
      std::fprintf(stderr,
                   "error: cannot tell the image format from '%s': use .png, .jpg, .exr, .tif, "
                   ".webp or --format\n",
                   out_path.c_str());
    return 2;
  }
  // --format and a file name that says another format: the bytes would belie the name.
  if (picture::ImageFormat named; !format_name.empty() && ImageFormatFor(out_path, "", &named) &&
                                  out_path != "-" && named != format) {
    std::fprintf(
        stderr,
        "error: --format %s does not match the output name '%s': name it .%s, or drop --format\n",
        format_name.c_str(), out_path.c_str(), picture::ImageFormatExtension(format));
    return 2;
  }
  Result<Rig> loaded = LoadAndReport(paths);
  if (!loaded.ok()) return 1;
  const auto rig = evaluator::Unstored(std::move(loaded.value()));
  const offscreen::OsMesaRenderer renderer(1);
  const evaluator::Evaluator evaluator(renderer);
  if (!ReportLod(evaluator, rig, r.mesh.lod)) return 1;
  if (std::string e = evaluator::FinishPoseSettings(r.mesh); !e.empty()) {
    std::fprintf(stderr, "error: --animation: %s\n", e.c_str());
    return 2;
  }
  evaluator::Workspace ws;
  if (!sheet) {
    return WriteProduced(out_path, evaluator::ProduceImage(evaluator, rig, r, format, ws));
  } else {
    // Cells: a JSON array, or one JSON object per line.
    const bool shape_cells = cells_text == "shapes" || cells_text.starts_with("shapes:");
    nlohmann::json cells = shape_cells ? nlohmann::json(cells_text)
                                       : nlohmann::json::parse(cells_text, nullptr, false);
    if (cells.is_discarded()) {
      cells = nlohmann::json::array();
      size_t start = 0;
      while (start < cells_text.size()) {
        size_t end = cells_text.find('\n', start);
        if (end == std::string::npos) end = cells_text.size();
        const std::string line = cells_text.substr(start, end - start);
        if (line.find_first_not_of(" \t\r") != std::string::npos) {
          nlohmann::json cell = nlohmann::json::parse(line, nullptr, false);
          if (cell.is_discarded()) {
            std::fprintf(stderr, "error: --cells: line %zu is not JSON\n", cells.size() + 1);
            return 1;
          }
          cells.push_back(cell);
        }
        start = end + 1;
      }
    }
    auto parsed =
        evaluator::ParseSheetRequest(nlohmann::json{{"cells", cells}, {"columns", columns}}.dump(
            -1, ' ', false, nlohmann::json::error_handler_t::replace));
    if (!parsed.ok()) {
      PrintStatus(parsed.status());
      return 1;
    }
    evaluator::SheetRequest& request = parsed.value();
    if (Status s = evaluator::ExpandShapeCells(rig->rig, &renderer, request); !s.ok()) {
      PrintStatus(s);
      return 1;
    }
    request.base =
        r;  // The render settings, blend options and pose of the flags; the cells' weights.
    return WriteProduced(out_path, evaluator::ProduceSheet(evaluator, rig, request, format, ws));
  }
}

}  // namespace facespace::cli
