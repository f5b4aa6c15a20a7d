// A batch request resolved against one rig: which variants there are, what each is called, and
// each one's point. Every variant's weights are a pure function of the plan and its index, so a
// run can stop, resume, or be split into shards that agree.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/engine/variants.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/evaluator/request.h"

namespace facespace::batch {

struct BatchPlan {
  // Held, not pointed at: a queued plan outlives the store's entry when the rig is uploaded again
  // (even with the same bytes, so the same version) or deleted while the job waits.
  std::shared_ptr<const evaluator::StoredRig> rig;
  evaluator::BatchRequest request;
  SampleSpec sample;                        // When request.sampled.
  std::vector<std::vector<float>> weights;  // Explicit variants, resolved.
  size_t total = 0;
  std::string spec_json;  // batch.json: {"request": ..., "rig": ..., "rig_version": ...}
  Pose pose;              // The request's pose, shared by every variant.
  bool posed = false;
  std::vector<Warning> pose_warnings;
  // What the request's expressions (and a gaze through eye shapes) add to every variant's weights.
  std::vector<float> face_weights;
  evaluator::OutputSpec output;  // Every variant's file (a mesh in pieces, or a render).
  // Labelled samples (request.dataset, dataset.h).
  std::vector<float>
      bare_weights;  // The pose's weights without the face: a drawn face is added to them.
  std::vector<uint32_t> segment_of_primitive;
  std::vector<std::string> segment_names;  // By id; 0 is "background".
  uint64_t draw_seed = 1;                  // randomize.seed, else the sample's seed.
  std::string pose_json = "{}";            // The request's pose members, for every KEY.json.
  // randomize.background.images, loaded (LoadBackgroundImages): each picture scaled to cover the
  // render's size, as 8-bit sRGB and as linear floats, so a sample only blends.
  struct Background {
    std::string name;
    std::vector<unsigned char> srgb8;  // RGB, width x height.
    std::vector<float> linear;         // RGB.
  };
  std::vector<Background> backgrounds;
  bool labelled() const { return request.dataset.labelled(); }
};

// Parses and resolves a batch body (evaluator::ParseBatchRequest's schema) against a rig (the pose
// must resolve too). `rig->version` identifies the rig's content, so a rerun against another rig is
// refused.
Result<BatchPlan> MakeBatchPlan(std::shared_ptr<const evaluator::StoredRig> rig,
                                std::string_view request_json);

std::string VariantId(const BatchPlan& plan, size_t index);    // The given id, else "v" + 6 digits.
std::string VariantFile(const BatchPlan& plan, size_t index);  // id + "." + the format's extension.

// Variant `index` as a point: its weights and the plan's pose, checked (the pose's warnings last).
void VariantPoint(const BatchPlan& plan, size_t index, evaluator::ResolvedPoint& point);
// The same unchecked, for a caller that changes the point before checking it (a sample's drawn
// face).
void VariantWeights(const BatchPlan& plan, size_t index, evaluator::ResolvedPoint& point);

// The contact sheet of the variants `indices`, labelled with their ids: 256 x 256 cells, PNG.
Result<std::string> VariantSheet(const BatchPlan& plan, std::span<const size_t> indices,
                                 const evaluator::Evaluator& evaluator, evaluator::Workspace& ws);

}  // namespace facespace::batch
