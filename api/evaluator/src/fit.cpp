// Fitting: the weights that best reproduce a mesh, as JSON.
#include "facespace/evaluator/answers.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/formats/io.h"

namespace facespace::evaluator {

std::string FitResultJson(const Rig& rig, const FitResult& fit, bool aligned) {
  std::string weights = "{";
  for (size_t s = 0; s < rig.shapes.size(); ++s) {
    weights += std::string(s ? "," : "") + formats::JsonString(rig.shapes[s].name) + ":" +
               FormatNumber(fit.weights[s]);
  }
  std::string residual;
  AnswerWriter<Answer::kResidual>(residual)
      .Number("rms", fit.rms_error)
      .Number("max", fit.max_error)
      .End();
  std::string out;
  AnswerWriter<Answer::kFit> w(out);
  w.Raw("weights", weights + "}").Raw("residual", residual);
  if (aligned) {
    std::string& matrix = w.Open("alignment");
    for (int i = 0; i < 16; ++i) matrix += (i ? "," : "[") + FormatNumber(fit.alignment[i]);
    matrix += "]";
  }
  return w.Raw("warnings", formats::WarningsToJson(fit.warnings)).End() + "\n";
}

Result<Output> ProduceFit(const Rig& rig, const FitRequest& request) {
  std::vector<std::vector<float>> target = request.target.positions;
  if (!request.target.mesh_space) WorldToMeshSpace(rig, target);
  auto fit = FitWeights(rig, target, request.options);
  if (!fit.ok() && fit.status().code == StatusCode::kCancelled) return fit.status();
  if (!fit.ok()) {
    Status s = WithInputReason(fit.status(), kInvalidTarget);
    if (s.fields.empty()) s.fields.push_back({"/target", s.message});
    return s;
  }
  return Output{FitResultJson(rig, fit.value(), request.options.rigid_align), "application/json",
                fit->warnings, 0.0};
}

}  // namespace facespace::evaluator
