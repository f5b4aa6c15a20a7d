// /v1/rigs/{id}/speech: lip sync from text (espeak-ng) or recorded speech (PocketSphinx), as keys,
// audio, a stream of frames or a video; /v1/voices: what text can be spoken with.
#include "../http/cost.h"
#include "../http/problem.h"
#include "facespace/lipsync/lipsync.h"
#include "routes.h"

namespace facespace::http {

namespace {

// The request's cost before any speech is made: the audio's seconds and rate from its chunks alone,
// or the text's length in seconds at its rate (its words, or characters / 6 for a script without
// spaces).
bool SpeechWithinBudget(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                        const Rig& rig, const evaluator::SpeechRequest& r) {
  double seconds = 0.0;
  int rate = 16000;
  if (r.has_audio) {
    auto layout = speech::ReadWavLayout(r.audio);
    if (!layout.ok()) return SendStatus(req, res, layout.status()), false;
    seconds = std::min(layout->seconds(), static_cast<double>(speech::kMaxAudioSeconds));
    rate = layout->rate * std::max<int>(1, layout->channels);
  } else {
    const double units = std::max(static_cast<double>(speech::CountWords(r.text)),
                                  static_cast<double>(r.text.size()) / 6.0);
    seconds = 0.5 + units * 60.0 / std::max(80, r.rate);
  }
  return WithinBudget(ctx, req, res, SpeechCost(rig, r, seconds, rate));
}

bool IsAudioBody(const httplib::Request& req) {
  const std::string type = req.get_header_value("Content-Type");
  return type.rfind("audio/", 0) == 0 || speech::LooksLikeWav(req.body);
}

// The video: within the frame limit and the render budget (for the whole encode), drawn as it goes.
void SendSpeechVideo(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                     const std::shared_ptr<const evaluator::StoredRig>& stored,
                     const lipsync::SpeechPlan& plan, const evaluator::SpeechRequest& r) {
  const size_t frames = evaluator::FrameCount(plan.sequence, r.fps);
  // A video is drawn whole before it is sent: at most --max-video-seconds (its cost was admitted
  // already).
  const float max_seconds = ctx.options.max_video_seconds;
  if (plan.audio.seconds() > max_seconds) {
    const std::string field = r.has_audio ? "/audio" : "/text";
    return SendProblem(
        req, res, Problem::kVideoTooLong,
        field + ": a video is at most " + FormatNumber(max_seconds) + " s, and this speech is " +
            FormatNumber(plan.audio.seconds()) +
            " s; say less at once, or ask for json, wav or a stream of frames",
        {{field, "at most " + FormatNumber(max_seconds) + " s of speech as a video"}});
  }
  if (!WithinFrameLimit(ctx, req, res, frames, "video", "the speech's") ||
      !CheckRenderBudget(ctx, req, res, r.render.render, 1))
    return;
  const WorkspacePool::Lease ws = ctx.workspaces.Acquire(req);
  std::string video;
  auto encoded = WithinRenderBudget(
      ctx, RenderBudget::Estimate(r.render.render, 1), [&]() -> Result<evaluator::Encoded> {
        auto bytes = lipsync::SpeechVideo(ctx.evaluator, stored, plan, r, *ws);
        if (!bytes.ok()) return bytes.status();
        video = std::move(bytes.value());
        return evaluator::Encoded{};
      });
  if (!encoded.ok()) return SendStatus(req, res, encoded.status());
  ctx.metrics.CountBlends(frames);
  res.status = 200;
  res.set_header("Facespace-Frames", std::to_string(frames));
  res.set_content(std::move(video), "video/webm");
}

}  // namespace

void PostSpeech(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  if (!stored) return;
  evaluator::SpeechRequest r;
  if (IsAudioBody(req)) {
    std::vector<std::pair<std::string, std::string>> settings(req.params.begin(), req.params.end());
    auto parsed = evaluator::SpeechRequestOfWav(req.body, settings);
    if (!parsed.ok()) return SendStatus(req, res, parsed.status());
    r = std::move(parsed.value());
  } else if (!ReadJsonBody(req, res, evaluator::ParseSpeechRequest, r)) {
    return;
  }
  AttachVocabulary(ctx, r.render.mesh);
  const picture::RenderOptions& size = r.render.render;
  if (r.format == evaluator::FrameFormat::kWebm &&
      static_cast<long long>(size.width) * size.height > ctx.options.max_video_pixels) {
    return SendProblem(
        req, res, Problem::kInvalidRequest,
        "/width: a video is at most " + std::to_string(ctx.options.max_video_pixels) +
            " pixels (1920 x 1080)",
        {{"/width", "width x height at most " + std::to_string(ctx.options.max_video_pixels)}});
  }
  if (!SpeechWithinBudget(ctx, req, res, stored->rig, r)) return;
  auto plan = lipsync::PlanSpeech(stored->rig, r, net::StopOf(req));
  if (!plan.ok()) return SendStatus(req, res, plan.status());
  // Text was priced by its words; now that it is spoken, by its real length (espeak-ng reads digits
  // as long numbers: 130 bytes were 64 s of speech, priced as 8), before any frame is drawn.
  if (!r.has_audio &&
      !WithinBudget(ctx, req, res, SpeechCost(stored->rig, r, plan->audio.seconds(), 16000)))
    return;
  if (const std::vector<Warning> warnings = lipsync::SpeechWarnings(plan.value());
      !warnings.empty())
    res.set_header("Facespace-Warnings", WarningsHeader(warnings));
  res.set_header("Facespace-Duration", FormatNumber(plan->audio.seconds()));
  if (r.format == evaluator::FrameFormat::kJson) {
    res.status = 200;
    res.set_content(lipsync::SpeechJson(stored->rig, plan.value(), r.fps, r.with_audio),
                    "application/json");
  } else if (r.format == evaluator::FrameFormat::kWav) {
    res.status = 200;
    res.set_content(speech::WriteWav(plan->audio), "audio/wav");
  } else if (r.format == evaluator::FrameFormat::kWebm) {
    SendSpeechVideo(ctx, req, res, stored, plan.value(), r);
  } else {
    auto seq = std::make_shared<const Sequence>(std::move(plan->sequence));
    SendSequenceStream(ctx, req, res, stored, seq, r.fps, r.format, r.render.mesh.options);
  }
}

void GetVoices(ServerState&, const httplib::Request&, httplib::Response& res) {
  nlohmann::json voices = nlohmann::json::array();
  for (const speech::VoiceInfo& v : speech::Voices())
    voices.push_back({{"name", v.name}, {"language", v.language}});
  res.set_header("Cache-Control", "max-age=3600");
  SendJson(res, 200, {{"voices", std::move(voices)}, {"default", kDefaultVoice}});
}

}  // namespace facespace::http
