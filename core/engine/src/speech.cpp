#include "facespace/engine/speech.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "facespace/engine/face.h"
#include "facespace/engine/utf8.h"

namespace facespace {
inline namespace engine {

std::optional<Viseme> VisemeByName(std::string_view name) {
  for (size_t i = 0; i < kVisemeCount; ++i) {
    if (kVisemeNames[i] == name) return static_cast<Viseme>(i);
  }
  return std::nullopt;
}

namespace {

using V = Viseme;

// A phoneme as the tables spell it: ASCII lowered, stress digits and marks, length marks and
// combining diacritics (U+0300..U+036F: syllabic, dental, ...) left out.
std::string Normalized(std::string_view p) {
  std::string out;
  for (size_t i = 0; i < p.size();) {
    char32_t cp = 0;
    const size_t len =
        std::max<size_t>(DecodeUtf8(p, i, cp), 1);  // A broken byte is kept as it is.
    const bool mark = cp == 0x2C8 || cp == 0x2CC || cp == 0x2D0 || cp == 0x2D1 ||
                      (cp >= 0x300 && cp <= 0x36F) ||
                      (cp < 0x80 && ((cp >= '0' && cp <= '9') || cp == '\'' || cp == ',' ||
                                     cp == '%' || cp == '=' || cp == ':'));
    if (!mark) {
      if (cp >= 'A' && cp <= 'Z')
        out += static_cast<char>(cp + 32);
      else
        out += p.substr(i, len);
    }
    i += len;
  }
  return out;
}

// nullopt in a table: no shape of its own (takes the next sound's).
using Entry = std::optional<Viseme>;
const std::unordered_map<std::string, Entry>& Table() {
  static const std::unordered_map<std::string, Entry> kTable = [] {
    std::unordered_map<std::string, Entry> t;
    auto put = [&](Entry v, std::initializer_list<const char*> names) {
      for (const char* n : names) t.emplace(n, v);
    };
    // Pauses and noises (espeak-ng, CMU/PocketSphinx fillers, flite).
    put(V::kSil, {"", "_", "sil", "sp", "pau", "h#", "+nsn+", "+spn+", "+breath+", "+cough+",
                  "+noise+", "+um+", "+uh+", "<s>", "</s>", "<sil>", "[sil]", "|", "||"});
    // ARPAbet (CMU's dictionary, PocketSphinx, flite).
    put(V::kAA, {"aa", "ae", "ah", "aw", "ax", "ay", "ax-h"});
    put(V::kE, {"eh", "ey"});
    put(V::kIH, {"ih", "iy", "ix", "y"});
    put(V::kOH, {"ao", "ow", "oy"});
    put(V::kOU, {"uh", "uw", "ux", "w"});
    put(V::kRR, {"er", "axr", "r"});
    put(V::kPP, {"p", "b", "m", "em"});
    put(V::kFF, {"f", "v"});
    put(V::kTH, {"th", "dh"});
    put(V::kDD, {"t", "d", "dx"});
    put(V::kKK, {"k", "g", "ng"});
    put(V::kCH, {"ch", "jh", "sh", "zh"});
    put(V::kSS, {"s", "z"});
    put(V::kNN, {"n", "l", "el", "en", "nx"});
    put(std::nullopt, {"hh", "q"});
    // IPA (espeak-ng with phoneme events as IPA), single symbols and the clusters the first symbol
    // misreads.
    put(V::kAA, {"a", "ɑ", "æ", "ʌ", "ɐ", "ə", "ɶ", "aɪ", "aʊ"});
    put(V::kE, {"e", "ɛ", "ɜ", "ø", "œ", "eɪ", "eə"});
    put(V::kIH, {"i", "ɪ", "ɨ", "j", "ɪə"});
    put(V::kOH, {"o", "ɔ", "ɒ", "ɤ", "oʊ", "əʊ", "ɔɪ"});
    put(V::kOU, {"u", "ʊ", "ɯ", "ʉ", "ʍ", "ɥ", "ʊə"});
    put(V::kRR, {"ɹ", "ɻ", "ʁ", "ɚ", "ɝ", "ɾʲ"});
    put(V::kPP, {"ɓ"});
    put(V::kFF, {"ɸ", "β", "ɱ"});
    put(V::kTH, {"θ", "ð"});
    put(V::kDD, {"ɾ", "ɗ", "ʈ", "ɖ"});
    put(V::kKK, {"ŋ", "x", "ɣ", "ɡ", "ɢ", "c", "ɟ"});
    put(V::kCH, {"ʃ", "ʒ", "ɕ", "ʑ", "tʃ", "dʒ", "tɕ", "dʑ", "ʂ", "ʐ"});
    put(V::kSS, {"ts", "dz"});
    put(V::kNN, {"ɫ", "ɲ", "ɴ", "ʎ", "ɳ", "ɭ"});
    put(std::nullopt, {"h", "ɦ", "ʔ", "ç"});
    return t;
  }();
  return kTable;
}

bool IsPause(const std::optional<Viseme>& v) { return v && *v == V::kSil; }

}  // namespace

std::optional<Viseme> VisemeOfPhoneme(std::string_view phoneme) {
  const std::string n = Normalized(phoneme);
  const auto& table = Table();
  if (auto it = table.find(n); it != table.end()) return it->second;
  // A cluster the table does not list: its first symbol ("tʲ", "kʰ", "aɪə").
  if (!n.empty()) {
    char32_t cp;
    const size_t len = std::max<size_t>(DecodeUtf8(n, 0, cp), 1);
    if (auto it = table.find(n.substr(0, len)); it != table.end()) return it->second;
  }
  return V::kNN;
}

std::vector<TimedViseme> VisemesOfPhonemes(std::span<const TimedPhoneme> phonemes) {
  struct Item {
    std::optional<Viseme> v;
    float start, end;
  };
  std::vector<const TimedPhoneme*> sorted;
  sorted.reserve(phonemes.size());
  for (const TimedPhoneme& p : phonemes) {
    if (std::isfinite(p.start) && std::isfinite(p.end) && p.end >= p.start) sorted.push_back(&p);
  }
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const auto* a, const auto* b) { return a->start < b->start; });
  std::vector<Item> items;
  items.reserve(sorted.size() + 1);
  for (const TimedPhoneme* p : sorted) {
    const float start = items.empty() ? p->start : std::max(p->start, items.back().end);
    if (!items.empty() && start > items.back().end + 1e-4f)
      items.push_back({V::kSil, items.back().end, start});
    items.push_back({VisemeOfPhoneme(p->name), start, std::max(start, p->end)});
  }
  // h-like sounds: the next sound's shape (else the one before, else a pause).
  for (size_t i = items.size(); i-- > 0;) {
    if (items[i].v) continue;
    std::optional<Viseme> take;
    if (i + 1 < items.size() && !IsPause(items[i + 1].v))
      take = items[i + 1].v;
    else if (i > 0 && items[i - 1].v)
      take = items[i - 1].v;
    items[i].v = take ? take : std::optional<Viseme>(V::kSil);
  }
  // Short pauses between two sounds: half to each.
  std::vector<Item> kept;
  kept.reserve(items.size());
  for (size_t i = 0; i < items.size(); ++i) {
    Item it = items[i];
    const bool inner = !kept.empty() && i + 1 < items.size() && !IsPause(kept.back().v) &&
                       !IsPause(items[i + 1].v);
    if (IsPause(it.v) && inner && it.end - it.start < kShortPause) {
      const float mid = 0.5f * (it.start + it.end);
      kept.back().end = mid;
      items[i + 1].start = mid;
      continue;
    }
    kept.push_back(it);
  }
  std::vector<TimedViseme> out;
  out.reserve(kept.size());
  for (const Item& it : kept) {
    if (!(it.end > it.start)) continue;
    if (!out.empty() && out.back().viseme == *it.v) {
      out.back().end = it.end;
      continue;
    }
    out.push_back({*it.v, it.start, it.end});
  }
  return out;
}

std::vector<TimedViseme> VisemesOfUtterance(std::span<const TimedPhoneme> phonemes, float end) {
  std::vector<TimedViseme> v = VisemesOfPhonemes(phonemes);
  if (v.empty()) v.push_back({Viseme::kSil, 0.0f, end});
  if (v.front().start > 0.0f) v.insert(v.begin(), {Viseme::kSil, 0.0f, v.front().start});
  if (v.back().end < end) {
    if (v.back().viseme == Viseme::kSil)
      v.back().end = end;
    else
      v.push_back({Viseme::kSil, v.back().end, end});
  }
  return v;
}

// ---- viseme maps ------------------------------------------------------------------------------

namespace {

using Row = std::vector<CandidateBind>;  // One viseme's binds.

// ARKit's mouth: each viseme as the jaw and lip shapes a face tracker reports for it.
const std::array<Row, kVisemeCount>& ArkitVisemes() {
  static const std::array<Row, kVisemeCount> kRows = {
      Row{},  // sil
      Row{{"mouthPress_L|mouthPressLeft", 0.5f},
          {"mouthPress_R|mouthPressRight", 0.5f},
          {"mouthRollLower", 0.3f},
          {"mouthRollUpper", 0.2f}},  // PP
      Row{{"mouthRollLower", 0.7f},
          {"mouthUpperUp_L|mouthUpperUpLeft", 0.3f},
          {"mouthUpperUp_R|mouthUpperUpRight", 0.3f},
          {"jawOpen", 0.08f}},  // FF
      Row{{"jawOpen", 0.15f},
          {"tongueOut", 0.4f},
          {"mouthStretch_L|mouthStretchLeft", 0.2f},
          {"mouthStretch_R|mouthStretchRight", 0.2f}},  // TH
      Row{{"jawOpen", 0.2f},
          {"mouthStretch_L|mouthStretchLeft", 0.3f},
          {"mouthStretch_R|mouthStretchRight", 0.3f}},  // DD
      Row{{"jawOpen", 0.25f},
          {"mouthStretch_L|mouthStretchLeft", 0.3f},
          {"mouthStretch_R|mouthStretchRight", 0.3f}},  // kk
      Row{{"jawOpen", 0.15f},
          {"mouthFunnel", 0.5f},
          {"mouthPucker", 0.3f},
          {"mouthShrugUpper", 0.2f}},  // CH
      Row{{"jawOpen", 0.08f},
          {"mouthStretch_L|mouthStretchLeft", 0.5f},
          {"mouthStretch_R|mouthStretchRight", 0.5f},
          {"mouthSmile_L|mouthSmileLeft", 0.2f},
          {"mouthSmile_R|mouthSmileRight", 0.2f}},  // SS
      Row{{"jawOpen", 0.15f},
          {"mouthStretch_L|mouthStretchLeft", 0.2f},
          {"mouthStretch_R|mouthStretchRight", 0.2f}},                       // nn
      Row{{"jawOpen", 0.2f}, {"mouthFunnel", 0.4f}, {"mouthPucker", 0.2f}},  // RR
      Row{{"jawOpen", 0.7f},
          {"mouthLowerDown_L|mouthLowerDownLeft", 0.3f},
          {"mouthLowerDown_R|mouthLowerDownRight", 0.3f}},  // aa
      Row{{"jawOpen", 0.4f},
          {"mouthStretch_L|mouthStretchLeft", 0.4f},
          {"mouthStretch_R|mouthStretchRight", 0.4f},
          {"mouthSmile_L|mouthSmileLeft", 0.2f},
          {"mouthSmile_R|mouthSmileRight", 0.2f}},  // E
      Row{{"jawOpen", 0.25f},
          {"mouthStretch_L|mouthStretchLeft", 0.5f},
          {"mouthStretch_R|mouthStretchRight", 0.5f},
          {"mouthSmile_L|mouthSmileLeft", 0.2f},
          {"mouthSmile_R|mouthSmileRight", 0.2f}},                           // ih
      Row{{"jawOpen", 0.5f}, {"mouthFunnel", 0.8f}},                         // oh
      Row{{"jawOpen", 0.2f}, {"mouthPucker", 0.9f}, {"mouthFunnel", 0.3f}},  // ou
  };
  return kRows;
}

// MMD's five vowel morphs: consonants as the vowel shapes they look most like, a little.
const std::array<Row, kVisemeCount>& MmdVisemes() {
  static const std::array<Row, kVisemeCount> kRows = {
      Row{},                             // sil
      Row{},                             // PP: every mouth morph at 0 is closed lips.
      Row{{"う", 0.3f}, {"い", 0.2f}},   // FF
      Row{{"あ", 0.2f}, {"え", 0.2f}},   // TH
      Row{{"あ", 0.2f}, {"い", 0.3f}},   // DD
      Row{{"あ", 0.3f}, {"い", 0.2f}},   // kk
      Row{{"う", 0.5f}, {"い", 0.3f}},   // CH
      Row{{"い", 0.6f}},                 // SS
      Row{{"あ", 0.15f}, {"い", 0.2f}},  // nn
      Row{{"う", 0.5f}, {"お", 0.2f}},   // RR
      Row{{"あ", 1.0f}},                 // aa
      Row{{"え", 1.0f}},                 // E
      Row{{"い", 1.0f}},                 // ih
      Row{{"お", 1.0f}},                 // oh
      Row{{"う", 1.0f}},                 // ou
  };
  return kRows;
}

// MMD's other standard mouth morphs, held at 0 while speaking (MMDAgent's NOLIP).
constexpr std::string_view kMmdNolip[] = {"ワ",       "▲",      "∧",        "ω",        "ω□",
                                          "□",        "にやり", "にっこり", "口角上げ", "口角下げ",
                                          "口横広げ", "ん",     "はんっ！", "えー",     "ぺろっ",
                                          "てへぺろ", "口締め", "結び",     "む"};

}  // namespace

void DeriveVisemes(Rig& rig) {
  VisemeMap& m = rig.visemes;
  // MMD's five vowels where the rig has them all (an MMD model with ARKit-named morphs too, as Uka,
  // speaks with the vowels its author made for lip sync), else ARKit's jaw and lips.
  bool mmd = true;
  for (const char* vowel : {"あ", "い", "う", "え", "お"}) mmd = mmd && FindShape(rig, vowel) >= 0;
  const bool arkit = !mmd && FindShape(rig, "jawOpen") >= 0;
  if (!arkit && !mmd) return;
  const auto& rows = arkit ? ArkitVisemes() : MmdVisemes();
  for (size_t v = 0; v < kVisemeCount; ++v) {
    if (m.named & (1u << v)) continue;
    m.binds[v].clear();
    for (const CandidateBind& b : rows[v]) {
      const int s = FirstShapeOf(rig, b.shapes);
      if (s >= 0) m.binds[v].push_back({static_cast<uint32_t>(s), b.weight});
    }
  }
  if (!m.jaw_named) {
    m.jaw.clear();
    const int jaw = FindShape(rig, arkit ? "jawOpen" : "あ");
    if (jaw >= 0) m.jaw.push_back(static_cast<uint32_t>(jaw));
  }
  if (!m.nolip_named && mmd) {
    m.nolip.clear();
    for (std::string_view n : kMmdNolip) {
      const int s = FindShape(rig, std::string(n));
      if (s >= 0) m.nolip.push_back(static_cast<uint32_t>(s));
    }
  }
}

Status CanSpeak(const Rig& rig) {
  if (!rig.visemes.empty()) return Status::Ok();
  return WithReason(
      FailedPrecondition(
          "rig '" + rig.name +
          "' has no mouth to speak with: its manifest maps no \"visemes\", and it has neither "
          "ARKit's "
          "jawOpen (with mouthClose, mouthFunnel, mouthPucker, ...) nor MMD's あ い う え お"),
      "no-mouth");
}

// ---- keys -------------------------------------------------------------------------------------

std::vector<float> VisemeKeyTimes(const TimedViseme& v, const SpeechOptions& options) {
  const float d = v.end - v.start, mid = 0.5f * (v.start + v.end);
  if (v.viseme == V::kPP) {
    const float hold = std::max(options.min_hold, d - 2.0f * kKeyInset);
    return {mid - 0.5f * hold, mid + 0.5f * hold};
  }
  if (d > kLongViseme) return {v.start + kKeyInset, v.end - kKeyInset};
  return {mid};
}

Sequence SpeechSequence(const Rig& rig, std::span<const TimedViseme> visemes,
                        std::span<const float> base, const SpeechOptions& options) {
  const size_t n = rig.shapes.size();
  const VisemeMap& map = rig.visemes;
  Sequence seq;
  seq.transition.kind = TransitionKind::kSmoothstep;
  if (visemes.empty()) return seq;
  // Each viseme's weights.
  std::vector<std::vector<float>> values(visemes.size());
  for (size_t i = 0; i < visemes.size(); ++i) {
    std::vector<float>& w = values[i];
    w.assign(n, 0.0f);
    for (size_t s = 0; s < std::min(n, base.size()); ++s) w[s] = base[s];
    const TimedViseme& v = visemes[i];
    if (v.viseme == V::kSil) continue;
    for (uint32_t s : map.nolip) {
      if (s < n) w[s] = 0.0f;
    }
    float a = options.strength;
    if (IsVowel(v.viseme) && options.full_vowel > 0.0f)
      a *= std::clamp((v.end - v.start) / options.full_vowel, 0.35f, 1.0f);
    for (const auto& [s, weight] : map.binds[static_cast<size_t>(v.viseme)]) {
      if (s < n) w[s] += a * weight;
    }
  }
  // A short consonant between two open sounds keeps part of their jaw: no chatter.
  for (size_t i = 1; i + 1 < visemes.size(); ++i) {
    const TimedViseme& v = visemes[i];
    if (IsVowel(v.viseme) || v.viseme == V::kPP || v.viseme == V::kSil ||
        v.end - v.start >= options.short_consonant)
      continue;
    if (!IsVowel(visemes[i - 1].viseme) || !IsVowel(visemes[i + 1].viseme)) continue;
    for (uint32_t s : map.jaw) {
      if (s < n)
        values[i][s] = std::max(values[i][s],
                                options.jaw_carry * std::min(values[i - 1][s], values[i + 1][s]));
    }
  }
  // Key times; a closure's keys win over an open sound's that would come at the same time.
  struct Key {
    float time;
    size_t value;
    bool closure;
  };
  const float first = visemes.front().start, last = visemes.back().end;
  std::vector<Key> keys;
  keys.reserve(2 * visemes.size() + 2);
  keys.push_back({first, 0, false});
  for (size_t i = 0; i < visemes.size(); ++i) {
    for (float t : VisemeKeyTimes(visemes[i], options))
      keys.push_back({std::clamp(t, first, last), i, visemes[i].viseme == V::kPP});
  }
  keys.push_back({last, visemes.size() - 1, false});
  std::stable_sort(keys.begin(), keys.end(),
                   [](const Key& a, const Key& b) { return a.time < b.time; });
  constexpr float kMinGap = 1e-3f;
  std::vector<Key> kept;
  kept.reserve(keys.size());
  for (const Key& k : keys) {
    while (!kept.empty() && k.time <= kept.back().time + kMinGap && k.closure &&
           !kept.back().closure)
      kept.pop_back();
    if (kept.empty() || k.time > kept.back().time + kMinGap) kept.push_back(k);
  }
  seq.keys.reserve(kept.size());
  for (const Key& k : kept) {
    Keyframe key;
    key.time = k.time;
    key.weights = values[k.value];
    seq.keys.push_back(std::move(key));
  }
  if (seq.keys.size() == 1) {  // One instant: a sequence needs its ends.
    Keyframe end = seq.keys.front();
    end.time = std::max(end.time + 2 * kMinGap,
                        std::nextafter(end.time, std::numeric_limits<float>::infinity()));
    seq.keys.push_back(std::move(end));
  }
  return seq;
}

}  // namespace engine
}  // namespace facespace
