// Speech requests: text (espeak-ng) or audio (PocketSphinx) to phonemes, visemes and the keys that
// speak them on a rig (core/speech.h), and their JSON.
#include "facespace/lipsync/lipsync.h"

#include "facespace/evaluator/answers.h"
#include "facespace/formats/io.h"
#include "facespace/offscreen/video.h"

namespace facespace::lipsync {

using namespace evaluator;  // The evaluator's points, specs and sequences.

Result<SpeechPlan> PlanSpeech(const Rig& rig, const evaluator::SpeechRequest& request,
                              const std::stop_token& stop) {
  if (Status s = CanSpeak(rig); !s.ok()) return s;
  SpeechPlan plan;
  if (request.has_audio) {
    auto audio = speech::ReadWav(request.audio);
    if (!audio.ok()) return audio.status();
    plan.audio = std::move(audio.value());
    if (plan.audio.samples.empty())
      return WithReason(InvalidArgument("/audio: has no samples"), "invalid-audio");
    auto heard = speech::Recognize(plan.audio, {.transcript = request.transcript, .stop = stop});
    if (!heard.ok()) return heard.status();
    plan.phonemes = std::move(heard->phonemes);
    plan.warnings = std::move(heard->warnings);
    plan.voiced_seconds = heard->voiced_seconds;
    const bool aligned =
        !request.transcript.empty() &&
        std::none_of(plan.warnings.begin(), plan.warnings.end(),
                     [](const Warning& w) { return w.code == "transcript_not_aligned"; });
    plan.source = aligned ? "pocketsphinx-aligned" : "pocketsphinx";
  } else {
    auto spoken = speech::Synthesize(
        request.text, {.voice = request.voice, .rate = request.rate, .stop = stop, .on_chunk = {}});
    if (!spoken.ok()) return spoken.status();
    plan.audio = std::move(spoken->audio);
    plan.phonemes = std::move(spoken->phonemes);
    plan.voice = std::move(spoken->voice);
    plan.source = "espeak-ng";
  }
  plan.visemes = VisemesOfUtterance(plan.phonemes, plan.audio.seconds());
  // The face under the speech.
  evaluator::ResolvedPoint base;
  if (Status s = ResolvePoint(rig, request.render.mesh, base); !s.ok()) return s;
  plan.warnings.insert(plan.warnings.end(), base.report.warnings.begin(),
                       base.report.warnings.end());
  SpeechOptions options;
  options.min_hold = 1.0f / request.fps;
  options.strength = request.strength;
  plan.sequence = SpeechSequence(rig, plan.visemes, base.weights, options);
  evaluator::AttachFace(rig, request.gaze, request.blink, request.blink_per_minute,
                        request.blink_seed, plan.sequence);
  return plan;
}

namespace {

std::string Base64(std::string_view in) {
  static constexpr char kDigits[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  for (size_t i = 0; i < in.size(); i += 3) {
    const size_t n = std::min<size_t>(3, in.size() - i);
    uint32_t v = 0;
    for (size_t k = 0; k < 3; ++k)
      v = (v << 8) | (k < n ? static_cast<unsigned char>(in[i + k]) : 0u);
    for (size_t k = 0; k < 4; ++k) out += k <= n ? kDigits[(v >> (18 - 6 * k)) & 63] : '=';
  }
  return out;
}

}  // namespace

std::vector<Warning> SpeechWarnings(const SpeechPlan& plan) {
  std::vector<Warning> warnings = plan.warnings;
  warnings.insert(warnings.end(), plan.sequence.warnings.begin(), plan.sequence.warnings.end());
  return warnings;
}

std::string SpeechJson(const Rig& rig, const SpeechPlan& plan, float fps, bool with_audio) {
  using evaluator::Answer;
  using evaluator::AnswerWriter;
  std::string out;
  AnswerWriter<Answer::kSpeech> w(out);
  w.Raw("source", formats::JsonString(plan.source));
  if (!plan.voice.empty()) w.Raw("voice", formats::JsonString(plan.voice));
  w.Number("duration", plan.audio.seconds())
      .Number("fps", fps)
      .Count("frames", evaluator::FrameCount(plan.sequence, fps));
  if (plan.source != "espeak-ng") w.Number("voiced_seconds", plan.voiced_seconds);
  std::string& phonemes = w.Open("phonemes");
  for (size_t i = 0; i < plan.phonemes.size(); ++i) {
    const TimedPhoneme& p = plan.phonemes[i];
    phonemes += i ? ',' : '[';
    AnswerWriter<Answer::kTimedPhoneme>(phonemes)
        .Raw("name", formats::JsonString(p.name))
        .Number("start", p.start)
        .Number("end", p.end)
        .End();
  }
  if (plan.phonemes.empty()) phonemes += '[';
  phonemes += ']';
  std::string& visemes = w.Open("visemes");
  for (size_t i = 0; i < plan.visemes.size(); ++i) {
    visemes += i ? ',' : '[';
    visemes += TimedVisemeJson(plan.visemes[i], 0.0);
  }
  if (plan.visemes.empty()) visemes += '[';
  visemes += ']';
  w.Raw("keys", evaluator::SequenceKeysJson(rig, plan.sequence))
      .Raw("transition", formats::JsonString(TransitionName(plan.sequence.transition)))
      .Raw("warnings", formats::WarningsToJson(SpeechWarnings(plan)));
  if (with_audio) w.Raw("audio_wav", "\"" + Base64(speech::WriteWav(plan.audio)) + "\"");
  return w.End() + "\n";
}

std::string TimedVisemeJson(const TimedViseme& v, double clock) {
  std::string out;
  return evaluator::AnswerWriter<evaluator::Answer::kTimedViseme>(out)
      .Raw("viseme", "\"" + std::string(VisemeName(v.viseme)) + "\"")
      .Number("start", clock + v.start)
      .Number("end", clock + v.end)
      .End();
}

Result<std::string> SpeechVideo(const evaluator::Evaluator& evaluator,
                                const std::shared_ptr<const evaluator::StoredRig>& stored,
                                const SpeechPlan& plan, const evaluator::SpeechRequest& request,
                                evaluator::Workspace& ws,
                                const std::function<void(size_t)>& on_frame) {
  offscreen::VideoOptions video;
  video.width = request.render.render.width;
  video.height = request.render.render.height;
  video.fps = request.fps;
  video.helper_cpu = ws.helper_cpu;
  auto encoder = offscreen::WebmEncoder::Start(video, plan.audio.samples, plan.audio.rate);
  if (!encoder.ok()) return encoder.status();
  const Rig& rig = stored->rig;
  const Sequence& seq = plan.sequence;
  const evaluator::OutputSpec spec = evaluator::OutputSpec::Pixels(request.render);
  evaluator::SequencePhysics physics(rig, seq);
  evaluator::ResolvedPoint point;
  const size_t frames = evaluator::FrameCount(seq, request.fps);
  const float start = seq.keys.empty() ? 0.0f : seq.keys.front().time;
  for (size_t i = 0; i < frames; ++i) {
    if (ws.stop.stop_requested()) return Cancelled();
    const float t = start + static_cast<float>(static_cast<double>(i) / request.fps);
    SequencePoint(rig, seq, t, request.render.mesh.options.mode, point, &physics);
    auto drawn = evaluator.Run(stored, point, spec, ws);
    if (!drawn.ok()) return drawn.status();
    if (Status s = encoder.value()->Add(ws.image); !s.ok()) return s;
    if (on_frame) on_frame(i);
  }
  return encoder.value()->Finish();
}

}  // namespace facespace::lipsync
