// libFuzzer: request JSON -> weights, controls, pose, camera, sequence, batch sampling (and a
// dataset's members), resolved against real rigs (FaceCap; a skinned CesiumMan); or (first byte
// 0xFF) a manifest applied to FaceCap, (0xFE) a derive's body and landmarks, or (0xFD) a capture's
// body, its frames solved on a small landmark map. The first byte picks the schema.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "facespace/derive/capture.h"
#include "facespace/derive/derive.h"
#include "facespace/engine/skeleton.h"
#include "facespace/engine/weights.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/formats/io.h"

namespace {

const facespace::Rig& Rig(bool skinned) {
  static const facespace::Rig face =
      facespace::formats::LoadRigFile(FACESPACE_SOURCE_DIR "/assets/facecap/facecap.glb").value();
  static const facespace::Rig man = [] {
    auto r =
        facespace::formats::LoadRigFile(FACESPACE_SHARED_ASSETS "/real/CesiumMan/CesiumMan.glb");
    return r.ok()
               ? std::move(r.value())
               : facespace::formats::LoadRigFile(FACESPACE_SOURCE_DIR "/assets/facecap/facecap.glb")
                     .value();
  }();
  return skinned ? man : face;
}

// The evaluator's first step (controls, pose, weights, checks), as every route takes it.
void Weigh(const facespace::Rig& rig, const facespace::evaluator::MeshRequest& m) {
  facespace::evaluator::ResolvedPoint point;
  facespace::evaluator::ResolvePoint(rig, m, point);
}

// A landmark map without a registration (which takes seconds under the sanitizers: a slow unit):
// MediaPipe's canonical face as the rest, two shapes, one opening the lips (and their gap), one
// closing the left lids.
const facespace::derive::LandmarkRig& Landmarks() {
  static const facespace::derive::LandmarkRig map = [] {
    using facespace::derive::kMediaPipeFace;
    const facespace::Rig face =
        facespace::formats::LoadRigFile(FACESPACE_SOURCE_DIR
                                        "/assets/trackers/mediapipe/canonical_face_model.obj")
            .value();
    facespace::derive::LandmarkRig m;
    m.rig_shapes = 2;
    m.shapes = {0, 1};
    m.upper = {1, 1};
    m.diag = 20;
    m.found.assign(kMediaPipeFace, 1);
    m.rigid.assign(kMediaPipeFace, 1.0f);
    m.rest.assign(3 * kMediaPipeFace, 0.0f);
    const facespace::Primitive& p = face.primitives[0];
    for (size_t v = 0; v < p.vertex_count(); ++v) {
      const size_t file = p.source_vertices.empty() ? v : p.source_vertices[v];
      for (int c = 0; c < 3 && file < kMediaPipeFace; ++c)
        m.rest[3 * file + c] = p.positions[3 * v + c];
    }
    m.moves.assign(2 * 3 * kMediaPipeFace, 0.0);
    m.moves[3 * 14 + 1] = -1.0;                        // The lower lip down.
    m.moves[3 * kMediaPipeFace + 3 * 386 + 1] = -0.5;  // The left upper lid down.
    m.rigid[14] = m.rigid[386] = 0.02f;
    m.gaps.push_back({13, 14, 0.5, {1.0, 0.0}});
    m.normal = {1.0 + 50.0, 0.0, 0.0, 0.25};
    return m;
  }();
  return map;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string_view body(reinterpret_cast<const char*>(data + 1), size - 1);
  const facespace::Rig& rig = Rig(data[0] & 0x10);
  if (data[0] == 0xFE) {  // A derive's body, and its landmarks as the derive reads them.
    if (auto d = facespace::evaluator::ParseDeriveRequest(body); d.ok() && !d->landmarks.empty())
      (void)facespace::derive::ReadLandmarks(d->landmarks);
    (void)facespace::derive::ReadLandmarks(body);
    return 0;
  }
  if (data[0] == 0xFD) {  // A capture's body, solved.
    if (auto c = facespace::evaluator::ParseCaptureRequest(body); c.ok()) {
      facespace::derive::CaptureOptions o;
      o.fps = c->fps;
      o.neutral = c->neutral;
      (void)facespace::derive::SolveFrames(Landmarks(), c->frames, o);
    }
    return 0;
  }
  if (data[0] == 0xFF) {  // A manifest (an upload's): its regions and landmarks index meshes,
                          // materials, vertices.
    facespace::Rig copy = Rig(false);
    (void)facespace::formats::ApplyManifest(copy, std::string(body));
    return 0;
  }
  using namespace facespace;
  switch (data[0] % 6) {
    case 0:
      if (auto m = evaluator::ParseMeshRequest(body); m.ok()) Weigh(rig, m.value());
      break;
    case 1:
      if (auto r = evaluator::ParseRenderRequest(body); r.ok()) Weigh(rig, r->mesh);
      break;
    case 2:
      if (auto s = evaluator::ParseSheetRequest(body); s.ok()) {
        for (const auto& cell : s->cells) {
          facespace::evaluator::MeshRequest m = s->base.mesh;
          m.weights = cell;
          Weigh(rig, m);
        }
      }
      break;
    case 3:
      if (auto s = evaluator::ParseSequenceRequest(body); s.ok()) {
        if (auto seq = ResolveSequence(rig, s.value()); seq.ok()) {
          std::vector<float> w(rig.shapes.size());
          for (float t : s->times) facespace::SampleSequence(seq.value(), t, w);
        }
      }
      break;
    case 4:
      if (auto b = evaluator::ParseBatchRequest(body); b.ok() && b->sampled) {
        if (auto spec = ResolveSampleSpec(rig, b.value()); spec.ok()) {
          std::vector<float> w(rig.shapes.size());
          const size_t n =
              std::min<size_t>(facespace::SampleCount(spec.value(), rig.shapes.size()), 3);
          for (size_t k = 0; k < n; ++k) facespace::SampleVariant(rig, spec.value(), k, w);
        }
      }
      break;
    case 5:
      if (auto f = evaluator::ParseFitRequest(body); f.ok())
        facespace::evaluator::ProduceFit(rig, f.value());
      break;
  }
  return 0;
}
