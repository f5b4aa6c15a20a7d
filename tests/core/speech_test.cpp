// Phonemes to visemes to keys (core/speech.h), on the bundled rigs.
#include "facespace/engine/speech.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "facespace/formats/io.h"

namespace facespace {
namespace speech_test {  // Named: core_tests is a unity build, its files share one unit.

Rig Load(const std::string& rel) {
  auto rig = formats::LoadRigFile(std::string(FACESPACE_SOURCE_DIR) + "/assets/" + rel);
  EXPECT_TRUE(rig.ok()) << rig.status().message;
  return std::move(rig.value());
}

Viseme V(std::string_view p) {
  auto v = VisemeOfPhoneme(p);
  EXPECT_TRUE(v.has_value()) << p;
  return v.value_or(Viseme::kSil);
}

TEST(Speech, PhonemesInIpaAndArpabetGiveTheirVisemes) {
  // ARPAbet with stress digits (CMU, PocketSphinx), flite's lower case.
  EXPECT_EQ(V("M"), Viseme::kPP);
  EXPECT_EQ(V("b"), Viseme::kPP);
  EXPECT_EQ(V("AH0"), Viseme::kAA);
  EXPECT_EQ(V("IY1"), Viseme::kIH);
  EXPECT_EQ(V("UW"), Viseme::kOU);
  EXPECT_EQ(V("OW2"), Viseme::kOH);
  EXPECT_EQ(V("EY"), Viseme::kE);
  EXPECT_EQ(V("F"), Viseme::kFF);
  EXPECT_EQ(V("DH"), Viseme::kTH);
  EXPECT_EQ(V("JH"), Viseme::kCH);
  EXPECT_EQ(V("Z"), Viseme::kSS);
  EXPECT_EQ(V("NG"), Viseme::kKK);
  EXPECT_EQ(V("L"), Viseme::kNN);
  EXPECT_EQ(V("ER0"), Viseme::kRR);
  EXPECT_EQ(V("SIL"), Viseme::kSil);
  EXPECT_EQ(V("pau"), Viseme::kSil);
  EXPECT_EQ(V("+NSN+"), Viseme::kSil);
  // IPA (espeak-ng), with stress and length marks and diacritics.
  EXPECT_EQ(V("ˈəʊ"), Viseme::kOH);
  EXPECT_EQ(V("oʊ"), Viseme::kOH);
  EXPECT_EQ(V("aɪ"), Viseme::kAA);
  EXPECT_EQ(V("iː"), Viseme::kIH);
  EXPECT_EQ(V("θ"), Viseme::kTH);
  EXPECT_EQ(V("tʃ"), Viseme::kCH);
  EXPECT_EQ(V("ɹ"), Viseme::kRR);
  EXPECT_EQ(V("n̩"), Viseme::kNN);
  EXPECT_EQ(V("ɡ"), Viseme::kKK);
  EXPECT_EQ(V("ɯ"), Viseme::kOU);
  EXPECT_EQ(V("_"), Viseme::kSil);
  // h and the glottal stop take the next sound's shape.
  EXPECT_FALSE(VisemeOfPhoneme("h").has_value());
  EXPECT_FALSE(VisemeOfPhoneme("HH").has_value());
  EXPECT_FALSE(VisemeOfPhoneme("ʔ").has_value());
  EXPECT_EQ(V("Ж"), Viseme::kNN);  // Unknown: a neutral mouth, not silence.
}

TEST(Speech, VisemesMergeInheritAndSplitShortPauses) {
  const std::vector<TimedPhoneme> phonemes = {
      {"_", 0.0f, 0.1f},  {"h", 0.1f, 0.15f}, {"ə", 0.15f, 0.2f},
      {"l", 0.2f, 0.3f},  {"_", 0.3f, 0.34f},                      // A 40 ms pause: no closing.
      {"m", 0.34f, 0.4f}, {"b", 0.4f, 0.45f}, {"iː", 0.6f, 0.8f},  // A gap at 0.45..0.6: a pause.
  };
  const std::vector<TimedViseme> v = VisemesOfPhonemes(phonemes);
  ASSERT_EQ(v.size(), 6u);
  EXPECT_EQ(v[0].viseme, Viseme::kSil);
  EXPECT_EQ(v[1].viseme, Viseme::kAA);  // h + ə
  EXPECT_FLOAT_EQ(v[1].start, 0.1f);
  EXPECT_FLOAT_EQ(v[1].end, 0.2f);
  EXPECT_EQ(v[2].viseme, Viseme::kNN);
  EXPECT_FLOAT_EQ(v[2].end, 0.32f);     // Half the short pause.
  EXPECT_EQ(v[3].viseme, Viseme::kPP);  // m + b merged, and half the pause.
  EXPECT_FLOAT_EQ(v[3].start, 0.32f);
  EXPECT_FLOAT_EQ(v[3].end, 0.45f);
  EXPECT_EQ(v[4].viseme, Viseme::kSil);  // The gap.
  EXPECT_EQ(v[5].viseme, Viseme::kIH);
  for (size_t i = 1; i < v.size(); ++i) EXPECT_FLOAT_EQ(v[i].start, v[i - 1].end);
}

TEST(Speech, DerivedMapsForArkitAndMmdRigsAndNoneForAFaceSpace) {
  const Rig facecap = Load("facecap/facecap.glb");
  ASSERT_TRUE(CanSpeak(facecap).ok());
  const auto& aa = facecap.visemes.binds[static_cast<size_t>(Viseme::kAA)];
  const int jaw = FindShape(facecap, "jawOpen");
  ASSERT_GE(jaw, 0);
  EXPECT_TRUE(std::any_of(aa.begin(), aa.end(), [&](const auto& b) {
    return b.first == static_cast<uint32_t>(jaw) && b.second > 0.5f;
  }));
  EXPECT_EQ(facecap.visemes.jaw, std::vector<uint32_t>{static_cast<uint32_t>(jaw)});

  const Rig uka = Load("uka/MS_Uka.pmx");  // Her manifest's map, from her MMDAgent shapemap.
  ASSERT_TRUE(CanSpeak(uka).ok());
  const auto& ou = uka.visemes.binds[static_cast<size_t>(Viseme::kOU)];
  ASSERT_EQ(ou.size(), 1u);
  EXPECT_EQ(uka.shapes[ou[0].first].name, "う");
  EXPECT_EQ(uka.visemes.nolip.size(), 18u);
  EXPECT_EQ(uka.shapes[uka.visemes.nolip[0]].name, "え");

  const Rig cube =
      formats::LoadRigFile(test::RealAsset("AnimatedMorphCube/AnimatedMorphCube.gltf")).value();
  const Status s = CanSpeak(cube);
  EXPECT_EQ(s.code, StatusCode::kFailedPrecondition);
  EXPECT_EQ(s.reason, "no-mouth");
  EXPECT_NE(s.message.find("jawOpen"), std::string::npos);
}

float WeightAt(const Rig& rig, const Sequence& seq, float t, int shape) {
  std::vector<float> w(rig.shapes.size());
  SampleSequence(seq, t, w);
  return w[shape];
}

TEST(Speech, KeysSitAtTheVisemesTimesAndClosuresClose) {
  const Rig rig = Load("facecap/facecap.glb");
  const int jaw = FindShape(rig, "jawOpen"), press = FindShape(rig, "mouthPress_L");
  const std::vector<TimedViseme> visemes = {{Viseme::kSil, 0.0f, 0.2f},
                                            {Viseme::kAA, 0.2f, 0.45f},
                                            {Viseme::kPP, 0.45f, 0.48f},
                                            {Viseme::kAA, 0.48f, 0.6f},
                                            {Viseme::kSil, 0.6f, 0.9f}};
  const std::vector<float> base(rig.shapes.size(), 0.0f);
  SpeechOptions options;
  const Sequence seq = SpeechSequence(rig, visemes, base, options);
  ASSERT_TRUE(ValidateSequence(seq, rig.shapes.size()).ok());
  // Every key time is one of the visemes' own (VisemeKeyTimes) or an end.
  std::vector<float> expected = {0.0f, 0.9f};
  for (const TimedViseme& v : visemes) {
    for (float t : VisemeKeyTimes(v, options)) expected.push_back(std::clamp(t, 0.0f, 0.9f));
  }
  for (const Keyframe& k : seq.keys) {
    EXPECT_TRUE(std::any_of(expected.begin(), expected.end(), [&](float t) {
      return std::fabs(t - k.time) < 1e-6f;
    })) << k.time;
  }
  // The long aa holds its jaw (0.7) between its inset keys; silence is the base.
  EXPECT_NEAR(WeightAt(rig, seq, 0.3f, jaw), 0.7f, 1e-5f);
  EXPECT_NEAR(WeightAt(rig, seq, 0.05f, jaw), 0.0f, 1e-6f);
  // The 30 ms closure reaches closed lips (jaw 0, lips pressed) and holds them for a 30 fps frame.
  const float mid = 0.465f, hold = options.min_hold;
  for (float t : {mid - 0.5f * hold, mid, mid + 0.5f * hold}) {
    EXPECT_NEAR(WeightAt(rig, seq, t, jaw), 0.0f, 1e-6f) << t;
    EXPECT_NEAR(WeightAt(rig, seq, t, press), 0.5f, 1e-6f) << t;
  }
}

TEST(Speech, TheJawDoesNotChatterOnShortSyllables) {
  // "banana"-like: short vowels with short n's between them.
  const Rig rig = Load("facecap/facecap.glb");
  const int jaw = FindShape(rig, "jawOpen");
  std::vector<TimedViseme> visemes = {{Viseme::kSil, 0.0f, 0.1f}};
  float t = 0.1f;
  for (int i = 0; i < 6; ++i) {
    visemes.push_back({Viseme::kAA, t, t + 0.07f});
    visemes.push_back({Viseme::kNN, t + 0.07f, t + 0.12f});
    t += 0.12f;
  }
  visemes.push_back({Viseme::kSil, t, t + 0.2f});
  const std::vector<float> base(rig.shapes.size(), 0.0f);
  const Sequence seq = SpeechSequence(rig, visemes, base);
  // Over the syllables the jaw stays open: it never falls under 0.6 of its smaller peak, and swings
  // (peak - trough) less than half the full aa.
  float lo = 1e9f, hi = 0.0f;
  for (float s = 0.14f; s < t - 0.06f; s += 0.005f) {
    const float w = WeightAt(rig, seq, s, jaw);
    lo = std::min(lo, w);
    hi = std::max(hi, w);
  }
  EXPECT_GT(hi, 0.3f);               // It does open.
  EXPECT_GE(lo, 0.6f * hi - 1e-4f);  // And does not shut between the vowels.
  EXPECT_LT(hi - lo, 0.35f);
  EXPECT_LT(hi, 0.7f);  // Short vowels open less than a full aa.
}

TEST(Speech, MmdRigsHoldNolipShapesAtZeroWhileSpeaking) {
  const Rig uka = Load("uka/MS_Uka.pmx");
  const int e = FindShape(uka, "え"), smile = FindShape(uka, "にっこり"), a = FindShape(uka, "あ");
  std::vector<float> base(uka.shapes.size(), 0.0f);
  base[smile] = 0.8f;  // A smiling mouth under the speech.
  const std::vector<TimedViseme> visemes = {
      {Viseme::kSil, 0.0f, 0.2f}, {Viseme::kAA, 0.2f, 0.5f}, {Viseme::kSil, 0.5f, 0.8f}};
  const Sequence seq = SpeechSequence(uka, visemes, base);
  EXPECT_NEAR(WeightAt(uka, seq, 0.35f, a), 1.0f, 1e-5f);
  EXPECT_NEAR(WeightAt(uka, seq, 0.35f, smile), 0.0f, 1e-6f);
  EXPECT_NEAR(WeightAt(uka, seq, 0.35f, e), 0.0f, 1e-6f);
  EXPECT_NEAR(WeightAt(uka, seq, 0.05f, smile), 0.8f, 1e-6f);  // Back when silent.
  EXPECT_NEAR(WeightAt(uka, seq, 0.8f, smile), 0.8f, 1e-6f);
}

}  // namespace speech_test
}  // namespace facespace
