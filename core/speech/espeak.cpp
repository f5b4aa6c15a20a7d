// Text to speech with libespeak-ng, synchronous: the audio and its phoneme events come back through
// one callback. espeak-ng keeps global state (voice, rate, callback), so one synthesis runs at a
// time.
#include <espeak-ng/speak_lib.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <mutex>

#include "facespace/engine/rig.h"
#include "facespace/engine/utf8.h"
#include "facespace/speech/speech.h"

namespace facespace::speech {

namespace {

std::timed_mutex& Lock() {
  static std::timed_mutex m;
  return m;
}

// What one synthesis collects.
struct Collect {
  std::vector<int16_t> samples;
  std::vector<std::pair<int, std::string>> events;  // (ms, IPA phoneme)
  std::chrono::steady_clock::time_point deadline;
  std::stop_token stop;
  const SynthOptions* options = nullptr;
  int rate = 0;
  size_t made = 0;  // Samples made, kept or not.
  bool timed_out = false, stopped = false, too_long = false;
};
Collect* g_collect = nullptr;  // Under Lock().

int OnSynth(short* wav, int count, espeak_EVENT* events) {
  Collect* c = g_collect;
  if (!c) return 1;
  const bool keep = !c->options || !c->options->on_chunk || c->options->keep_audio;
  if (!keep) c->samples.clear();  // Given to on_chunk last time: not kept.
  const size_t samples_before = c->samples.size(), events_before = c->events.size();
  if (wav && count > 0)
    c->samples.insert(c->samples.end(), wav, wav + count), c->made += static_cast<size_t>(count);
  for (espeak_EVENT* e = events; e && e->type != espeakEVENT_LIST_TERMINATED; ++e) {
    if (e->type != espeakEVENT_PHONEME) continue;
    const char* s = e->id.string;
    c->events.emplace_back(e->audio_position, std::string(s, strnlen(s, sizeof(e->id.string))));
  }
  if (c->options && c->options->on_chunk) {
    c->options->on_chunk(
        c->rate, std::span<const int16_t>(c->samples).subspan(samples_before),
        std::span<const std::pair<int, std::string>>(c->events).subspan(events_before));
  }
  if (c->stop.stop_requested()) {
    c->stopped = true;
    return 1;  // Stops the synthesis.
  }
  if (std::chrono::steady_clock::now() > c->deadline) {
    c->timed_out = true;
    return 1;
  }
  if (c->options && c->options->max_seconds > 0 &&
      static_cast<double>(c->made) > c->options->max_seconds * c->rate) {
    c->too_long = true;
    return 1;
  }
  return 0;
}

// Initialized once, under Lock(); the sample rate, or <= 0 when espeak-ng's data is missing.
int Initialized() {
  static int rate = [] {
    const int r = espeak_Initialize(AUDIO_OUTPUT_SYNCHRONOUS, 200, nullptr,
                                    espeakINITIALIZE_PHONEME_EVENTS | espeakINITIALIZE_PHONEME_IPA |
                                        espeakINITIALIZE_DONT_EXIT);
    if (r > 0) espeak_SetSynthCallback(OnSynth);
    return r;
  }();
  return rate;
}

std::vector<VoiceInfo> ListVoicesLocked() {
  std::vector<VoiceInfo> out;
  const espeak_VOICE** voices = espeak_ListVoices(nullptr);
  for (size_t i = 0; voices && voices[i]; ++i) {
    const espeak_VOICE* v = voices[i];
    // `languages`: a priority byte, then a zero-terminated language, repeated; the first is the
    // main one.
    std::string lang = v->languages && v->languages[0] ? std::string(v->languages + 1) : "";
    out.push_back({v->name ? v->name : "", lang});
  }
  return out;
}

}  // namespace

std::vector<VoiceInfo> Voices() {
  // espeak-ng's voices do not change while it runs: listed once, then answered without its lock (a
  // synthesis may hold it for seconds).
  static std::mutex cache_lock;
  static std::vector<VoiceInfo> cache;
  std::lock_guard<std::mutex> cached(cache_lock);
  if (cache.empty()) {
    std::unique_lock<std::timed_mutex> lock(Lock(), std::defer_lock);
    if (!lock.try_lock_for(kBusyWait) || Initialized() <= 0) return {};
    cache = ListVoicesLocked();
  }
  return cache;
}

Result<Spoken> Synthesize(std::string_view text, const SynthOptions& options) {
  size_t chars = 0;
  bool blank = true;
  for (size_t i = 0; i < text.size(); ++chars) {
    char32_t cp;
    const size_t len = DecodeUtf8(text, i, cp);
    if (len == 0)
      return WithReason(
          InvalidField("/text", "is not valid UTF-8 (at byte " + std::to_string(i) + ")"),
          "invalid-text");
    blank = blank && (cp == ' ' || cp == '\t' || cp == '\n' || cp == '\r');
    i += len;
  }
  if (blank)
    return WithReason(InvalidField("/text", "is empty; send the words to say"), "invalid-text");
  if (chars > kMaxTextChars) {
    return WithReason(
        InvalidField("/text", std::to_string(chars) + " characters, over the limit of " +
                                  std::to_string(kMaxTextChars)),
        "text-too-long");
  }
  if (options.rate < 80 || options.rate > 450) {
    return WithReason(
        InvalidField("/rate", std::to_string(options.rate) + " words a minute; from 80 to 450"),
        "invalid-rate");
  }
  std::unique_lock<std::timed_mutex> lock(Lock(), std::defer_lock);
  if (!lock.try_lock_for(kBusyWait)) return Busy("espeak-ng");
  const int rate = Initialized();
  if (rate <= 0)
    return Internal("espeak-ng could not start (its data, espeak-ng-data, is missing)");
  // A voice by name or by language: the first voice whose name or language equals it.
  std::string voice;
  const std::vector<VoiceInfo> voices = ListVoicesLocked();
  for (const VoiceInfo& v : voices) {
    if (v.language == options.voice || v.name == options.voice) {
      voice = v.language.empty() ? v.name : v.language;
      break;
    }
  }
  if (voice.empty() || espeak_SetVoiceByName(voice.c_str()) != EE_OK) {
    std::vector<std::string_view> names;
    for (const VoiceInfo& v : voices) {
      if (!v.language.empty()) names.push_back(v.language);
    }
    return WithReason(
        InvalidField("/voice", "unknown voice '" + options.voice + "'" +
                                   DidYouMean(options.voice, names) + " (GET /v1/voices lists " +
                                   std::to_string(voices.size()) + ")"),
        "unknown-voice");
  }
  espeak_SetParameter(espeakRATE, options.rate, 0);
  Collect collect;
  collect.deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  collect.stop = options.stop;
  collect.options = &options;
  collect.rate = rate;
  g_collect = &collect;
  const std::string z(text);
  const espeak_ERROR err = espeak_Synth(z.c_str(), z.size() + 1, 0, POS_CHARACTER, 0,
                                        espeakCHARS_UTF8, nullptr, nullptr);
  espeak_Synchronize();
  g_collect = nullptr;
  if (collect.stopped) return Cancelled();
  if (err != EE_OK)
    return Internal("espeak-ng failed to speak (error " + std::to_string(static_cast<int>(err)) +
                    ")");
  if (collect.timed_out)
    return WithReason(InvalidField("/text", "took espeak-ng over 20 s; say less at once",
                                   StatusCode::kResourceExhausted),
                      "text-too-long");
  if (collect.too_long) {
    return WithReason(
        InvalidField("/text",
                     "makes over " + std::to_string(static_cast<int>(options.max_seconds)) +
                         " s of speech without a pause; say less at once",
                     StatusCode::kResourceExhausted),
        "speech-too-long");
  }
  Spoken out;
  out.voice = voice;
  out.audio.rate = rate;
  out.seconds = static_cast<double>(collect.made) / rate;
  if (!options.on_chunk || options.keep_audio) {
    out.audio.samples.resize(collect.samples.size());
    for (size_t i = 0; i < collect.samples.size(); ++i)
      out.audio.samples[i] = collect.samples[i] / 32768.0f;
  }
  out.phonemes = PhonemesOfEvents(collect.events, static_cast<float>(out.seconds));
  return out;
}

std::vector<TimedPhoneme> PhonemesOfEvents(std::span<const std::pair<int, std::string>> events,
                                           float end) {
  std::vector<TimedPhoneme> out;
  for (size_t i = 0; i < events.size(); ++i) {
    const float start = std::min(end, events[i].first / 1000.0f);
    const float stop =
        std::max(start, i + 1 < events.size() ? std::min(end, events[i + 1].first / 1000.0f) : end);
    const std::string& name = events[i].second;
    if (name.empty() && stop <= start) continue;
    out.push_back({name.empty() ? "_" : name, start, stop});
  }
  return out;
}

}  // namespace facespace::speech
