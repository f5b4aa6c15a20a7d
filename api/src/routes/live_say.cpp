#include "live_say.h"

#include <nlohmann/json.hpp>

#include "facespace/core/weights.h"
#include "facespace/speech/speech.h"

namespace facespace::api::http {

namespace {

using Clock = std::chrono::steady_clock;
constexpr size_t kChunkSamples = 2205;  // 0.1 s at espeak-ng's 22,050 Hz: an audio message.

// The phonemes whose end is known: each event's but the last's, which ends where that one starts.
std::vector<TimedPhoneme> FinishedPhonemes(std::span<const std::pair<int, std::string>> events) {
  if (events.size() < 2) return {};
  return speech::PhonemesOfEvents(events.first(events.size() - 1), events.back().first / 1000.0f);
}

}  // namespace

std::string ErrorEvent(const std::string& type, const std::string& detail, const std::string& pointer) {
  nlohmann::json e = {{"event", "error"}, {"type", type}, {"detail", detail}};
  if (!pointer.empty()) e["pointer"] = pointer;
  return e.dump();
}

std::string VisemeEvent(const TimedViseme& v, double clock) {
  return "{\"viseme\":\"" + std::string(VisemeName(v.viseme)) + "\",\"start\":" + FormatNumber(clock + v.start) + ",\"end\":" +
         FormatNumber(clock + v.end) + "}";
}

struct LiveSpeaker::Utterance {
  int rate = 22050;
  std::vector<int16_t> samples;
  std::vector<std::pair<int, std::string>> events;
  std::vector<TimedViseme> visemes;  // Those known for sure so far; all of them once made.
  size_t sent_samples = 0, sent_visemes = 0;
  double clock = 0;                  // The session's audio clock at its first sample.
  Clock::time_point wall;            // When its first sample plays (is sent).
  bool started = false;
};

LiveSpeaker::~LiveSpeaker() { Close(); }

void LiveSpeaker::Close() {
  std::jthread thread;
  {
    std::lock_guard<std::mutex> lock(mu_);
    closed_ = true;
    queue_.clear();
    queued_chars_ = 0;
    utterance_.request_stop();
    thread = std::move(thread_);
  }
  if (thread.joinable()) {
    thread.request_stop();
    cv_.notify_all();
    thread.join();
  }
}

Status LiveSpeaker::Say(std::string text, std::string voice, int rate) {
  if (text.empty() || text.size() > 4 * speech::kMaxTextChars) return InvalidField("/say/text", "must be 1 to 2,000 characters of text to speak");
  if (rate < 80 || rate > 450) return InvalidField("/say/rate", std::to_string(rate) + " words a minute; from 80 to 450");
  std::lock_guard<std::mutex> lock(mu_);
  if (closed_) return Cancelled();
  if (queued_chars_ + text.size() > kMaxQueuedChars) {
    return WithReason(InvalidField("/say/text", "more than " + std::to_string(kMaxQueuedChars) + " characters waiting to be spoken; wait, or stop",
                                   StatusCode::kResourceExhausted),
                      "say-queue-full");
  }
  queued_chars_ += text.size();
  queue_.push_back({std::move(text), std::move(voice), rate});
  if (!thread_.joinable()) thread_ = std::jthread([this](std::stop_token stop) { Run(stop); });
  cv_.notify_all();
  return Status::Ok();
}

bool LiveSpeaker::Stop() {
  std::lock_guard<std::mutex> lock(mu_);
  const bool any = speaking_ || !queue_.empty();
  queue_.clear();
  queued_chars_ = 0;
  utterance_.request_stop();
  cv_.notify_all();
  return any;
}

void LiveSpeaker::Run(std::stop_token stop) {
  while (!stop.stop_requested()) {
    Piece piece;
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, stop, [this] { return !queue_.empty(); });
      if (stop.stop_requested()) return;
      piece = std::move(queue_.front());
      queue_.pop_front();
      queued_chars_ -= piece.text.size();
      speaking_ = true;
      utterance_ = std::stop_source();
    }
    Speak(piece, stop);
    std::lock_guard<std::mutex> lock(mu_);
    speaking_ = false;
  }
}

// Sends the audio due (up to kLead ahead of real time) and the visemes that start within it; the
// seconds until more is due, or 0 when everything made is out.
double LiveSpeaker::Send(Utterance& u, bool all_made) {
  if (!u.started) return 0;
  const double played = std::chrono::duration<double>(Clock::now() - u.wall).count();
  const size_t due = std::min(u.samples.size(), static_cast<size_t>((played + kLead) * u.rate));
  while (u.sent_samples < due && (all_made || due - u.sent_samples >= kChunkSamples || u.samples.size() == due)) {
    const size_t n = std::min(kChunkSamples, due - u.sent_samples);
    std::string m("pcm1", 4);
    PutU32(m, ++chunk_);
    PutU32(m, static_cast<uint32_t>(u.rate));
    PutU32(m, static_cast<uint32_t>(std::llround(u.clock * u.rate)) + static_cast<uint32_t>(u.sent_samples));
    for (size_t i = 0; i < n; ++i) {
      const auto s = static_cast<uint16_t>(u.samples[u.sent_samples + i]);
      m.push_back(static_cast<char>(s & 0xFF));
      m.push_back(static_cast<char>(s >> 8));
    }
    post_(ws::Opcode::kBinary, m);
    u.sent_samples += n;
  }
  const double sent_to = static_cast<double>(u.sent_samples) / u.rate;
  const bool audio_out = all_made && u.sent_samples == u.samples.size();
  while (u.sent_visemes < u.visemes.size() && (audio_out || u.visemes[u.sent_visemes].start < sent_to)) {
    Post(VisemeEvent(u.visemes[u.sent_visemes++], u.clock));
  }
  if (audio_out && u.sent_visemes == u.visemes.size()) return 0;
  return std::max(0.01, sent_to - kLead - played);
}

void LiveSpeaker::Speak(const Piece& piece, std::stop_token stop) {
  Utterance u;
  u.clock = clock_;
  const std::stop_token halt = utterance_.get_token();
  std::stop_callback forward(stop, [this] { utterance_.request_stop(); });
  Post(nlohmann::json{{"event", "say"}, {"state", "start"}, {"clock", clock_}}.dump());
  speech::SynthOptions options{.voice = piece.voice, .rate = piece.rate, .stop = halt, .on_chunk = {}};
  options.on_chunk = [&](int rate, std::span<const int16_t> samples, std::span<const std::pair<int, std::string>> events) {
    u.rate = rate;
    if (!u.started && !samples.empty()) u.started = true, u.wall = Clock::now();
    u.samples.insert(u.samples.end(), samples.begin(), samples.end());
    u.events.insert(u.events.end(), events.begin(), events.end());
    // Visemes sure not to change as more speech comes: all but the last three of those known.
    std::vector<TimedViseme> known = VisemesOfUtterance(FinishedPhonemes(u.events), 0.0f);
    if (known.size() > 3) {
      known.resize(known.size() - 3);
      if (known.size() > u.visemes.size()) u.visemes = std::move(known);
    }
    Send(u, false);
  };
  auto spoken = speech::Synthesize(piece.text, options);
  if (!spoken.ok()) {
    const Status& s = spoken.status();
    if (s.code != StatusCode::kCancelled) {
      Post(ErrorEvent(s.reason.empty() ? "say-failed" : s.reason, s.message, s.fields.empty() ? "/say" : "/say" + s.fields[0].pointer));
    }
  } else {
    // The whole utterance's visemes, as the speech route makes them; those sent are its first ones.
    u.visemes = VisemesOfUtterance(spoken->phonemes, spoken->audio.seconds());
    if (!u.started) u.started = true, u.wall = Clock::now();
    for (double wait = Send(u, true); wait > 0 && !halt.stop_requested(); wait = Send(u, true)) {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait_for(lock, halt, std::chrono::duration<double>(wait), [] { return false; });
    }
  }
  const bool stopped = halt.stop_requested();
  clock_ += static_cast<double>(u.sent_samples) / u.rate;
  Post(nlohmann::json{{"event", "say"}, {"state", stopped ? "stopped" : "end"}, {"clock", clock_}}.dump());
}

}  // namespace facespace::api::http
