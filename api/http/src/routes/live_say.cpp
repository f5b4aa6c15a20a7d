#include "live_say.h"

#include <cstring>
#include <nlohmann/json.hpp>

#include "facespace/engine/weights.h"
#include "facespace/lipsync/lipsync.h"
#include "facespace/speech/speech.h"

namespace facespace::http {

namespace {

using Clock = std::chrono::steady_clock;
constexpr size_t kChunkSamples = 2205;  // 0.1 s at espeak-ng's 22,050 Hz: an audio message.

// The phonemes whose end is known: each event's but the last's, which ends where that one starts.
std::vector<TimedPhoneme> FinishedPhonemes(std::span<const std::pair<int, std::string>> events) {
  if (events.size() < 2) return {};
  return speech::PhonemesOfEvents(events.first(events.size() - 1), events.back().first / 1000.0f);
}

// About how long a word takes to say at `rate` words a minute: espeak-ng reads digits as numbers
// ("999999999999" is seven seconds), letters at about 14 a second.
double WordSeconds(std::string_view word, int rate) {
  double digits = 0, others = 0;
  for (char c : word) (c >= '0' && c <= '9' ? digits : others) += 1;
  return (0.7 * digits + 0.075 * others + 0.05) * 175.0 / std::max(rate, 1);
}

bool EndsSentence(std::string_view word) {
  while (!word.empty() && (word.back() == '"' || word.back() == '\'' || word.back() == ')'))
    word.remove_suffix(1);
  return !word.empty() && std::strchr(".!?;:", word.back()) != nullptr;
}

}  // namespace

std::atomic<size_t>& HeldBytes() {
  static std::atomic<size_t> held{0};
  return held;
}

std::vector<std::string> SpeechSegments(std::string_view text, int rate) {
  std::vector<std::string> out;
  std::string segment;
  double seconds = 0;
  size_t sentence_end = 0;  // Of `segment`: where its last whole sentence ends (0: none yet) ...
  double sentence_seconds = 0;  // ... and how long those sentences take.
  for (size_t at = 0; at < text.size();) {
    const size_t begin = text.find_first_not_of(" \t\r\n", at);
    if (begin == std::string_view::npos) break;
    const size_t end = std::min(text.size(), text.find_first_of(" \t\r\n", begin));
    const std::string_view word = text.substr(begin, end - begin);
    at = end;
    const double w = WordSeconds(word, rate);
    if (!segment.empty() && seconds + w > LiveSpeaker::kSegmentSeconds) {
      // Too long with this word: cut after the last whole sentence, else here.
      const size_t cut = sentence_end > 0 ? sentence_end : segment.size();
      out.push_back(segment.substr(0, cut));
      segment.erase(0, std::min(segment.size(), cut + 1));
      seconds -= sentence_end > 0 ? sentence_seconds : seconds;
      sentence_end = 0;
    }
    segment.append(segment.empty() ? "" : " ").append(word);
    seconds += w;
    if (EndsSentence(word)) sentence_end = segment.size(), sentence_seconds = seconds;
  }
  if (!segment.empty()) out.push_back(std::move(segment));
  return out;
}

std::string ErrorEvent(const std::string& type, const std::string& detail,
                       const std::string& pointer) {
  nlohmann::json e = {{"event", "error"}, {"type", type}, {"detail", detail}};
  if (!pointer.empty()) e["pointer"] = pointer;
  return e.dump();
}

std::string StatusEvent(const Status& s, const std::string& where) {
  return ErrorEvent(s.reason.empty() ? "invalid-message" : s.reason, s.message,
                    s.fields.empty() ? where : s.fields[0].pointer);
}

Status FieldErrors(Status s) {
  s.code = StatusCode::kInvalidArgument;
  if (!s.fields.empty()) s.message = s.fields[0].message;
  return s;
}

struct LiveSpeaker::Utterance {
  int rate = 22050;
  std::vector<int16_t> pending;  // Made and not yet sent: the samples from sent_samples on.
  size_t made = 0, sent_samples = 0;
  std::vector<TimedViseme>
      visemes;  // On the piece's clock: the finished segments', then the current one's sure ones.
  size_t sent_visemes = 0;
  size_t segment_visemes = 0;  // Where the current segment's visemes begin.
  double segment_start = 0;    // Seconds into the piece where the current segment begins.
  double clock = 0;            // The session's audio clock at its first sample.
  Clock::time_point wall;      // When its first sample plays (is sent).
  bool started = false;
  ~Utterance() { HeldBytes() -= pending.size() * sizeof(int16_t); }
  double seconds_made() const { return static_cast<double>(made) / rate; }
  double played() const {
    return started ? std::chrono::duration<double>(Clock::now() - wall).count() : 0.0;
  }
  // The current segment's visemes (on its own clock) in place of those it had, when they are more.
  void SetSegmentVisemes(std::vector<TimedViseme> v, bool final) {
    if (!final && v.size() <= visemes.size() - segment_visemes) return;
    for (TimedViseme& t : v)
      t.start += static_cast<float>(segment_start), t.end += static_cast<float>(segment_start);
    visemes.resize(segment_visemes);
    visemes.insert(visemes.end(), v.begin(), v.end());
    sent_visemes = std::min(sent_visemes, visemes.size());
  }
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
  if (text.empty() || text.size() > 4 * speech::kMaxTextChars)
    return InvalidField("/say/text", "must be 1 to 2,000 characters of text to speak");
  if (rate < 80 || rate > 450)
    return InvalidField("/say/rate", std::to_string(rate) + " words a minute; from 80 to 450");
  std::lock_guard<std::mutex> lock(mu_);
  if (closed_) return Cancelled();
  if (queued_chars_ + text.size() > kMaxQueuedChars) {
    return WithReason(InvalidField("/say/text",
                                   "more than " + std::to_string(kMaxQueuedChars) +
                                       " characters waiting to be spoken; wait, or stop",
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
  cpu_mark_ = ThreadCpuSeconds();
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
// seconds until more is due, or 0 when everything made is out. What is sent is let go.
double LiveSpeaker::Send(Utterance& u, bool all_made) {
  if (!u.started) return 0;
  const double played = u.played();
  const size_t due = std::min(u.made, static_cast<size_t>((played + kLead) * u.rate));
  size_t taken = 0;  // Of u.pending.
  while (u.sent_samples < due &&
         (all_made || due - u.sent_samples >= kChunkSamples || u.made == due)) {
    const size_t n = std::min(kChunkSamples, due - u.sent_samples);
    std::string m("pcm1", 4);
    PutU32(m, ++chunk_);
    PutU32(m, static_cast<uint32_t>(u.rate));
    PutU32(m, static_cast<uint32_t>(std::llround(u.clock * u.rate)) +
                  static_cast<uint32_t>(u.sent_samples));
    for (size_t i = 0; i < n; ++i) {
      const auto s = static_cast<uint16_t>(u.pending[taken + i]);
      m.push_back(static_cast<char>(s & 0xFF));
      m.push_back(static_cast<char>(s >> 8));
    }
    post_(net::ws::Opcode::kBinary, m);
    u.sent_samples += n;
    taken += n;
  }
  u.pending.erase(u.pending.begin(), u.pending.begin() + static_cast<std::ptrdiff_t>(taken));
  HeldBytes() -= taken * sizeof(int16_t);
  const double sent_to = static_cast<double>(u.sent_samples) / u.rate;
  const bool audio_out = all_made && u.sent_samples == u.made;
  while (u.sent_visemes < u.visemes.size() &&
         (audio_out || u.visemes[u.sent_visemes].start < sent_to)) {
    Post(lipsync::TimedVisemeJson(u.visemes[u.sent_visemes++], u.clock));
  }
  if (audio_out && u.sent_visemes == u.visemes.size()) return 0;
  return std::max(0.01, sent_to - kLead - played);
}

// Sends what is due until `until()` holds or the piece is halted, waiting between sends.
void LiveSpeaker::SendWhile(Utterance& u, bool all_made, const std::stop_token& halt,
                            const std::function<bool()>& more) {
  for (double wait = Send(u, all_made); wait > 0 && !halt.stop_requested() && more();
       wait = Send(u, all_made)) {
    Charge();
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait_for(lock, halt, std::chrono::duration<double>(std::min(wait, 0.1)),
                 [] { return false; });
  }
}

void LiveSpeaker::Charge() {
  const double now = ThreadCpuSeconds();
  cpu_ns_ += static_cast<int64_t>((now - cpu_mark_) * 1e9);
  cpu_mark_ = now;
}

// One segment of a piece synthesized, its audio streamed as it is made and let go as it is sent.
bool LiveSpeaker::SpeakSegment(Utterance& u, const Piece& piece, std::string_view text,
                               const std::stop_token& halt) {
  u.segment_start = u.seconds_made();
  u.segment_visemes = u.visemes.size();
  std::vector<std::pair<int, std::string>> events;
  speech::SynthOptions options{.voice = piece.voice,
                               .rate = piece.rate,
                               .stop = halt,
                               .on_chunk = {},
                               .keep_audio = false,
                               .max_seconds = kMaxSegmentSeconds};
  options.on_chunk = [&](int rate, std::span<const int16_t> samples,
                         std::span<const std::pair<int, std::string>> made_events) {
    u.rate = rate;
    if (!u.started && !samples.empty()) u.started = true, u.wall = Clock::now();
    u.pending.insert(u.pending.end(), samples.begin(), samples.end());
    u.made += samples.size();
    HeldBytes() += samples.size() * sizeof(int16_t);
    events.insert(events.end(), made_events.begin(), made_events.end());
    // Visemes sure not to change as more speech comes: all but the last three of those known.
    std::vector<TimedViseme> known = VisemesOfUtterance(FinishedPhonemes(events), 0.0f);
    if (known.size() > 3) {
      known.resize(known.size() - 3);
      u.SetSegmentVisemes(std::move(known), false);
    }
    Send(u, false);
  };
  // espeak-ng speaks for one caller at a time, each waiting kBusyWait for it: a session waits its
  // turn while it is open (many started at once) rather than be refused; only kBusyPatience of
  // waiting is said, as busy.
  auto spoken = speech::Synthesize(text, options);
  const auto give_up = Clock::now() + std::chrono::duration<double>(kBusyPatience);
  while (!spoken.ok() && spoken.status().reason == "busy" && !halt.stop_requested() &&
         Clock::now() < give_up)
    spoken = speech::Synthesize(text, options);
  Charge();
  if (!spoken.ok()) {
    const Status& s = spoken.status();
    if (s.code != StatusCode::kCancelled) {
      Post(ErrorEvent(s.reason.empty() ? "say-failed" : s.reason, s.message,
                      s.fields.empty() ? "/say" : "/say" + s.fields[0].pointer));
    }
    return s.code != StatusCode::kCancelled &&
           s.reason == "speech-too-long";  // Go on with the next segment.
  }
  // The segment's visemes, as the speech route makes them for its text; those sent are its first
  // ones.
  u.SetSegmentVisemes(VisemesOfUtterance(spoken->phonemes, static_cast<float>(spoken->seconds)),
                      true);
  if (!u.started) u.started = true, u.wall = Clock::now();
  return true;
}

void LiveSpeaker::Speak(const Piece& piece, std::stop_token stop) {
  Utterance u;
  u.clock = clock_;
  const std::stop_token halt = utterance_.get_token();
  std::stop_callback forward(stop, [this] { utterance_.request_stop(); });
  Post(nlohmann::json{{"event", "say"}, {"state", "start"}, {"clock", clock_}}.dump());
  const std::vector<std::string> segments = SpeechSegments(piece.text, piece.rate);
  for (size_t i = 0; i < segments.size() && !halt.stop_requested(); ++i) {
    // The next segment is made once what is made of this one is within kRefill of playing, and
    // while the speech held across sessions is under its cap: memory holds a segment and a lead,
    // however long the text. A session with nothing left to play is never held by the others' (it
    // would wait on them forever while they keep refilling): each holds at most one segment.
    SendWhile(u, false, halt, [&] {
      const double ahead = u.seconds_made() - u.played();
      return ahead > kRefill || (ahead > 0 && HeldBytes() > kMaxHeldBytes);
    });
    if (halt.stop_requested() || !SpeakSegment(u, piece, segments[i], halt)) break;
  }
  SendWhile(u, true, halt, [] { return true; });
  const bool stopped = halt.stop_requested();
  clock_ += static_cast<double>(u.sent_samples) / u.rate;
  Charge();
  Post(nlohmann::json{{"event", "say"}, {"state", stopped ? "stopped" : "end"}, {"clock", clock_}}
           .dump());
}

}  // namespace facespace::http
