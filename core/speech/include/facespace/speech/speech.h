// Speech in and out, for lip sync (core/speech.h turns the phonemes into visemes and keys):
//   - WAV bytes read (untrusted: bounded, every chunk checked) and written;
//   - text spoken by Debian's libespeak-ng: the audio and its phoneme events (IPA, with their
//   times);
//   - speech recognized by Debian's PocketSphinx: phonemes with times, or a transcript aligned to
//   the
//     audio; where nobody speaks (silence, noise) it says silence.
// Below the evaluator, beside the formats and physics; core itself stays Eigen alone.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <stop_token>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "facespace/engine/speech.h"
#include "facespace/engine/status.h"

namespace facespace::speech {

// Mono audio, samples in [-1, 1].
struct Audio {
  int rate = 0;  // Samples per second.
  std::vector<float> samples;
  float seconds() const {
    return rate > 0 ? static_cast<float>(samples.size()) / static_cast<float>(rate) : 0.0f;
  }
};

// Each engine serves one request at a time; another waits this long for it, then is told "busy"
// (ResourceExhausted, reason "busy": the service answers 503, retry shortly) rather than holding
// its thread for as long as the queue is.
inline constexpr std::chrono::milliseconds kBusyWait{2000};
inline Status Busy(const char* engine) {
  return WithReason(
      ResourceExhausted(std::string(engine) + " is speaking for another request; retry shortly"),
      "busy");
}

// ---- WAV --------------------------------------------------------------------------------------

inline constexpr float kMaxAudioSeconds = 60.0f;

// Where a WAV's samples are and what they are, read from its chunks alone (no sample decoded): what
// an admission step needs to price the audio before the work.
struct WavLayout {
  uint16_t format = 0, channels = 0, bits = 0;
  int rate = 0;
  size_t frames = 0;  // Samples per channel.
  size_t data = 0;    // Offset of the first sample.
  double seconds() const { return rate > 0 ? static_cast<double>(frames) / rate : 0.0; }
};
Result<WavLayout> ReadWavLayout(std::string_view bytes);

// A RIFF/WAVE file: PCM 8, 16, 24 or 32 bit, or IEEE float 32 (plain or WAVE_FORMAT_EXTENSIBLE), 1
// to 8 channels (averaged to mono), 8 to 192 kHz. Errors (InvalidArgument, reason "invalid-audio"):
// not a WAV, a format it does not read, truncated headers; longer than `max_seconds`:
// ResourceExhausted (reason "audio-too-long"). A data chunk cut short is read as far as it goes.
Result<Audio> ReadWav(std::string_view bytes, float max_seconds = kMaxAudioSeconds);

// 16-bit PCM mono WAV.
std::string WriteWav(const Audio& audio);

// Whether the bytes start as a RIFF/WAVE file.
bool LooksLikeWav(std::string_view bytes);

// The audio at another rate (band-limited: a windowed-sinc low-pass below both Nyquist rates).
Audio Resample(const Audio& audio, int rate);

// ---- text to speech (libespeak-ng) -------------------------------------------------------------

inline constexpr size_t kMaxTextChars = 2000;

using facespace::kDefaultVoice;  // core/speech.h

struct SynthOptions {
  std::string voice =
      kDefaultVoice;     // An espeak-ng voice name or language ("en-us", "en", "ja", "de", ...).
  int rate = 175;        // Words per minute, 80 to 450.
  std::stop_token stop;  // Fired: the synthesis stops at espeak-ng's next callback, Cancelled.
  // Called as espeak-ng makes the speech (about 0.2 s of audio a call), under its lock: the new
  // samples (16-bit, at the voice's rate) and the new phoneme events (start in ms, IPA; "" a
  // pause). For speech that starts while it is made (the live route); it must not wait.
  std::function<void(int rate, std::span<const int16_t> samples,
                     std::span<const std::pair<int, std::string>> events)>
      on_chunk;
  // With on_chunk: false gives the samples to on_chunk alone, keeping none (Spoken's audio is then
  // empty, its rate and `seconds` still set), so that memory does not grow with the speech.
  bool keep_audio = true;
  // Seconds of audio at most (0: no cap); more stops the synthesis with ResourceExhausted
  // ("speech-too-long").
  double max_seconds = 0;
};

struct Spoken {
  Audio audio;
  double seconds = 0;  // Of the speech made (the audio's, also when it was not kept).
  std::vector<TimedPhoneme> phonemes;  // IPA, as espeak-ng's phoneme events name them; pauses "_".
  std::string voice;                   // The voice that spoke.
};

// Speaks `text` (UTF-8, 1 to kMaxTextChars characters). Errors name the field: empty or too long
// text
// (/text), an unknown voice (/voice, with the closest names), a rate out of range (/rate). One
// synthesis at a time (espeak-ng keeps global state): callers queue on a lock.
Result<Spoken> Synthesize(std::string_view text, const SynthOptions& options);

// espeak-ng's phoneme events (start in ms, IPA; "" a pause) as phonemes: each from its event to the
// next one's, the last to `end` (seconds), every time at most `end`; an unnamed one that lasts is a
// pause ("_"), one of no length no phoneme. Synthesize's, and the live route's as the speech comes.
std::vector<TimedPhoneme> PhonemesOfEvents(std::span<const std::pair<int, std::string>> events,
                                           float end);

// The voices espeak-ng has: {name, languages}.
struct VoiceInfo {
  std::string name, language;
};
std::vector<VoiceInfo> Voices();

// ---- speech to phonemes (PocketSphinx) --------------------------------------------------------

// Words of `text` as the dictionary spells them (runs of letters, digits and apostrophes), counted
// without making them: the transcript's limit and the cost of text to speak.
size_t CountWords(std::string_view text);

// A transcript has at most this many words a second of its audio, and 10 more (fast speech is 4-5).
inline constexpr double kMaxWordsPerSecond = 8.0;
inline size_t MaxTranscriptWords(double seconds) {
  return 10 + static_cast<size_t>(kMaxWordsPerSecond * std::max(0.0, seconds));
}

struct RecognizeOptions {
  // Words said (Rhubarb's dialog option): the audio is aligned to them (their phonemes from CMU's
  // dictionary); words the dictionary does not have are left out, named in a warning. Empty:
  // phonemes are recognized as heard (PocketSphinx's all-phone search).
  std::string transcript;
  std::stop_token
      stop;  // Fired: Cancelled between the steps (resampling, voice detection, decoding).
};

struct Recognized {
  std::vector<TimedPhoneme> phonemes;  // ARPAbet ("HH", "AH", "SIL").
  std::vector<Warning> warnings;
  float voiced_seconds = 0.0f;  // How much of the audio the voice detector took as speech.
};

// US English, 16 kHz (other rates are resampled). Where the voice detector hears no voice (silence,
// steady noise), phonemes are SIL whatever the decoder said. One decoder, used one request at a
// time.
Result<Recognized> Recognize(const Audio& audio, const RecognizeOptions& options);

// Speech recognized while it is heard (the live route's listen): 16 kHz 16-bit mono chunks in, as
// they come, through PocketSphinx's all-phone search decoding as it goes; phonemes out once they
// are sure (their end kLagFrames behind the newest audio), SIL where the voice detector hears no
// voice. Each recognizer holds a decoder of its own (made in 90 ms), at most kMaxLiveDecoders at
// once.
class LiveRecognizer {
 public:
  static constexpr int kLagFrames = 8;  // 80 ms: a phoneme ending later may still change.
  static constexpr double kUtteranceSeconds =
      20;  // The decoder starts afresh after this much audio.
  // A recognizer, or ResourceExhausted (reason "busy") when every decoder is in use.
  static Result<std::unique_ptr<LiveRecognizer>> Open();
  ~LiveRecognizer();
  LiveRecognizer(const LiveRecognizer&) = delete;
  LiveRecognizer& operator=(const LiveRecognizer&) = delete;
  // Decodes `pcm` (16 kHz); appends the phonemes now sure to `sure` (times from the first sample
  // fed).
  Status Feed(std::span<const int16_t> pcm, std::vector<TimedPhoneme>& sure);
  // The end of the audio: every phoneme left.
  Status Finish(std::vector<TimedPhoneme>& rest);

 private:
  explicit LiveRecognizer(void* decoder) : ps_(decoder) {}
  // The utterance's segments ending before frame `before` (all of them at its end) as phonemes.
  void Take(int before, std::vector<TimedPhoneme>& out);
  void* ps_;                    // ps_decoder_t.
  std::vector<int16_t> audio_;  // This utterance's, for the voice detector.
  double offset_ = 0;           // Seconds before this utterance.
  int taken_ = 0;               // Frames of this utterance already given out.
  bool in_utterance_ = false;
};
inline constexpr int kMaxLiveDecoders = 4;

// Per 10 ms frame of `audio`: whether a voice speaks there (energy above the floor and a pitch
// period between 60 and 400 Hz near it, with a margin of 0.2 s around voiced stretches).
std::vector<bool> VoiceActivity(const Audio& audio);

}  // namespace facespace::speech
