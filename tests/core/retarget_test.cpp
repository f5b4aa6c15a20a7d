// Retargeting weights between vocabularies (core/retarget.h): MMD's morphs onto FaceCap, ARKit's
// names onto the derived MakeHuman and onto a rig that has only あいうえお, VRM's presets, another
// rig's shapes, a VRM whose shapes only its expressions name; the errors.
#include "facespace/engine/retarget.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "facespace/engine/face.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace retarget_test {  // Named: core_tests is a unity build, its files share one unit.

const Rig& FaceCap() {
  static const Rig rig = formats::LoadRigFile(test::Bundled("facecap/facecap.glb")).value();
  return rig;
}

// A rig of shape names alone: what the solve reads.
Rig Named(std::initializer_list<const char*> names) {
  Rig rig;
  for (const char* n : names) rig.shapes.push_back({.name = n});
  return rig;
}

struct Solved {
  std::map<std::string, double> weights, expressions;
  std::vector<Warning> warnings;
};

Solved Solve(const Rig& rig, Vocabulary v, std::vector<WeightEntry> entries,
             const Rig* from = nullptr, const char* label = "test") {
  Solved s;
  Retargeted out;
  const Status status = Retarget(rig, {v, from, label}, entries, out, s.warnings);
  EXPECT_TRUE(status.ok()) << status.message;
  for (const WeightEntry& e : out.weights) s.weights[e.name] = e.value;
  for (const WeightEntry& e : out.expressions) s.expressions[e.name] = e.value;
  return s;
}

WeightEntry W(const char* name, double value) {
  return {name, -1, value, std::string("/weights/") + name};
}

TEST(Retarget, MmdMorphsMoveFaceCapByWhatTheyDo) {
  // あ alone opens the mouth: the table's aa, jaw 0.8 and the lower lip down 0.3, exactly.
  Solved a = Solve(FaceCap(), Vocabulary::kMmd, {W("あ", 1)});
  EXPECT_NEAR(a.weights["jawOpen"], 0.8, 1e-5);
  EXPECT_NEAR(a.weights["mouthLowerDown_L"], 0.3, 1e-5);
  EXPECT_NEAR(a.weights["mouthLowerDown_R"], 0.3, 1e-5);
  EXPECT_EQ(a.weights.size(), 3u);
  EXPECT_TRUE(a.warnings.empty());
  // まばたき closes both eyes, whole.
  Solved blink = Solve(FaceCap(), Vocabulary::kMmd, {W("まばたき", 1)});
  EXPECT_NEAR(blink.weights["eyeBlink_L"], 1.0, 1e-5);
  EXPECT_NEAR(blink.weights["eyeBlink_R"], 1.0, 1e-5);
  // う rounds the lips.
  Solved u = Solve(FaceCap(), Vocabulary::kMmd, {W("う", 1)});
  EXPECT_NEAR(u.weights["mouthPucker"], 1.0, 1e-5);
  EXPECT_LT(u.weights["jawOpen"], 0.2);
  // At half weight, half.
  EXPECT_NEAR(Solve(FaceCap(), Vocabulary::kMmd, {W("あ", 0.5)}).weights["jawOpen"], 0.4, 1e-5);
}

TEST(Retarget, ArkitNamesReachTheDerivedMakeHumanByItsOwnNames) {
  const Rig mh = formats::LoadRigFile(test::Bundled("makehuman/makehuman.glb")).value();
  // Apple's spelling to FaceCap's, which the derived shapes carry; MakeHuman's 286 identity
  // modifiers sit nowhere and stay 0.
  Solved s = Solve(mh, Vocabulary::kArkit,
                   {W("eyeBlinkLeft", 1), W("jawOpen", 0.5), W("mouthSmileRight", 0.7)});
  EXPECT_EQ(s.weights.size(), 3u);
  EXPECT_NEAR(s.weights["eyeBlink_L"], 1.0, 1e-6);
  EXPECT_NEAR(s.weights["jawOpen"], 0.5, 1e-6);
  EXPECT_NEAR(s.weights["mouthSmile_R"], 0.7, 1e-6);
  EXPECT_TRUE(s.warnings.empty());
}

TEST(Retarget, AnArkitStreamMovesARigThatHasOnlyTheFiveVowels) {
  const Rig vowels = Named({"あ", "い", "う", "え", "お"});
  // ARKit's open jaw with the lower lip down is あ; a pucker is mostly う.
  Solved a =
      Solve(vowels, Vocabulary::kArkit,
            {W("jawOpen", 0.8), W("mouthLowerDownLeft", 0.3), W("mouthLowerDownRight", 0.3)});
  EXPECT_NEAR(a.weights["あ"], 1.0, 1e-4);
  EXPECT_TRUE(a.warnings.empty());
  Solved u = Solve(vowels, Vocabulary::kArkit, {W("mouthPucker", 1)});
  ASSERT_TRUE(u.weights.count("う"));
  for (const auto& [name, w] : u.weights) EXPECT_LE(w, u.weights["う"]) << name;
  // A blink it cannot show: said, by name.
  Solved blink = Solve(vowels, Vocabulary::kArkit, {W("eyeBlinkLeft", 1), W("jawOpen", 0.4)},
                       nullptr, "arkit");
  ASSERT_EQ(blink.warnings.size(), 1u);
  EXPECT_EQ(blink.warnings[0].code, "vocabulary_unexpressed");
  EXPECT_EQ(blink.warnings[0].shape, "eyeBlinkLeft");
  EXPECT_NE(blink.warnings[0].message.find("eyeBlinkLeft 1 (shows 0)"), std::string::npos)
      << blink.warnings[0].message;
  EXPECT_NE(blink.warnings[0].message.find("arkit"), std::string::npos);
}

TEST(Retarget, AnArkitStreamClosesAndOpensUkasPmdWhichHasOnlyMmdsMorphs) {
  // The PMD Uka: 120 MMD morphs, no ARKit name. Both blinks are one まばたき, not a share of each
  // of her four eye-closing morphs; the jaw her あ family; her own eye_*_geo shapes sit nowhere.
  const Rig uka =
      formats::LoadRigFile(test::SharedAssets() + "/more/MMD/Uka_PMD/MS_Uka.pmd").value();
  ASSERT_LT(FindShape(uka, "jawOpen"), 0);
  Solved s = Solve(uka, Vocabulary::kArkit,
                   {W("eyeBlinkLeft", 1), W("eyeBlinkRight", 1), W("jawOpen", 0.8),
                    W("mouthLowerDownLeft", 0.3), W("mouthLowerDownRight", 0.3)});
  EXPECT_NEAR(s.weights["まばたき"], 1.0, 1e-4);
  for (const char* eye : {"とじ目", "ウィンク２", "ｳｨﾝｸ２右", "まば左", "まば右"})
    EXPECT_EQ(s.weights.count(eye), 0u) << eye;
  EXPECT_GT(s.weights["あ"] + s.weights["ああ"], 0.9);
  EXPECT_TRUE(s.warnings.empty()) << s.warnings[0].message;
}

TEST(Retarget, TheVocabularysOwnNameWinsOverATablesCombination) {
  // Uka carries both MMD's morphs and ARKit's names: each vocabulary reaches its own.
  const Rig both = Named({"あ", "まばたき", "jawOpen", "mouthLowerDownLeft", "mouthLowerDownRight",
                          "eyeBlinkLeft", "eyeBlinkRight", "eyeBlink"});
  Solved mmd = Solve(both, Vocabulary::kMmd, {W("あ", 1), W("まばたき", 1)});
  EXPECT_NEAR(mmd.weights["あ"], 1.0, 0.02);
  EXPECT_NEAR(mmd.weights["まばたき"], 1.0, 0.02);
  EXPECT_LT(mmd.weights["jawOpen"], 0.02);
  EXPECT_LT(mmd.weights["eyeBlink"], 0.02);
  Solved arkit = Solve(both, Vocabulary::kArkit,
                       {W("jawOpen", 1), W("eyeBlinkLeft", 1), W("eyeBlinkRight", 1)});
  EXPECT_NEAR(arkit.weights["jawOpen"], 1.0, 1e-4);
  EXPECT_NEAR(arkit.weights["eyeBlinkLeft"], 1.0, 0.02);
  EXPECT_LT(arkit.weights["あ"], 0.02);
  EXPECT_LT(arkit.weights["まばたき"], 0.02);
}

TEST(Retarget, VrmPresetsAndVroidShapes) {
  Solved happy = Solve(FaceCap(), Vocabulary::kVrm, {W("happy", 1), W("neutral", 1)});
  EXPECT_NEAR(happy.weights["mouthSmile_L"], 1.0, 1e-5);
  EXPECT_NEAR(happy.weights["mouthSmile_R"], 1.0, 1e-5);
  // VRoid's exports prefix Fcl_ shapes with the mesh's name.
  const Rig vroid = Named({"Face.M_F00_000_00_Fcl_MTH_A", "Face.M_F00_000_00_Fcl_EYE_Close_L"});
  Solved s = Solve(vroid, Vocabulary::kMmd, {W("あ", 1), W("ウィンク２", 1)});
  EXPECT_NEAR(s.weights["Face.M_F00_000_00_Fcl_MTH_A"], 1.0, 1e-4);
  EXPECT_NEAR(s.weights["Face.M_F00_000_00_Fcl_EYE_Close_L"], 1.0, 1e-4);
}

TEST(Retarget, AVrmWhoseShapesOnlyItsExpressionsNameFollowsThroughThem) {
  Rig vrm = Named({"Blink_Both", "Mouth_Open"});
  vrm.expressions.push_back({.name = "blink", .binds = {{0, 1.0f}}});
  vrm.expressions.push_back({.name = "aa", .binds = {{1, 1.0f}}});
  Solved s = Solve(vrm, Vocabulary::kArkit, {W("eyeBlinkLeft", 1), W("eyeBlinkRight", 1)});
  EXPECT_TRUE(s.weights.empty());
  EXPECT_NEAR(s.expressions["blink"], 1.0, 1e-4);
  EXPECT_LT(s.expressions["aa"], 1e-4);
}

TEST(Retarget, AnotherRigsShapesByWhatTheyDoElseByName) {
  Rig other = Named({"あ", "browLift"});
  Rig target = Named({"jawOpen", "mouthLowerDown_L", "mouthLowerDown_R", "browLift"});
  Solved s = Solve(target, Vocabulary::kRig, {W("あ", 1), W("browLift", 0.6)}, &other, "other");
  EXPECT_NEAR(s.weights["jawOpen"], 0.8, 1e-5);
  EXPECT_NEAR(s.weights["browLift"], 0.6, 1e-6);  // No table knows it: the same name.
  Rig lacking = Named({"jawOpen"});
  Solved l = Solve(lacking, Vocabulary::kRig, {W("browLift", 0.6)}, &other, "other");
  ASSERT_EQ(l.warnings.size(), 1u);
  EXPECT_NE(l.warnings[0].message.find("browLift 0.6"), std::string::npos) << l.warnings[0].message;
}

TEST(Retarget, ErrorsNameTheirEntry) {
  Retargeted out;
  std::vector<Warning> warnings;
  Status typo = Retarget(FaceCap(), {Vocabulary::kArkit, nullptr, "arkit"},
                         std::vector{W("jawOpem", 1)}, out, warnings);
  ASSERT_FALSE(typo.ok());
  ASSERT_EQ(typo.fields.size(), 1u);
  EXPECT_EQ(typo.fields[0].pointer, "/weights/jawOpem");
  EXPECT_NE(typo.fields[0].message.find("did you mean 'jawOpen'"), std::string::npos)
      << typo.fields[0].message;
  Status index = Retarget(FaceCap(), {Vocabulary::kMmd, nullptr, "mmd"},
                          std::vector<WeightEntry>{{"", 3, 1.0, "/weights/3"}}, out, warnings);
  ASSERT_FALSE(index.ok());
  EXPECT_EQ(index.fields[0].pointer, "/weights/3");
  Status nan = Retarget(FaceCap(), {Vocabulary::kMmd, nullptr, "mmd"}, std::vector{W("あ", NAN)},
                        out, warnings);
  ASSERT_FALSE(nan.ok());
  EXPECT_NE(nan.fields[0].message.find("finite"), std::string::npos);
  Rig other = Named({"あ"});
  Status unknown = Retarget(FaceCap(), {Vocabulary::kRig, &other, "other"}, std::vector{W("い", 1)},
                            out, warnings);
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.fields[0].pointer, "/weights/い");
}

// The other way (VMC out): a rig's weights in ARKit's 52, then as VRM's presets.
TEST(Retarget, WeightsGoOutAsArkitAndPresets) {
  const Rig rig = Named({"jawOpen", "あ", "whatever", "eyeBlink_L"});
  const auto places = ShapePlaces(rig);
  ASSERT_EQ(places.size(), 4u);
  EXPECT_TRUE(places[2].empty());
  std::array<float, kArkitAxes> arkit;
  const float w[] = {0.1f, 0.5f, 1.0f, 2.0f};
  ArkitOfWeights(places, w, arkit);
  auto axis = [](std::string_view name) {
    return std::find(std::begin(kArkitNames), std::end(kArkitNames), name) -
           std::begin(kArkitNames);
  };
  EXPECT_NEAR(arkit[axis("jawOpen")], 0.1 + 0.5 * 0.8, 1e-6);  // jawOpen, and あ's 0.8 of it.
  EXPECT_NEAR(arkit[axis("mouthLowerDownLeft")], 0.5 * 0.3, 1e-6);
  EXPECT_EQ(arkit[axis("eyeBlinkLeft")], 1.0f);  // 2 full blinks clamped to 1.
  EXPECT_EQ(arkit[axis("eyeBlinkRight")], 0.0f);

  // One eye shut is blinkLeft, both are blink (one preset, not its two sides); aa's own place is
  // aa.
  std::array<float, std::size(kExpressionPresets)> presets;
  auto preset = [&](std::string_view name) {
    return presets[std::find(std::begin(kExpressionPresets), std::end(kExpressionPresets), name) -
                   std::begin(kExpressionPresets)];
  };
  PresetsOfArkit(arkit, presets);
  EXPECT_NEAR(preset("blinkLeft"), 1.0, 1e-3);
  EXPECT_EQ(preset("blink"), 0.0f);
  // The jaw at 0.5 and the lower lip at 0.15 are aa (jaw 0.8, lip 0.3) at (0.8 x 0.5 + 2 x 0.3 x
  // 0.15) / (0.8^2 + 2 x 0.3^2) = 0.598 by least squares, a little less for its price.
  EXPECT_NEAR(preset("aa"), 0.598, 0.02);
  std::array<float, kArkitAxes> both{};
  both[axis("eyeBlinkLeft")] = both[axis("eyeBlinkRight")] = 1.0f;
  PresetsOfArkit(both, presets);
  EXPECT_NEAR(preset("blink"), 1.0, 1e-3);
  EXPECT_EQ(preset("blinkLeft"), 0.0f);
  EXPECT_EQ(preset("neutral"), 0.0f);
  std::array<float, kArkitAxes> none{};
  PresetsOfArkit(none, presets);
  EXPECT_TRUE(std::all_of(presets.begin(), presets.end(), [](float v) { return v == 0.0f; }));
}

}  // namespace retarget_test
}  // namespace facespace
