// Where the names of each vocabulary sit in the space they share (retarget.h): ARKit's 52 axes.
// The tables say what a name does in ARKit's terms, one row a name: "jawOpen:0.8" a share of an
// axis, "eyeBlink*:1" both sides of one, "@aa" a VRM preset (face.cpp's table, which the rigs'
// faces use too).
#include <algorithm>
#include <cctype>
#include <string>
#include <unordered_map>

#include "facespace/engine/face.h"
#include "facespace/engine/retarget.h"

namespace facespace {
inline namespace engine {

namespace {

struct NameRow {
  const char* name;
  const char* terms;
};

// MikuMikuDance's standard morphs (those of its bundled models, which most PMD/PMX rigs keep, and
// Uka's): eyes, brows, mouth. ウィンク closes the left eye (the character's), as VRM's blinkLeft.
constexpr NameRow kMmdRows[] = {
    {"まばたき", "eyeBlink*:1"},
    {"とじ目", "eyeBlink*:1"},
    {"笑い", "eyeBlink*:0.85 cheekSquint*:0.6 eyeSquint*:0.5"},
    {"ウィンク", "eyeBlinkLeft:0.9 cheekSquintLeft:0.4"},
    {"ウィンク右", "eyeBlinkRight:0.9 cheekSquintRight:0.4"},
    {"ウィンク２", "eyeBlinkLeft:1"},
    {"ｳｨﾝｸ２右", "eyeBlinkRight:1"},
    {"まば左", "eyeBlinkLeft:1"},
    {"まば右", "eyeBlinkRight:1"},
    {"なごみ", "eyeBlink*:0.7 eyeSquint*:0.3"},
    {"はぅ", "eyeBlink*:1 eyeSquint*:1"},
    {"びっくり", "eyeWide*:1"},
    {"見開き", "eyeWide*:0.8"},
    {"じと目", "eyeBlink*:0.45"},
    {"キリッ", "eyeSquint*:0.5 browDown*:0.3"},
    {"真面目", "browDown*:0.5"},
    {"困る", "browInnerUp:1"},
    {"にこり", "browInnerUp:0.3 browOuterUp*:0.5"},
    {"怒り", "browDown*:1 browOuterUp*:0.3"},
    {"上", "browInnerUp:1 browOuterUp*:1"},
    {"下", "browDown*:0.6"},
    {"あ", "@aa"},
    {"い", "@ih"},
    {"う", "@ou"},
    {"え", "@ee"},
    {"お", "@oh"},
    {"ああ", "jawOpen:1 mouthLowerDown*:0.4"},
    {"いい", "jawOpen:0.3 mouthStretch*:0.8"},
    {"叫び", "jawOpen:1 mouthStretch*:0.5"},
    {"∧", "mouthFrown*:1"},
    {"ω", "mouthPucker:0.5 mouthSmile*:0.3"},
    {"▲", "jawOpen:0.3 mouthFunnel:0.3"},
    {"はんっ！", "jawOpen:0.2 mouthUpperUp*:0.6"},
    {"えー", "jawOpen:0.2 mouthStretch*:0.5 mouthFrown*:0.4"},
    {"にやり", "mouthSmile*:0.8"},
    {"にっこり", "mouthSmile*:1 cheekSquint*:0.3"},
    {"口角上げ", "mouthSmile*:0.6"},
    {"口角下げ", "mouthFrown*:0.8"},
    {"口横広げ", "mouthStretch*:1"},
    {"ぺろっ", "jawOpen:0.2 tongueOut:1"},
};

// VRoid Studio's face shapes, after "Fcl_" (exports prefix them with the mesh's name).
constexpr NameRow kVroidRows[] = {
    {"EYE_Close", "eyeBlink*:1"},
    {"EYE_Close_L", "eyeBlinkLeft:1"},
    {"EYE_Close_R", "eyeBlinkRight:1"},
    {"EYE_Joy", "eyeBlink*:0.85 cheekSquint*:0.6"},
    {"EYE_Surprised", "eyeWide*:1"},
    {"EYE_Angry", "eyeSquint*:0.6"},
    {"BRW_Angry", "browDown*:1"},
    {"BRW_Sorrow", "browInnerUp:1"},
    {"BRW_Surprised", "browInnerUp:1 browOuterUp*:1"},
    {"MTH_A", "@aa"},
    {"MTH_I", "@ih"},
    {"MTH_U", "@ou"},
    {"MTH_E", "@ee"},
    {"MTH_O", "@oh"},
    {"MTH_Joy", "mouthSmile*:1"},
    {"MTH_Fun", "mouthSmile*:0.7"},
    {"MTH_Angry", "mouthFrown*:1"},
    {"MTH_Sorrow", "mouthFrown*:0.8"},
    {"MTH_Surprised", "jawOpen:0.5 mouthFunnel:0.5"},
};

std::string Lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

using Terms = std::vector<AxisTerm>;

struct Tables {
  std::unordered_map<std::string, uint8_t> arkit;  // Lower case, both spellings.
  std::unordered_map<std::string, Terms> sideless, vrm, mmd, vroid;
  Terms unit[kArkitAxes];
};

// "mouthSmile_L" spells "mouthSmileLeft".
std::string AppleSpelling(std::string_view name) {
  if (name.ends_with("_L")) return std::string(name.substr(0, name.size() - 2)) + "Left";
  if (name.ends_with("_R")) return std::string(name.substr(0, name.size() - 2)) + "Right";
  return std::string(name);
}

void AddTerm(const Tables& t, std::string_view name, float amount, Terms& out) {
  auto add = [&](const std::string& n) {
    const auto it = t.arkit.find(Lower(n));
    if (it != t.arkit.end()) out.push_back({it->second, amount});
  };
  if (name.ends_with("*")) {
    const std::string base(name.substr(0, name.size() - 1));
    add(base + "Left");
    add(base + "Right");
  } else {
    add(std::string(name));
  }
}

Terms ParseTerms(const Tables& t, std::string_view text) {
  Terms out;
  if (text.starts_with("@")) return t.vrm.at(std::string(text.substr(1)));
  size_t from = 0;
  while (from < text.size()) {
    const size_t end = std::min(text.find(' ', from), text.size());
    const std::string_view item = text.substr(from, end - from);
    const size_t colon = item.find(':');
    AddTerm(t, item.substr(0, colon), std::stof(std::string(item.substr(colon + 1))), out);
    from = end + 1;
  }
  return out;
}

Tables Build() {
  Tables t;
  for (int i = 0; i < kArkitAxes; ++i) {
    const std::string name(kArkitNames[i]);
    t.arkit[Lower(name)] = static_cast<uint8_t>(i);
    t.unit[i] = {{static_cast<uint8_t>(i), 1.0f}};
    for (const char* side : {"Left", "Right"}) {
      if (!name.ends_with(side)) continue;
      const std::string base = name.substr(0, name.size() - std::string_view(side).size());
      t.arkit[Lower(base + (side[0] == 'L' ? "_L" : "_R"))] = static_cast<uint8_t>(i);
      t.sideless[Lower(base)].push_back({static_cast<uint8_t>(i), 1.0f});
    }
  }
  for (std::string_view preset : kExpressionPresets) {
    Terms terms;
    for (const CandidateBind& b : ArkitPresetBinds(preset)) {
      const std::string_view shapes(b.shapes);
      const std::string_view first = shapes.substr(0, shapes.find('|'));
      AddTerm(t, AppleSpelling(first), b.weight, terms);
    }
    t.vrm[std::string(preset)] = std::move(terms);
  }
  for (const NameRow& r : kMmdRows) t.mmd[r.name] = ParseTerms(t, r.terms);
  for (const NameRow& r : kVroidRows) t.vroid[r.name] = ParseTerms(t, r.terms);
  return t;
}

const Tables& Get() {
  static const Tables kTables = Build();
  return kTables;
}

std::span<const AxisTerm> Find(const std::unordered_map<std::string, Terms>& map,
                               const std::string& key) {
  const auto it = map.find(key);
  return it == map.end() ? std::span<const AxisTerm>() : std::span<const AxisTerm>(it->second);
}

std::span<const AxisTerm> PlaceShape(const Tables& t, std::string_view name) {
  const std::string lower = Lower(name);
  if (const auto it = t.arkit.find(lower); it != t.arkit.end()) return t.unit[it->second];
  if (auto mmd = Find(t.mmd, std::string(name)); !mmd.empty()) return mmd;
  if (const size_t fcl = name.find("Fcl_"); fcl != std::string_view::npos) {
    if (auto vroid = Find(t.vroid, std::string(name.substr(fcl + 4))); !vroid.empty()) return vroid;
  }
  return Find(t.sideless, lower);
}

}  // namespace

std::span<const AxisTerm> Place(Vocabulary v, std::string_view name) {
  const Tables& t = Get();
  switch (v) {
    case Vocabulary::kArkit: {
      const auto it = t.arkit.find(Lower(name));
      return it == t.arkit.end() ? std::span<const AxisTerm>() : t.unit[it->second];
    }
    case Vocabulary::kVrm: return Find(t.vrm, std::string(name));
    case Vocabulary::kMmd: return Find(t.mmd, std::string(name));
    case Vocabulary::kOwn:
    case Vocabulary::kRig: return PlaceShape(t, name);
  }
  return {};
}

std::vector<std::string_view> VocabularyNames(Vocabulary v) {
  std::vector<std::string_view> names;
  if (v == Vocabulary::kArkit) names.assign(std::begin(kArkitNames), std::end(kArkitNames));
  if (v == Vocabulary::kVrm)
    names.assign(std::begin(kExpressionPresets), std::end(kExpressionPresets));
  if (v == Vocabulary::kMmd) {
    for (const NameRow& r : kMmdRows) names.push_back(r.name);
  }
  return names;
}

}  // namespace engine
}  // namespace facespace
