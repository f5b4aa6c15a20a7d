// facespace derive: a source rig's shapes (default: the bundled FaceCap's ARKit 52) transferred
// onto a head that has none, written as a glb with its manifest; facespace capture: a tracker's
// landmarks over frames as a rig's weights, by the same registration.
#include "facespace/derive/derive.h"

#include <cmath>
#include <cstdio>
#include <ctime>

#include "commands/cli.h"
#include "commands/flags.h"
#include "facespace/derive/capture.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/formats/io.h"

#ifndef FACESPACE_DEFAULT_SOURCE
#define FACESPACE_DEFAULT_SOURCE "assets/facecap/facecap.glb"
#endif
#ifndef FACESPACE_CANONICAL_FACE
#define FACESPACE_CANONICAL_FACE "assets/trackers/mediapipe/canonical_face_model.obj"
#endif

namespace facespace::cli {

Result<std::string> RigAsGlb(const std::shared_ptr<const evaluator::StoredRig>& rig);

int Derive(const std::vector<std::string>& args) {
  std::vector<std::string> positional;
  std::string from = FACESPACE_DEFAULT_SOURCE, out, landmarks_path, sets;
  Flags flags(
      "usage: facespace derive TARGET [--from SOURCE] -o OUT.glb [--landmarks FILE] [--shapes "
      "arkit,visemes]\n",
      "Transfers SOURCE's shapes (default: the bundled FaceCap, ARKit 52) onto TARGET's neutral: "
      "SOURCE's\n"
      "face registered onto TARGET's (landmarks or the heads' own shape, then non-rigid ICP) and "
      "each\n"
      "shape's deformation carried over (deformation transfer). Writes OUT.glb with TARGET's own "
      "shapes\n"
      "and the derived ones, named as SOURCE names them, and OUT.manifest.json marking them "
      "derived.\n"
      "TARGET is any mesh we read (glb, glTF, OBJ, FBX, COLLADA, PMX), facing +z with y up unless\n"
      "landmarks say where the face is.\n");
  flags.Text("--from", "SOURCE",
             "the rig whose shapes are transferred (its manifest's landmarks used)", &from);
  flags.Text("--landmarks", "FILE",
             "TARGET's landmarks: {\"scheme\", \"points\": [{\"name\", \"vertex\" | "
             "\"position\"}]}, named as SOURCE's",
             &landmarks_path);
  flags.Text("--shapes", "SETS",
             "arkit (SOURCE's ARKit-named shapes), visemes (the 15 baked as viseme_*); default all "
             "of SOURCE's and the visemes",
             &sets);
  flags.Text("-o, --output", "OUT.glb", "output", &out);
  if (int rc = flags.Parse(args, positional); rc >= 0) return rc;
  if (positional.empty() || out.empty())
    return flags.UsageError(out.empty() ? "no output given (-o OUT.glb)" : "give TARGET");
  Result<Rig> target = LoadAndReport(positional);
  if (!target.ok()) return 1;
  Result<Rig> source = LoadAndReport({from});
  if (!source.ok()) return 1;
  derive::Options options;
  options.visemes = sets.empty();
  if (!sets.empty()) {
    if (Status s = derive::ParseShapeSets(source.value(), sets, options); !s.ok())
      return PrintStatus(s), 2;
  }
  if (!landmarks_path.empty()) {
    std::string text;
    if (!ReadFile(landmarks_path, text)) {
      std::fprintf(stderr, "error: cannot read '%s'\n", landmarks_path.c_str());
      return 1;
    }
    auto l = derive::ReadLandmarks(text);
    if (!l.ok()) return PrintStatus(Prefixed(l.status(), landmarks_path + ": ")), 1;
    options.landmarks = std::move(l.value());
  }
  int shown = -1;
  options.progress = [&shown](double f, const char* step) {
    const int pct = static_cast<int>(100 * f);
    if (pct / 10 == shown / 10) return;
    shown = pct;
    std::fprintf(stderr, "derive: %3d%% %s\n", pct, step);
  };
  auto report = derive::DeriveShapes(target.value(), source.value(), options);
  if (!report.ok()) return PrintStatus(report.status()), 1;
  const derive::Report& r = report.value();
  const auto stored = evaluator::Unstored(std::move(target.value()));
  if (int rc = WriteResult(out, RigAsGlb(stored))) return rc;
  const std::string manifest_path = out.substr(0, out.rfind('.')) + ".manifest.json";
  if (int rc = WriteResult(manifest_path, formats::ManifestJson(stored->rig))) return rc;
  std::fprintf(stderr,
               "derive: %zu shapes from '%s' (%s alignment, %zu landmarks, scale %.4g), fit %.3f%% "
               "of the size on average "
               "(95%%: %.3f%%), %zu triangles matched, parts: %zu eyes, %zu rigid, %zu still; %.2f "
               "s CPU -> %s, %s\n",
               r.derived.size(), source->name.c_str(),
               r.alignment == derive::Alignment::kLandmarks ? "landmark" : "shape",
               r.landmarks_used, r.scale, 100 * r.mean_residual, 100 * r.max_residual,
               r.matched_triangles, r.parts_eyes, r.parts_rigid, r.parts_still, r.seconds,
               out.c_str(), manifest_path.c_str());
  if (!r.kept.empty())
    std::fprintf(stderr, "derive: %zu shapes TARGET already had are its own (kept)\n",
                 r.kept.size());
  return 0;
}

int Capture(const std::vector<std::string>& args) {
  std::vector<std::string> positional;
  std::string out;
  Flags flags(
      "usage: facespace capture RIG FRAMES.json -o KEYS.json\n",
      "A face tracker's landmarks over frames as RIG's weights: FRAMES.json is the capture "
      "route's body\n"
      "({\"scheme\": \"mediapipe-478\", \"image\": [w, h], \"fps\": 30, \"frames\": "
      "[[[x, y, z], ...], ...],\n"
      "\"neutral\": 0}: MediaPipe's points in the image's pixels); KEYS.json its answer, the "
      "keys of a\n"
      "sequence ({\"keys\": [{\"time\", \"weights\"}], \"head\": [[x, y, z, w], ...]}), "
      "whose keys the sequence routes and `sequence --keys` take as they are.\n"
      "MediaPipe's canonical face (assets/trackers) is registered onto RIG as a derive "
      "registers a face.\n");
  flags.Text("-o, --output", "KEYS.json", "output (- for stdout)", &out);
  if (int rc = flags.Parse(args, positional); rc >= 0) return rc;
  if (positional.size() != 2 || out.empty())
    return flags.UsageError(out.empty() ? "no output given (-o KEYS.json)"
                                        : "give RIG and FRAMES.json");
  Result<Rig> rig = LoadAndReport({positional[0]});
  if (!rig.ok()) return 1;
  std::string text;
  if (!ReadFile(positional[1], text)) {
    std::fprintf(stderr, "error: cannot read '%s'\n", positional[1].c_str());
    return 1;
  }
  auto request = evaluator::ParseCaptureRequest(text);
  if (!request.ok()) return PrintStatus(Prefixed(request.status(), positional[1] + ": ")), 2;
  Result<Rig> canonical = LoadAndReport({FACESPACE_CANONICAL_FACE});
  if (!canonical.ok()) return 1;
  const double cpu0 = std::clock() / double(CLOCKS_PER_SEC);
  auto map = derive::MapLandmarks(rig.value(), canonical.value(), {});
  if (!map.ok()) return PrintStatus(map.status()), 1;
  const double registered = std::clock() / double(CLOCKS_PER_SEC) - cpu0;
  derive::CaptureOptions o;
  o.fps = request->fps;
  o.neutral = request->neutral;
  auto captured = derive::SolveFrames(map.value(), request->frames, o);
  if (!captured.ok()) return PrintStatus(captured.status()), 2;
  const derive::Captured& c = captured.value();
  const std::string answer = evaluator::CaptureAnswerJson(rig.value(), c.weights, c.head,
                                                          request->fps, map->shapes.size());
  if (int rc = WriteResult(out, answer + "\n")) return rc;
  std::fprintf(stderr,
               "capture: %zu frames on %zu of the rig's shapes; landmarks registered in %.2f s "
               "CPU, %.3f ms a frame -> %s\n",
               c.weights.size(), map->shapes.size(), registered,
               1e3 * c.solve_seconds / static_cast<double>(c.weights.size()), out.c_str());
  return 0;
}

}  // namespace facespace::cli
