// facespace sequence: keyframe sequences from the command line.
#include "facespace/engine/sequence.h"

#include <unistd.h>

#include <Eigen/Dense>
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "commands/cli.h"
#include "commands/flags.h"
#include "facespace/engine/enum_table.h"
#include "facespace/engine/fit.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/formats/io.h"
#include "facespace/lipsync/lipsync.h"
#include "facespace/offscreen/render.h"

namespace facespace::cli {

namespace {

// --gaze (YAW,PITCH, X,Y,Z, or the body's JSON) and --blink (PER_MINUTE[,SEED]) as the body's
// members.
Status FaceMembers(const std::string& gaze, const std::string& blink, nlohmann::json& body) {
  auto numbers = [](const std::string& text, std::vector<double>& out) {
    size_t from = 0;
    while (from <= text.size()) {
      const size_t comma = std::min(text.find(',', from), text.size());
      double x = 0;
      const auto r = std::from_chars(text.data() + from, text.data() + comma, x);
      if (r.ec != std::errc() || r.ptr != text.data() + comma) return false;
      out.push_back(x);
      from = comma + 1;
    }
    return true;
  };
  if (!gaze.empty()) {
    const std::string text = gaze[0] == '{' ? gaze : evaluator::GazeShortForm(gaze);
    if (text.empty())
      return InvalidArgument("--gaze: want YAW,PITCH (degrees), X,Y,Z (a point) or JSON");
    body["gaze"] = nlohmann::json::parse(text, nullptr, false);
    if (body["gaze"].is_discarded()) return InvalidArgument("--gaze: malformed JSON");
  }
  if (!blink.empty()) {
    std::vector<double> n;
    if (!numbers(blink, n) || n.empty() || n.size() > 2 ||
        (n.size() == 2 && (n[1] < 0 || n[1] > 9007199254740992.0 || n[1] != std::floor(n[1])))) {
      return InvalidArgument("--blink: want PER_MINUTE or PER_MINUTE,SEED (a whole number)");
    }
    body["blink"] = {{"per_minute", n[0]}};
    if (n.size() == 2) body["blink"]["seed"] = static_cast<uint64_t>(n[1]);
  }
  return Status::Ok();
}

// A progress bar on a terminal, a line every 10% otherwise.
class Progress {
 public:
  explicit Progress(size_t total)
      : total_(total), tty_(isatty(2)), start_(std::chrono::steady_clock::now()) {}
  void Step(size_t done) {
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const double rate = secs > 0 ? done / secs : 0.0;
    if (tty_) {
      const int width = 30, filled = static_cast<int>(width * done / std::max<size_t>(total_, 1));
      std::fprintf(stderr, "\r[%s%s] %zu/%zu frames, %.1f frames/s ",
                   std::string(filled, '#').c_str(), std::string(width - filled, ' ').c_str(), done,
                   total_, rate);
      if (done == total_) std::fputc('\n', stderr);
    } else if (done == total_ ||
               secs - last_ >= 10.0) {  // A log: a line every 10 s at most, and the summary.
      std::fprintf(stderr,
                   done == total_ ? "frames: %zu of %zu written in %.2f s (%.1f frames/s)\n"
                                  : "frames: %zu/%zu, %.0f s (%.1f frames/s)\n",
                   done, total_, secs, rate);
      last_ = secs;
    }
  }

 private:
  size_t total_;
  bool tty_;
  double last_ = 0;
  std::chrono::steady_clock::time_point start_;
};

// Frames' warnings, once per code at the end ("in 37 of 100 frames, the first: ..."), instead of
// a line per frame.
class WarningSummary {
 public:
  void Add(std::span<const Warning> warnings) {
    std::vector<std::string> seen;  // A code counts once per frame.
    for (const Warning& w : warnings) {
      if (std::find(seen.begin(), seen.end(), w.code) != seen.end()) continue;
      seen.push_back(w.code);
      auto it = std::find_if(codes_.begin(), codes_.end(),
                             [&](const Entry& e) { return e.code == w.code; });
      if (it == codes_.end())
        codes_.push_back({w.code, w.message, 1});
      else
        ++it->frames;
    }
  }
  void Print(size_t frames) const {
    if (Quiet()) return;
    for (const Entry& e : codes_) {
      std::fprintf(stderr, "warning: %s in %zu of %zu frames, the first: %s\n", e.code.c_str(),
                   e.frames, frames, e.first.c_str());
    }
  }

 private:
  struct Entry {
    std::string code, first;
    size_t frames = 0;
  };
  std::vector<Entry> codes_;
};

// What `facespace sequence` writes: one JSON file of frames (with meshes, or their weights and pose
// alone), or a file per frame in a folder (OBJ, glb, f32).
enum class SequenceOutput { kJson, kWeights, kObj, kGlb, kF32 };
constexpr EnumName<SequenceOutput> kSequenceOutputs[] = {{SequenceOutput::kJson, "json"},
                                                         {SequenceOutput::kWeights, "weights"},
                                                         {SequenceOutput::kObj, "obj"},
                                                         {SequenceOutput::kGlb, "glb"},
                                                         {SequenceOutput::kF32, "f32"}};
bool OneFile(SequenceOutput o) {
  return o == SequenceOutput::kJson || o == SequenceOutput::kWeights;
}

// What `facespace sequence` is asked.
struct SequenceArgs {
  std::vector<std::string> paths;
  std::string keys_text, layers_text, from_animation, obj_times, transition, times_text, format,
      out, gaze_text, blink_text;
  bool smooth = false, has_fps = false, has_reduce = false, has_bake = false, physics = true;
  float fps = 30.0f, tolerance = 0.0f, bake = 0.0f;
  BlendOptions options;
  SequenceOutput output = SequenceOutput::kJson;  // --format, parsed.
};

void AddSequenceFlags(Flags& flags, SequenceArgs& a) {
  auto number = [](const char* flag, float lo, float* dst, bool* given) {
    return [flag, lo, dst, given](const std::string& v) {
      double d = 0;
      if (!NumberIn(flag, v, lo, 1e9, &d)) return 2;
      *dst = static_cast<float>(d);
      *given = true;
      return 0;
    };
  };
  flags.Value("--keys", "JSON|@FILE", "the keyframes",
              [&a](const std::string& v) { return ReadAtFile("--keys", v, a.keys_text) ? 0 : 1; });
  flags.Value(
      "--layers", "JSON|@FILE",
      "motions layered: a base, then overlays, each starting at its time: [{\"motion\", \"time\", "
      "\"loop\"}]",
      [&a](const std::string& v) { return ReadAtFile("--layers", v, a.layers_text) ? 0 : 1; });
  flags.Text("--from-animation", "NAME|INDEX",
             "play a clip or motion: its pose and weights (keys: its morph-weight channel)",
             &a.from_animation);
  flags.Text("--obj-times", "T0,T1,...", "OBJ sequence: one key per file at these times",
             &a.obj_times);
  flags.Text(
      "--transition", "T",
      "linear|step|smoothstep|smootherstep|ease-in|ease-out|ease-in-out|'cubic-bezier(a,b,c,d)'",
      &a.transition);
  flags.Switch("--smooth", "Catmull-Rom through the keys", [&a] { a.smooth = true; });
  flags.Switch("--no-physics",
               "no secondary motion: the rig's rigid bodies (MMD hair, skirts) follow their bones",
               [&a] { a.physics = false; });
  flags.Value("--gaze", "YAW,PITCH|X,Y,Z|JSON|@FILE",
              "where the eyes look: held (degrees, or a point), or a track {\"keys\": [{\"time\", "
              "\"target\" | \"yaw\", \"pitch\"}]}",
              [&a](const std::string& v) { return ReadAtFile("--gaze", v, a.gaze_text) ? 0 : 1; });
  flags.Text(
      "--blink", "PER_MINUTE[,SEED]",
      "natural blinks through the rig's blink expression (e.g. 15, or 15,7 for another draw)",
      &a.blink_text);
  flags.Text("--times", "JSON", "sample at these times: [0, 0.5, 1]", &a.times_text);
  flags.Value("--fps", "N", "sample every 1/N s from the first key to the last (default 30)",
              number("--fps", 1e-3f, &a.fps, &a.has_fps));
  flags.Value("--reduce", "TOLERANCE",
              "remove keys while the largest vertex error stays under TOLERANCE",
              number("--reduce", 0, &a.tolerance, &a.has_reduce));
  flags.Value("--bake", "TIME", "add a key at TIME with the in-between weights",
              number("--bake", -1e9f, &a.bake, &a.has_bake));
  AddBlendOptionFlags(flags, a.options);
  flags.Text("--format", "json|weights|obj|glb|f32",
             "one JSON file of frames (weights: their weights and pose, no meshes), or a file per "
             "frame in DIR (default: json, or glb when OUT is a folder: ends in / or exists)",
             &a.format);
  flags.Text("-o, --output", "OUT.json|DIR", "output", &a.out);
}

// The flags that go together do, and the format is one there is (`-o frames/`, or an existing
// folder: a glb per frame; else one JSON file). 0 or the exit code.
int CheckSequenceArgs(const Flags& flags, SequenceArgs& a) {
  const int sources = !a.keys_text.empty() + !a.layers_text.empty() + !a.from_animation.empty() +
                      !a.obj_times.empty();
  if ((!a.gaze_text.empty() || !a.blink_text.empty()) && a.keys_text.empty() &&
      a.layers_text.empty()) {
    return flags.UsageError("--gaze and --blink go with --keys or --layers");
  }
  if (a.paths.empty() || a.out.empty() || sources != 1) {
    return flags.UsageError(
        a.paths.empty() ? "no rig given"
        : a.out.empty() ? "no output given (-o)"
                        : "give exactly one of --keys, --layers, --from-animation, --obj-times");
  }
  if (a.format.empty()) {
    std::error_code ec;
    a.format = a.out.back() == '/' || std::filesystem::is_directory(a.out, ec) ? "glb" : "json";
  }
  if (!ParseEnum(kSequenceOutputs, a.format, &a.output))
    return std::fprintf(stderr, "error: --format must be json, weights, obj, glb or f32\n"), 2;
  if (OneFile(a.output) && a.out.back() == '/') {
    std::fprintf(stderr,
                 "error: --format %s writes one file, and '%s' is a folder: give a file name, or "
                 "--format obj|glb|f32 for a file per frame\n",
                 a.format.c_str(), a.out.c_str());
    return 2;
  }
  return 0;
}

// --keys or --layers, as a sequence request's body (with --gaze and --blink), resolved. 0 or the
// exit code.
int SequenceOfKeys(const Rig& rig, const SequenceArgs& a, facespace::Sequence& seq) {
  const bool layered = !a.layers_text.empty();
  nlohmann::json keys =
      nlohmann::json::parse(layered ? a.layers_text : a.keys_text, nullptr, false);
  if (keys.is_discarded())
    return std::fprintf(stderr, "error: %s: malformed JSON\n", layered ? "--layers" : "--keys"), 1;
  nlohmann::json body = {{layered ? "layers" : "keys", keys}, {"smooth", a.smooth}};
  if (!a.transition.empty()) body["transition"] = a.transition;
  if (!a.gaze_text.empty() || !a.blink_text.empty()) {
    if (Status s = FaceMembers(a.gaze_text, a.blink_text, body); !s.ok())
      return std::fprintf(stderr, "error: %s\n", s.message.c_str()), 2;
  }
  auto parsed = evaluator::ParseSequenceRequest(
      body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  if (!parsed.ok()) return std::fprintf(stderr, "error: %s\n", parsed.status().message.c_str()), 1;
  auto resolved = evaluator::ResolveSequence(rig, parsed.value());
  if (!resolved.ok())
    return std::fprintf(stderr, "error: %s\n", resolved.status().message.c_str()), 1;
  seq = std::move(resolved.value());
  return 0;
}

// --from-animation: a clip by name, else by index. 0 or the exit code.
int SequenceOfAnimation(const Rig& rig, const std::string& from_animation,
                        facespace::Sequence& seq) {
  ClipRequest named;
  named.name = from_animation;
  int clip = FindClip(rig, named);
  if (clip < 0 && from_animation.find_first_not_of("0123456789") == std::string::npos &&
      from_animation.size() < 9) {
    named = ClipRequest{};
    named.index = std::stoi(from_animation);
    clip = FindClip(rig, named);
  }
  if (clip < 0)
    return std::fprintf(stderr, "error: --from-animation: %s\n",
                        UnknownClipMessage(rig, named).c_str()),
           2;
  auto s = SequenceOfClip(rig, clip);
  if (!s.ok())
    return std::fprintf(stderr, "error: --from-animation: %s\n", s.status().message.c_str()), 1;
  seq = std::move(s.value());
  return 0;
}

// --obj-times: one key per OBJ file, the base at the first time, then each frame as its shape. 0 or
// the exit code.
int SequenceOfObjs(const Rig& rig, const std::string& obj_times, size_t files,
                   facespace::Sequence& seq) {
  std::vector<float> times;
  for (size_t start = 0; start <= obj_times.size();) {
    size_t end = obj_times.find(',', start);
    if (end == std::string::npos) end = obj_times.size();
    char* stop = nullptr;
    const std::string tok = obj_times.substr(start, end - start);
    times.push_back(std::strtof(tok.c_str(), &stop));
    if (tok.empty() || *stop)
      return std::fprintf(stderr, "error: --obj-times: '%s' is not a number\n", tok.c_str()), 2;
    start = end + 1;
  }
  if (times.size() != files)
    return std::fprintf(stderr, "error: --obj-times gives %zu times for %zu OBJ files\n",
                        times.size(), files),
           2;
  for (size_t k = 0; k < times.size(); ++k) {
    Keyframe key;
    key.time = times[k];
    key.weights.assign(rig.shapes.size(), 0.0f);
    if (k > 0) key.weights[k - 1] = 1.0f;
    seq.keys.push_back(std::move(key));
  }
  return 0;
}

// The sequence the flags give: keys or layers (a request's), else a clip or OBJ files (with
// --transition and --smooth). 0 or the exit code.
int MakeSequence(const Rig& rig, const SequenceArgs& a, facespace::Sequence& seq) {
  if (!a.keys_text.empty() || !a.layers_text.empty()) return SequenceOfKeys(rig, a, seq);
  const int rc = !a.from_animation.empty() ? SequenceOfAnimation(rig, a.from_animation, seq)
                                           : SequenceOfObjs(rig, a.obj_times, a.paths.size(), seq);
  if (rc != 0) return rc;
  if (!a.transition.empty() && !ParseTransition(a.transition, &seq.transition))
    return std::fprintf(stderr, "error: --transition: unknown '%s'\n", a.transition.c_str()), 2;
  seq.smooth |= a.smooth;
  if (Status st = ValidateSequence(seq, rig.shapes.size()); !st.ok())
    return std::fprintf(stderr, "error: %s\n", st.message.c_str()), 1;
  return 0;
}

// --times, else every 1/fps s from the first key to the last. 0 or the exit code.
int SampleTimes(const SequenceArgs& a, const facespace::Sequence& seq, std::vector<float>& times) {
  if (!a.times_text.empty()) {
    nlohmann::json t = nlohmann::json::parse(a.times_text, nullptr, false);
    if (t.is_discarded() || !t.is_array() || t.empty())
      return std::fprintf(stderr, "error: --times must be a JSON array of seconds\n"), 2;
    for (const auto& v : t) {
      if (!v.is_number()) return std::fprintf(stderr, "error: --times must hold numbers\n"), 2;
      times.push_back(v.get<float>());
    }
    return 0;
  }
  const float fps = a.has_fps ? a.fps : 30.0f;
  const double duration = seq.keys.back().time - seq.keys.front().time;
  const size_t frames = static_cast<size_t>(std::floor(duration * fps + 1e-6)) + 1;
  if (frames > 1000000) return std::fprintf(stderr, "error: too many frames\n"), 2;
  for (size_t k = 0; k < frames; ++k)
    times.push_back(seq.keys.front().time + static_cast<float>(k) / fps);
  return 0;
}

// Frames as files in a folder, frame_00000.EXT, the sequence's physics simulated over them.
int WriteFrameFiles(const std::shared_ptr<const evaluator::StoredRig>& stored,
                    const facespace::Sequence& seq, std::span<const float> times,
                    const SequenceArgs& a) {
  std::error_code ec;
  std::filesystem::create_directories(a.out, ec);
  if (ec)
    return std::fprintf(stderr, "error: cannot create '%s': %s\n", a.out.c_str(),
                        ec.message().c_str()),
           1;
  formats::MeshFormat mf;
  const char* extension =
      EnumEntry(kSequenceOutputs, a.output).name;  // The mesh format's name too.
  ParseMeshFormat(extension, &mf);
  evaluator::MeshRequest frame;
  frame.options = a.options;
  const evaluator::OutputSpec spec = evaluator::OutputSpec::Mesh(frame, mf);
  const evaluator::Evaluator evaluator;
  evaluator::Workspace ws;
  evaluator::ResolvedPoint point;
  evaluator::SequencePhysics simulation(stored->rig, seq);
  Progress progress(times.size());
  WarningSummary summary;
  for (size_t k = 0; k < times.size(); ++k) {
    evaluator::SequencePoint(stored->rig, seq, times[k], a.options.mode, point, &simulation);
    summary.Add(point.report.warnings);
    auto bytes = evaluator.Run(stored, point, spec, ws);
    if (!bytes.ok()) return std::fprintf(stderr, "error: %s\n", bytes.status().message.c_str()), 1;
    char name[64];
    std::snprintf(name, sizeof name, "/frame_%05zu.%s", k, extension);
    if (!WriteOutput(a.out + name, bytes->bytes))
      return std::fprintf(stderr, "error: cannot write '%s%s'\n", a.out.c_str(), name), 1;
    progress.Step(k + 1);
  }
  summary.Print(times.size());
  return 0;
}

// The sequence sampled: one JSON file of frames (or their weights), else a file per frame.
int WriteSamples(const std::shared_ptr<const evaluator::StoredRig>& stored,
                 const facespace::Sequence& seq, const SequenceArgs& a) {
  std::vector<float> times;
  if (int rc = SampleTimes(a, seq, times); rc != 0) return rc;
  if (!OneFile(a.output)) return WriteFrameFiles(stored, seq, times, a);
  std::vector<Warning> warnings;
  const evaluator::Evaluator evaluator;
  evaluator::Workspace ws;
  auto body =
      evaluator::SampleSequenceJson(evaluator, stored, seq, times, a.options, warnings, ws,
                                    static_cast<size_t>(-1), a.output == SequenceOutput::kWeights);
  WarningSummary
      summary;  // Each warning of the list is one frame's (they are in the body, by frame).
  for (const Warning& w : warnings) summary.Add(std::span<const Warning>(&w, 1));
  summary.Print(times.size());
  if (!body.ok()) return std::fprintf(stderr, "error: %s\n", body.status().message.c_str()), 1;
  return WriteResult(a.out, body);
}

}  // namespace

int Sequence(const std::vector<std::string>& args) {
  SequenceArgs a;
  Flags flags(
      "usage: facespace sequence RIG [SHAPE.obj ...] (--keys JSON|@FILE | --layers JSON|@FILE\n"
      "         | --from-animation NAME|INDEX | --obj-times T0,T1,...)\n"
      "         [--transition T] [--smooth] [--no-physics] (--times JSON | --fps N) [--format "
      "json|weights|obj|glb|f32] -o OUT.json|DIR\n"
      "       facespace sequence RIG ... --reduce TOLERANCE -o OUT.json\n"
      "       facespace sequence RIG ... --bake TIME -o OUT.json\n",
      "keys: [{\"time\": 0, \"weights\": {...}} | {\"time\": 1, \"shape\": \"jawOpen\"}, ...]; "
      "frames go to DIR as\n"
      "frame_00000.EXT for obj, glb and f32, or into one JSON file.\n");
  AddSequenceFlags(flags, a);
  if (int rc = flags.Parse(args, a.paths); rc >= 0) return rc;
  if (int rc = CheckSequenceArgs(flags, a); rc != 0) return rc;
  Result<Rig> loaded =
      a.paths.size() > 1 ? formats::LoadObjSequence(a.paths) : formats::LoadRigFile(a.paths[0]);
  if (!loaded.ok()) return std::fprintf(stderr, "error: %s\n", loaded.status().message.c_str()), 1;
  const auto stored = evaluator::Unstored(std::move(loaded.value()));
  const Rig& rig = stored->rig;
  facespace::Sequence seq;
  if (int rc = MakeSequence(rig, a, seq); rc != 0) return rc;
  seq.physics = a.physics;
  if (a.has_reduce) {
    auto r = ReduceSequence(rig, seq, a.tolerance);
    if (!r.ok()) return std::fprintf(stderr, "error: %s\n", r.status().message.c_str()), 1;
    std::fprintf(stderr, "kept %zu of %zu keys, max vertex error %s (tolerance %s)\n",
                 r->sequence.keys.size(), seq.keys.size(), FormatNumber(r->max_error).c_str(),
                 FormatNumber(a.tolerance).c_str());
    return WriteResult(a.out, evaluator::ReducedSequenceJson(rig, seq, r.value(), a.tolerance));
  }
  if (a.has_bake) {
    const facespace::Sequence baked = BakeKey(seq, a.bake);
    return WriteResult(a.out, "{\"keys\":" + evaluator::SequenceKeysJson(rig, baked) +
                                  ",\"transition\":\"" + TransitionName(seq.transition) + "\"}\n");
  }
  return WriteSamples(stored, seq, a);
}

int FitCommand(const std::vector<std::string>& args) {
  std::vector<std::string> paths;
  std::string out;
  FitOptions options;
  Flags flags(
      "usage: facespace fit RIG TARGET.(json|glb|gltf|obj) [--bounded] [--sum-at-most-one] "
      "[--align] -o FIT.json\n",
      "The weights that best reproduce TARGET (least squares over the shapes). TARGET: the JSON "
      "that\n"
      "`facespace blend` writes (its \"space\" says world or mesh), a glTF with the rig's "
      "primitives, or an\n"
      "OBJ with the rig's vertices in its primitive order (world space, as `blend -o x.obj` writes "
      "it).\n");
  flags.Switch("--bounded", "keep each weight in its shape's range",
               [&] { options.bounded = true; });
  flags.Switch("--sum-at-most-one", "keep the sum of the weights at most 1",
               [&] { options.sum_at_most_one = true; });
  flags.Switch("--align", "fit a rigid transform of the target first",
               [&] { options.rigid_align = true; });
  flags.Text("-o, --output", "FIT.json", "output", &out);
  if (int rc = flags.Parse(args, paths); rc >= 0) return rc;
  if (paths.size() != 2 || out.empty())
    return flags.UsageError(out.empty() ? "no output given (-o FIT.json)" : "give RIG and TARGET");
  auto rig = formats::LoadRigFile(paths[0]);
  if (!rig.ok()) return std::fprintf(stderr, "error: %s\n", rig.status().message.c_str()), 1;
  const std::string& tp = paths[1];
  const std::string ext = tp.substr(tp.rfind('.') + 1);
  std::vector<std::vector<float>> target;
  if (ext == "json") {
    std::string text;
    if (!ReadFile(tp, text))
      return std::fprintf(stderr, "error: cannot read '%s'\n", tp.c_str()), 1;
    auto t = evaluator::ParseTargetJson(text);
    if (!t.ok())
      return std::fprintf(stderr, "error: %s: %s\n", tp.c_str(), t.status().message.c_str()), 1;
    target = std::move(t->positions);
    if (!t->mesh_space) WorldToMeshSpace(rig.value(), target);
  } else {
    auto other = formats::LoadRigFile(tp, {.allow_external_files = true, .read_manifest = false});
    if (!other.ok()) return std::fprintf(stderr, "error: %s\n", other.status().message.c_str()), 1;
    if (ext == "obj") {
      // One OBJ with every primitive's vertices in order, world space: back to mesh space.
      const std::vector<float>& all = other->primitives[0].positions;
      size_t at = 0;
      for (size_t p = 0; p < rig->primitives.size(); ++p) {
        const size_t n = rig->primitives[p].positions.size();
        if (at + n > all.size())
          return std::fprintf(stderr, "error: %s has fewer vertices than the rig\n", tp.c_str()), 1;
        target.emplace_back(all.begin() + static_cast<std::ptrdiff_t>(at),
                            all.begin() + static_cast<std::ptrdiff_t>(at + n));
        at += n;
      }
      WorldToMeshSpace(rig.value(), target);
      if (at != all.size())
        return std::fprintf(stderr, "error: %s has more vertices than the rig\n", tp.c_str()), 1;
    } else {
      for (const Primitive& p : other->primitives) target.push_back(p.positions);
    }
  }
  auto fit = FitWeights(rig.value(), target, options);
  if (!fit.ok()) return std::fprintf(stderr, "error: %s\n", fit.status().message.c_str()), 1;
  PrintWarnings(fit->warnings);
  std::fprintf(
      stderr, "residual: rms %s, max %s (vertex distances in the scene's units: metres for glTF)\n",
      FormatNumber(fit->rms_error).c_str(), FormatNumber(fit->max_error).c_str());
  return WriteResult(out, evaluator::FitResultJson(rig.value(), fit.value(), options.rigid_align));
}

}  // namespace facespace::cli

namespace facespace::cli {

namespace {

// What OUT's extension asks speak to write: none (or stdout) is JSON; "" for another.
std::string SpeakFormatOf(const std::string& out) {
  const std::string ext = out == "-" ? "" : std::filesystem::path(out).extension().string();
  return ext == ".wav"                   ? "wav"
         : ext == ".webm"                ? "webm"
         : ext == ".ndjson"              ? "ndjson"
         : ext == ".json" || ext.empty() ? "json"
                                         : "";
}

// The speech as OUT asks: its JSON, its audio, a video of the face speaking, or frames' weights.
int WriteSpeech(const std::string& out, const std::shared_ptr<const evaluator::StoredRig>& stored,
                const lipsync::SpeechPlan& plan, const evaluator::SpeechRequest& r) {
  if (r.format == evaluator::FrameFormat::kJson)
    return WriteOutput(out, lipsync::SpeechJson(stored->rig, plan, r.fps)) ? 0 : 1;
  if (r.format == evaluator::FrameFormat::kWav)
    return WriteOutput(out, speech::WriteWav(plan.audio)) ? 0 : 1;
  const size_t frames = evaluator::FrameCount(plan.sequence, r.fps);
  Progress progress(frames);
  offscreen::OsMesaRenderer renderer;
  evaluator::Evaluator evaluator(renderer);
  evaluator::Workspace ws;
  if (r.format == evaluator::FrameFormat::kWebm) {
    auto video = lipsync::SpeechVideo(evaluator, stored, plan, r, ws,
                                      [&progress](size_t i) { progress.Step(i + 1); });
    return WriteResult(out, video);
  }
  std::string lines;
  for (size_t i = 0; i < frames; ++i) {
    auto line = evaluator::StreamFrame(evaluator, stored, plan.sequence, i, r.fps, false,
                                       r.render.mesh.options, ws);
    if (!line.ok()) {
      PrintStatus(line.status());
      return 1;
    }
    lines += line.value();
  }
  return WriteOutput(out, lines) ? 0 : 1;
}

}  // namespace

int Speak(const std::vector<std::string>& args) {
  std::vector<std::string> paths;
  std::string text, audio_path, transcript, voice, format, out, gaze_text, blink_text,
      expressions_text, camera_text;
  std::vector<std::pair<std::string, std::string>>
      numbers;  // rate, fps, strength, width, height: as given.
  auto setting = [&numbers](const char* name) {
    return [&numbers, name](const std::string& v) {
      numbers.emplace_back(name, v);
      return 0;
    };
  };
  Flags flags(
      "usage: facespace speak RIG (--text TEXT | --audio FILE.wav [--transcript TEXT]) [--voice V] "
      "[--rate WPM] [--fps N] [--strength S]\n"
      "       [--expressions JSON] [--gaze YAW,PITCH|X,Y,Z|JSON] [--blink PER_MINUTE[,SEED]] "
      "[--width W --height H] [--camera JSON]\n"
      "       -o OUT.json|OUT.wav|OUT.webm|OUT.ndjson\n",
      "Lip sync: the words are spoken by espeak-ng (--text) or heard by PocketSphinx (--audio), "
      "their phonemes become visemes\n"
      "and the visemes keys of the rig's mouth shapes (GET /v1/rigs/ID's \"visemes\"). OUT.json: "
      "phonemes, visemes and keys, as\n"
      "POST /v1/rigs/ID/speech gives them; OUT.wav: the audio; OUT.webm: a video of the face "
      "speaking, with its audio; OUT.ndjson:\n"
      "one line of weights per frame.");
  flags.Text("--text", "TEXT", "words to say (espeak-ng; at most 2000 characters)", &text);
  flags.Text("--audio", "FILE.wav",
             "speech to lip-sync (WAV, at most 60 s; PocketSphinx, US English)", &audio_path);
  flags.Text("--transcript", "TEXT",
             "with --audio: the words said, to align to rather than recognize", &transcript);
  flags.Text("--voice", "V",
             "espeak-ng's voice or language (default en-us; GET /v1/voices lists them)", &voice);
  flags.Value("--rate", "WPM", "words a minute, 80 to 450 (default 175)", setting("rate"));
  flags.Value("--fps", "N", "frames a second of the video and the frames (default 30)",
              setting("fps"));
  flags.Value("--strength", "S", "how far the mouth moves, 0 to 2 (default 1)",
              setting("strength"));
  flags.Text("--expressions", "JSON", "the face under the speech: {\"happy\": 0.5}",
             &expressions_text);
  flags.Text("--gaze", "YAW,PITCH|X,Y,Z|JSON", "where the eyes look (held, or a track)",
             &gaze_text);
  flags.Text("--blink", "PER_MINUTE[,SEED]", "natural blinks", &blink_text);
  flags.Value("--width", "W", "the video's width (even; default 512)", setting("width"));
  flags.Value("--height", "H", "the video's height (even; default 512)", setting("height"));
  flags.Text("--camera", "JSON", "the video's camera, as the render route's", &camera_text);
  flags.Text("--format", "json|wav|webm|ndjson", "what to write (default: from OUT's extension)",
             &format);
  flags.Text("-o, --output", "OUT", "output", &out);
  if (int rc = flags.Parse(args, paths); rc >= 0) return rc;
  if (paths.size() != 1 || out.empty() || text.empty() == audio_path.empty()) {
    return flags.UsageError(paths.size() != 1 ? "give one rig"
                            : out.empty()     ? "no output given (-o)"
                                              : "give --text or --audio");
  }
  if (format.empty()) {  // From OUT's extension; none (or stdout) is JSON; another is refused, not
                         // written as JSON.
    format = SpeakFormatOf(out);
    if (format.empty()) {
      std::fprintf(stderr,
                   "error: -o %s: speak writes .json, .wav, .webm or .ndjson (or say which with "
                   "--format json|wav|webm|ndjson)\n",
                   out.c_str());
      return 2;
    }
  }
  // One body, read by the route's own parser: the same checks and messages.
  nlohmann::json body = nlohmann::json::object();
  for (const auto& [name, value] : numbers) {
    double d = 0;
    if (!NumberIn("--" + name, value, -1e9, 1e9, &d)) return 2;
    body[name] = d == std::floor(d) ? nlohmann::json(static_cast<long long>(d)) : nlohmann::json(d);
  }
  if (!voice.empty()) body["voice"] = voice;
  if (!transcript.empty()) body["transcript"] = transcript;
  body["format"] = format;
  for (const auto& [name, value] :
       {std::pair{"expressions", &expressions_text}, std::pair{"camera", &camera_text}}) {
    if (value->empty()) continue;
    body[name] = nlohmann::json::parse(*value, nullptr, false);
    if (body[name].is_discarded())
      return flags.UsageError(std::string("--") + name + ": malformed JSON");
  }
  if (Status s = FaceMembers(gaze_text, blink_text, body); !s.ok())
    return flags.UsageError(s.message);
  Result<evaluator::SpeechRequest> request = Status::Ok();
  if (!audio_path.empty()) {
    std::string wav;
    if (!ReadFile(audio_path, wav)) {
      std::fprintf(stderr, "error: --audio: cannot read '%s'\n", audio_path.c_str());
      return 1;
    }
    std::vector<std::pair<std::string, std::string>> settings;
    for (auto it = body.begin(); it != body.end(); ++it)
      settings.emplace_back(it.key(), it->is_string() ? it->get<std::string>() : it->dump());
    request = evaluator::SpeechRequestOfWav(std::move(wav), settings);
  } else {
    body["text"] = text;
    request = evaluator::ParseSpeechRequest(
        body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  }
  if (!request.ok()) {
    PrintStatus(request.status());
    return 2;
  }
  auto loaded = LoadAndReport({paths[0]});
  if (!loaded.ok()) return 1;
  const auto stored = evaluator::Unstored(std::move(loaded.value()));
  auto plan = lipsync::PlanSpeech(stored->rig, request.value());
  if (!plan.ok()) {
    PrintStatus(plan.status());
    return 1;
  }
  PrintWarnings(lipsync::SpeechWarnings(plan.value()));
  return WriteSpeech(out, stored, plan.value(), request.value());
}

}  // namespace facespace::cli
