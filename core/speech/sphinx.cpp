// Speech to phonemes with PocketSphinx (Debian's pocketsphinx and pocketsphinx-en-us): its
// all-phone search, or a grammar of the transcript's words whose segments are then split into the
// words' phonemes from CMU's dictionary. A voice detector of our own (VoiceActivity) silences what
// nobody said.
#include <pocketsphinx.h>
#include <sphinxbase/err.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <span>
#include <sstream>

#include "facespace/speech/speech.h"
#include "sphinx_decoder.h"

namespace facespace::speech {

namespace {

// The lock every decoder's making and freeing takes (see sphinx_decoder.h).
std::mutex& SetUpLock() {
  static std::mutex mu;
  return mu;
}

}  // namespace

ps_decoder_t* NewAllPhoneDecoder() {
  std::lock_guard<std::mutex> lock(SetUpLock());
  static const bool quiet = [] {
    err_set_logfp(nullptr);  // sphinxbase's log off, for the process (its default is stderr).
    return true;
  }();
  (void)quiet;
  const std::string model = FACESPACE_SPHINX_MODEL;
  cmd_ln_t* config = cmd_ln_init(nullptr, ps_args(), TRUE, "-hmm", (model + "/en-us").c_str(),
                                 "-dict", (model + "/cmudict-en-us.dict").c_str(), "-allphone",
                                 (model + "/en-us-phone.lm.bin").c_str(), "-backtrace", "yes",
                                 "-beam", "1e-20", "-pbeam", "1e-20", "-lw", "2.0", "-allphone_ci",
                                 "yes", "-remove_silence", "no", nullptr);
  if (!config) return nullptr;
  ps_decoder_t* ps = ps_init(config);
  cmd_ln_free_r(config);
  return ps;
}

void FreeDecoder(ps_decoder_t* ps) {
  if (!ps) return;
  std::lock_guard<std::mutex> lock(SetUpLock());
  ps_free(ps);
}

std::vector<float> CepstralMeans(ps_decoder_t* ps) {
  const cmn_t* c = ps_get_feat(ps)->cmn_struct;
  return c ? std::vector<float>(c->cmn_mean, c->cmn_mean + c->veclen) : std::vector<float>{};
}

void SetCepstralMeans(ps_decoder_t* ps, const std::vector<float>& means) {
  cmn_t* c = ps_get_feat(ps)->cmn_struct;
  if (!c || means.size() != static_cast<size_t>(c->veclen)) return;
  std::copy(means.begin(), means.end(), c->cmn_mean);
  std::fill(c->sum, c->sum + c->veclen, 0.0f);
  c->nframe = 0;
}

bool Heard(const std::vector<bool>& active, int first, int sf, int ef) {
  size_t on = 0;
  for (int f = std::max(sf, first); f <= ef && static_cast<size_t>(f - first) < active.size(); ++f)
    on += active[static_cast<size_t>(f - first)];
  return 2 * on > static_cast<size_t>(ef - sf + 1);
}

void AppendSegment(std::vector<TimedPhoneme>& out, std::string name, float start, float end,
                   bool heard) {
  if (const size_t paren = name.find('('); paren != std::string::npos) name.resize(paren);
  if (!heard || name.empty() || name == "<sil>" || name == "<s>" || name == "</s>" ||
      name.front() == '+' || name.front() == '[')
    name = "SIL";
  if (!out.empty() && out.back().name == "SIL" && name == "SIL") {
    out.back().end = std::max(out.back().end, end);
    return;
  }
  out.push_back({name, start, std::max(start, end)});
}

namespace {

constexpr float kFrame = 0.01f;  // PocketSphinx's frames: 100 a second.

struct Decoder {
  std::timed_mutex lock;
  ps_decoder_t* ps = nullptr;
  bool tried = false;
  std::vector<float> cmn;  // Its cepstral means as made (the model's -cmninit).
};

Decoder& TheDecoder() {
  static Decoder d;
  return d;
}

// Under the decoder's lock: made once.
ps_decoder_t* Make(Decoder& d) {
  if (d.tried) return d.ps;
  d.tried = true;
  d.ps = NewAllPhoneDecoder();
  if (d.ps) d.cmn = CepstralMeans(d.ps);
  return d.ps;
}

bool IsArpabetVowel(std::string_view p) {
  return !p.empty() && std::strchr("AEIOU", p[0]) != nullptr;
}

// The transcript's words as the dictionary spells them: lower case, letters, digits and
// apostrophes.
std::vector<std::string> Words(std::string_view text) {
  std::vector<std::string> out;
  std::string w;
  for (char c : text) {
    const unsigned char u = static_cast<unsigned char>(c);
    if (std::isalnum(u) || c == '\'') {
      w += static_cast<char>(std::tolower(u));
    } else if (!w.empty()) {
      out.push_back(std::move(w));
      w.clear();
    }
  }
  if (!w.empty()) out.push_back(std::move(w));
  return out;
}

std::vector<std::string> Split(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> out;
  for (std::string t; in >> t;) out.push_back(t);
  return out;
}

// Runs the active search over the samples; the segments as (name, start frame, end frame
// inclusive).
struct Segment {
  std::string name;
  int sf, ef;
};
// `first_frame`: where `pcm` starts in the audio, added to the segments' frames.
std::vector<Segment> Decode(ps_decoder_t* ps, std::span<const int16_t> pcm, int first_frame,
                            bool* ok) {
  std::vector<Segment> out;
  SetCepstralMeans(ps, TheDecoder().cmn);
  *ok = ps_start_utt(ps) >= 0 && ps_process_raw(ps, pcm.data(), pcm.size(), FALSE, TRUE) >= 0 &&
        ps_end_utt(ps) >= 0;
  if (!*ok) return out;
  int32 score;
  *ok = ps_get_hyp(ps, &score) != nullptr;
  for (ps_seg_t* seg = ps_seg_iter(ps); seg; seg = ps_seg_next(seg)) {
    int sf, ef;
    ps_seg_frames(seg, &sf, &ef);
    out.push_back({ps_seg_word(seg), sf + first_frame, ef + first_frame});
  }
  return out;
}

// The frames (10 ms) from the first to the last one louder than the floor (-50 dBFS, and 35 dB
// under the loudest), widened by 30 ms: a grammar's search puts its first word at the first frame
// it is given, so it is given none of the silence before the speech.
std::pair<int, int> Loud(std::span<const int16_t> pcm) {
  constexpr size_t kHop = 160;
  std::vector<double> energy(pcm.size() / kHop);
  double loudest = 0.0;
  for (size_t f = 0; f < energy.size(); ++f) {
    double e = 0.0;
    for (size_t i = f * kHop; i < (f + 1) * kHop; ++i) e += static_cast<double>(pcm[i]) * pcm[i];
    energy[f] = e / kHop;
    loudest = std::max(loudest, energy[f]);
  }
  const double floor = std::max(32768.0 * 32768.0 * 1e-5, loudest * std::pow(10.0, -3.5));
  int first = -1, last = -1;
  for (size_t f = 0; f < energy.size(); ++f) {
    if (energy[f] < floor) continue;
    if (first < 0) first = static_cast<int>(f);
    last = static_cast<int>(f);
  }
  if (first < 0) return {0, static_cast<int>(energy.size())};
  return {std::max(0, first - 3), std::min(static_cast<int>(energy.size()), last + 4)};
}

}  // namespace

size_t CountWords(std::string_view text) {
  size_t n = 0;
  bool in_word = false;
  for (char c : text) {
    const bool part = std::isalnum(static_cast<unsigned char>(c)) || c == '\'';
    n += part && !in_word;
    in_word = part;
  }
  return n;
}

namespace {

// Aligned words into their phonemes: a vowel takes twice a consonant's share of its word.
std::vector<Segment> WordsToPhones(ps_decoder_t* ps, const std::vector<Segment>& words) {
  std::vector<Segment> phones;
  for (const Segment& s : words) {
    char* p = s.name[0] == '<' || s.name[0] == '[' ? nullptr : ps_lookup_word(ps, s.name.c_str());
    if (!p) {
      phones.push_back({"SIL", s.sf, s.ef});
      continue;
    }
    const std::vector<std::string> list = Split(p);
    std::free(p);
    float units = 0.0f;
    for (const std::string& ph : list) units += IsArpabetVowel(ph) ? 2.0f : 1.0f;
    const float frames = static_cast<float>(s.ef - s.sf + 1);
    float at = 0.0f;
    for (const std::string& ph : list) {
      const float share = frames * (IsArpabetVowel(ph) ? 2.0f : 1.0f) / units;
      const int sf = s.sf + static_cast<int>(std::lround(at));
      const int ef = s.sf + static_cast<int>(std::lround(at + share)) - 1;
      if (ef >= sf) phones.push_back({ph, sf, ef});
      at += share;
    }
  }
  return phones;
}

}  // namespace

Result<Recognized> Recognize(const Audio& input, const RecognizeOptions& options) {
  if (input.rate <= 0)
    return WithReason(InvalidField("/audio", "has no sample rate"), "invalid-audio");
  // A transcript is what the audio can hold: a search over 50,000 words for a minute of audio held
  // the decoder for a minute.
  const size_t max_words = MaxTranscriptWords(input.seconds());
  if (const size_t words = CountWords(options.transcript); words > max_words) {
    return WithReason(
        InvalidField("/transcript", std::to_string(words) + " words for " +
                                        std::to_string(input.seconds()).substr(0, 5) +
                                        " s of audio; at most " + std::to_string(max_words) + " (" +
                                        std::to_string(static_cast<int>(kMaxWordsPerSecond)) +
                                        " a second, and 10 more)"),
        "transcript-too-long");
  }
  // Everything after this is the decoder's work, in its one queue: resampling and the voice
  // detector too (eight 192 kHz WAVs resampled at once beside the queue took 51 s of CPU).
  Decoder& d = TheDecoder();
  std::unique_lock<std::timed_mutex> lock(d.lock, std::defer_lock);
  if (!lock.try_lock_for(kBusyWait)) return Busy("PocketSphinx");
  if (options.stop.stop_requested()) return Cancelled();
  const Audio audio = Resample(input, 16000);
  if (options.stop.stop_requested()) return Cancelled();
  Recognized out;
  const std::vector<bool> active = VoiceActivity(audio);
  const size_t voiced = static_cast<size_t>(std::count(active.begin(), active.end(), true));
  out.voiced_seconds = voiced * kFrame;
  const float total = audio.seconds();
  if (voiced == 0) {  // Nobody speaks: silence, without asking the decoder.
    out.phonemes.push_back({"SIL", 0.0f, total});
    return out;
  }
  if (options.stop.stop_requested()) return Cancelled();
  std::vector<int16_t> pcm(audio.samples.size());
  for (size_t i = 0; i < pcm.size(); ++i)
    pcm[i] =
        static_cast<int16_t>(std::lround(std::clamp(audio.samples[i], -1.0f, 1.0f) * 32767.0f));
  ps_decoder_t* ps = Make(d);
  if (!ps)
    return Internal(
        "PocketSphinx could not start (its US English model, pocketsphinx-en-us, is missing)");

  std::vector<Segment> segments;
  bool aligned = false;
  if (!options.transcript.empty()) {
    std::string grammar = "#JSGF V1.0;\ngrammar align;\npublic <s> =";
    std::vector<std::string> unknown;
    size_t known = 0;
    for (const std::string& w : Words(options.transcript)) {
      char* phones = ps_lookup_word(ps, w.c_str());
      if (!phones) {
        unknown.push_back(w);
        continue;
      }
      std::free(phones);
      grammar += " " + w;
      ++known;
    }
    grammar += ";\n";
    if (!unknown.empty()) {
      std::string names;
      for (size_t i = 0; i < unknown.size() && i < 10; ++i) names += (i ? ", " : "") + unknown[i];
      out.warnings.push_back(CountWarning(
          "transcript_words_unknown", unknown.size(),
          "word(s) of the transcript are not in the dictionary and are left out: " + names));
    }
    const std::string phones_search = ps_get_search(ps);  // The all-phone search, set back after.
    if (known > 0 && ps_set_jsgf_string(ps, "align", grammar.c_str()) == 0 &&
        ps_set_search(ps, "align") == 0) {
      bool ok = false;
      const auto [from, to] = Loud(pcm);
      segments = Decode(ps,
                        std::span<const int16_t>(pcm).subspan(static_cast<size_t>(from) * 160,
                                                              static_cast<size_t>(to - from) * 160),
                        from, &ok);
      aligned = ok;
      ps_set_search(ps, phones_search.c_str());
      ps_unset_search(ps, "align");
      if (aligned) {
        segments = WordsToPhones(ps, segments);
      }
    }
    if (!aligned) {
      out.warnings.push_back({"transcript_not_aligned",
                              "the audio could not be aligned to the transcript; its phonemes are "
                              "recognized as heard instead",
                              "", 0.0, false});
    }
  }
  if (!aligned) {
    bool ok = false;
    segments = Decode(ps, pcm, 0, &ok);
  }
  // Segments to phonemes; where the voice detector heard no voice over most of one, silence.
  for (const Segment& s : segments) {
    const int sf = std::max(0, s.sf), ef = std::max(s.sf, s.ef);
    AppendSegment(out.phonemes, s.name, sf * kFrame, std::min(total, (ef + 1) * kFrame),
                  Heard(active, 0, sf, ef));
  }
  if (out.phonemes.empty()) out.phonemes.push_back({"SIL", 0.0f, total});
  return out;
}

}  // namespace facespace::speech
