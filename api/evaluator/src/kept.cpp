#include "kept.h"

#include "facespace/engine/shape_tools.h"
#include "facespace/formats/lod.h"

namespace facespace::evaluator {

std::shared_ptr<const DerivedRig> DerivedRigs::At(const std::shared_ptr<const StoredRig>& stored,
                                                  int lod) {
  if (lod < 0 || lod > formats::kMaxLod) return nullptr;
  const std::shared_ptr<const Rig> own(stored, &stored->rig);
  std::shared_ptr<const DerivedRig> kept;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (auto* levels = derived_.Find(own)) kept = (*levels)[lod];
  }
  if (!kept) {  // Made outside the lock: a large rig takes a while.
    auto d = std::make_shared<DerivedRig>();
    std::shared_ptr<const Rig> rig = own;
    if (lod > 0) {
      auto made = formats::MakeLod(stored->rig, lod);
      if (!made.ok()) return nullptr;
      rig = d->rig = std::make_shared<const Rig>(std::move(made.value()));
    }
    d->has_focus = ShapeFocusBox(*rig, d->focus_min, d->focus_max);
    d->focus_small = d->has_focus && FrameShapesByDefault(*rig, d->focus_min, d->focus_max);
    d->focus_joint = d->focus_small ? ShapeFocusJoint(*rig) : -1;
    std::lock_guard<std::mutex> lock(mu_);
    auto& slot = derived_.At(own)[lod];
    if (!slot) slot = std::move(d);
    kept = slot;
  }
  if (lod > 0) return kept;
  auto at_rest = std::make_shared<DerivedRig>(*kept);
  at_rest->rig = own;
  return at_rest;
}

std::shared_ptr<const Rig> DerivedRigs::RigAt(const std::shared_ptr<const StoredRig>& stored,
                                              int lod) {
  if (lod == 0) return std::shared_ptr<const Rig>(stored, &stored->rig);
  auto d = At(stored, lod);
  return d ? d->rig : nullptr;
}

std::shared_ptr<const RigOcclusion> DerivedRigs::Occlusion(
    const std::shared_ptr<const StoredRig>& stored, int lod) {
  if (lod < 0 || lod > formats::kMaxLod) return nullptr;
  const std::shared_ptr<const Rig> own(stored, &stored->rig);
  auto kept = [&]() -> std::shared_ptr<const RigOcclusion> {
    std::lock_guard<std::mutex> lock(mu_);
    auto* levels = occlusion_.Find(own);
    return levels ? (*levels)[static_cast<size_t>(lod)] : nullptr;
  };
  if (auto found = kept()) return found;
  std::lock_guard<std::mutex> baking(bake_mu_);
  if (auto found = kept()) return found;  // Baked while this one waited.
  const std::shared_ptr<const Rig> rig = RigAt(stored, lod);
  if (!rig) return nullptr;
  BlendedRig rest;
  BlendContext context;
  const std::vector<float> neutral(rig->shapes.size(), 0.0f);
  if (!EvaluateRig(*rig, neutral, BlendOptions{}, rest, context).ok()) return nullptr;
  auto baked =
      std::make_shared<const RigOcclusion>(BakeRigOcclusion(*rig, rest, OcclusionSettings{}));
  std::lock_guard<std::mutex> lock(mu_);
  occlusion_.At(own)[static_cast<size_t>(lod)] = baked;
  return baked;
}

void DerivedRigs::Prepare(const std::shared_ptr<const StoredRig>& stored, int lod,
                          picture::RenderOptions& options) {
  const picture::View view = options.view;
  if (view == picture::View::kShaded || view == picture::View::kWireframe ||
      view == picture::View::kClay)
    options.occlusion = Occlusion(stored, lod);
  picture::Camera& camera = options.camera;
  if (camera.frame == picture::Framing::kAll) return;
  if (auto d = At(stored, lod); d && d->has_focus) {
    camera.has_focus = true;
    camera.focus_small = d->focus_small;
    camera.focus_min = d->focus_min;
    camera.focus_max = d->focus_max;
    camera.focus_joint = d->focus_joint;
  }
}

GlbWriters::Lease GlbWriters::Acquire(const std::shared_ptr<const Rig>& rig) {
  std::unique_ptr<formats::GlbVariantWriter> writer;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (auto* free = free_.Find(rig); free && !free->empty()) {
      writer = std::move(free->back());
      free->pop_back();
    }
  }
  if (!writer) writer = std::make_unique<formats::GlbVariantWriter>();
  return Lease(*this, rig, std::move(writer));
}

void GlbWriters::Release(const std::shared_ptr<const Rig>& rig,
                         std::unique_ptr<formats::GlbVariantWriter> writer) {
  std::lock_guard<std::mutex> lock(mu_);
  auto& free = free_.At(rig);
  if (free.size() < kKeptPerRig) free.push_back(std::move(writer));
}

std::shared_ptr<const formats::F32Writer> F32Writers::Get(const std::shared_ptr<const Rig>& rig,
                                                          bool mesh_space) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (auto* kept = writers_.Find(rig); kept && (*kept)[mesh_space]) return (*kept)[mesh_space];
  }
  auto made = std::make_shared<const formats::F32Writer>(
      *rig, mesh_space);  // Outside the lock: a large rig takes a while.
  std::lock_guard<std::mutex> lock(mu_);
  auto& kept = writers_.At(rig)[mesh_space];
  if (!kept) kept = std::move(made);
  return kept;
}

}  // namespace facespace::evaluator
