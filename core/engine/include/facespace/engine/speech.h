// Lip sync: timed phonemes (from a synthesizer's events or a recognizer's segments) to the 15
// visemes of OpenXR/Oculus, and visemes to keys of a sequence through the rig's viseme map (rig.h,
// VisemeMap), with coarticulation. No audio here: core/speech reads, synthesizes and recognizes it.
//
//   phonemes ──VisemesOfPhonemes──> visemes ──SpeechSequence(rig, base weights)──> Sequence (keys)
//
// The keys then go where every sequence goes: sampled, streamed, reduced, rendered.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/engine/rig.h"
#include "facespace/engine/sequence.h"
#include "facespace/engine/status.h"

namespace facespace {
inline namespace engine {

// The voice text is spoken with when a request names none (core/speech's synthesizer takes it by
// default; GET /v1/voices says it as "default").
inline constexpr char kDefaultVoice[] = "en-us";

// OpenXR's (Oculus's) visemes, in their order.
enum class Viseme : uint8_t {
  kSil,
  kPP,
  kFF,
  kTH,
  kDD,
  kKK,
  kCH,
  kSS,
  kNN,
  kRR,
  kAA,
  kE,
  kIH,
  kOH,
  kOU
};
inline constexpr size_t kVisemeCount = 15;
inline constexpr std::string_view kVisemeNames[kVisemeCount] = {
    "sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E", "ih", "oh", "ou"};
inline std::string_view VisemeName(Viseme v) { return kVisemeNames[static_cast<size_t>(v)]; }
// The visemes as web avatars name their shapes (Oculus/OVR's, OpenXR's), in Viseme order.
inline constexpr std::string_view kOvrVisemeNames[kVisemeCount] = {
    "viseme_sil", "viseme_PP", "viseme_FF", "viseme_TH", "viseme_DD",
    "viseme_kk",  "viseme_CH", "viseme_SS", "viseme_nn", "viseme_RR",
    "viseme_aa",  "viseme_E",  "viseme_I",  "viseme_O",  "viseme_U"};
std::optional<Viseme> VisemeByName(std::string_view name);
inline bool IsVowel(Viseme v) { return v >= Viseme::kAA; }

struct TimedPhoneme {
  std::string
      name;  // IPA (espeak-ng) or ARPAbet (CMU's: PocketSphinx, flite), as the source gave it.
  float start = 0.0f, end = 0.0f;  // Seconds.
};
struct TimedViseme {
  Viseme viseme = Viseme::kSil;
  float start = 0.0f, end = 0.0f;
};

// A phoneme's viseme: IPA or ARPAbet, stress digits, stress and length marks ignored ("ˈəʊ",
// "AH0"). h, ɦ and the glottal stop have no shape of their own: nullopt (they take the next
// sound's). Pauses
// ("_", "SIL", "pau", "+NSN+", "") are sil; an unknown symbol is nn (a neutral, slightly open
// mouth).
std::optional<Viseme> VisemeOfPhoneme(std::string_view phoneme);

// Pauses shorter than this between two sounds belong to the sounds (the mouth does not close for
// them).
inline constexpr float kShortPause = 0.08f;

// The phonemes as visemes over the same time: each phoneme its viseme (h-like ones the next
// sound's), pauses under kShortPause split between their neighbours, neighbours with the same
// viseme merged, and zero-length ones dropped. Times as given (sorted by start); gaps between
// phonemes are sil.
std::vector<TimedViseme> VisemesOfPhonemes(std::span<const TimedPhoneme> phonemes);

// An utterance's visemes (VisemesOfPhonemes) with sil before the first and after the last, to `end`
// (seconds: the audio's length): what the speech route says, and the live route's say with it.
std::vector<TimedViseme> VisemesOfUtterance(std::span<const TimedPhoneme> phonemes, float end);

// Fills what the manifest left of rig.visemes: MMD's あ い う え お when the rig has all five
// (NOLIP: the other standard MMD mouth morphs it has), else ARKit's names (jawOpen, mouthFunnel,
// mouthPucker, mouthStretch_L/R, mouthRollLower, mouthPress_L/R, ...). Neither: it stays empty
// (CanSpeak says so).
void DeriveVisemes(Rig& rig);

// Whether the rig can speak: ok, or FailedPrecondition (reason "no-mouth") naming what it lacks.
Status CanSpeak(const Rig& rig);

struct SpeechOptions {
  // Every bilabial closure (PP) holds its closed lips at least this long, so frames sampled at 1 /
  // hold per second see it closed (1 / fps).
  float min_hold = 1.0f / 30.0f;
  // A vowel shorter than this opens the mouth in proportion (no full open and close on every short
  // vowel).
  float full_vowel = 0.12f;
  // A consonant shorter than this between two open sounds keeps this share of their smaller jaw
  // opening.
  float short_consonant = 0.12f;
  float jaw_carry = 0.6f;
  float strength = 1.0f;  // Scales every viseme (0..1: mumbled, 1: as mapped).
};

// The keys that speak `visemes` on top of `base` (one weight per shape: the face under the speech).
// Each viseme is a key (a long one two, at its ends, a closure one held for min_hold) whose weights
// are base + strength x its binds, with the NOLIP shapes at 0 while a sound is spoken; sil is the
// base itself. Between keys, smoothstep: neighbouring visemes overlap in time, and each key is
// reached exactly (a PP's lips close). Times are the visemes' own; the first key is at the first
// viseme's start, the last at the last one's end.
Sequence SpeechSequence(const Rig& rig, std::span<const TimedViseme> visemes,
                        std::span<const float> base, const SpeechOptions& options = {});

// The key times SpeechSequence puts for a viseme: one at its middle; a long one (over kLongViseme)
// two, kKeyInset inside its ends; a closure (PP) two around its middle, max(min_hold, its length
// less two insets) apart. Times may leave the viseme (a short closure's hold); SpeechSequence drops
// a key that would not come after the one before it, closures first kept.
inline constexpr float kLongViseme = 0.15f;
inline constexpr float kKeyInset = 0.05f;
std::vector<float> VisemeKeyTimes(const TimedViseme& v, const SpeechOptions& options);

}  // namespace engine
}  // namespace facespace
