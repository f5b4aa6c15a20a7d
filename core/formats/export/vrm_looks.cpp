// What a VRM looks like and which faces apps find in it: toon materials as MToon (1.0's extension,
// 0.x's material properties), material morphs as expressions' material colour binds, and the custom
// expressions apps drive by name (ARKit's 52 "perfect sync" shapes, OVR's 15 visemes).
#include <algorithm>
#include <cmath>

#include "export/vrm_parts.h"
#include "facespace/engine/blend.h"
#include "facespace/engine/color.h"
#include "facespace/engine/face.h"
#include "facespace/engine/speech.h"

namespace facespace::formats::writers {

namespace {

// MMD's shared toon ramps darken the side turned from the light to about three quarters of the lit
// colour.
constexpr float kShade = 0.75f;

float GammaOf(float linear) {
  return static_cast<float>(SrgbEncode(linear));
}  // 0.x's colours are written sRGB-encoded.

int BaseTexture(const ordered_json& gltf_material) {
  const auto pbr = gltf_material.find("pbrMetallicRoughness");
  if (pbr == gltf_material.end() || !pbr->contains("baseColorTexture")) return -1;
  return (*pbr)["baseColorTexture"].value("index", -1);
}

}  // namespace

ordered_json MToon1(const Material& m, const ordered_json& gltf_material) {
  if (!m.toon) return nullptr;
  const auto& c = m.base_color_factor;
  ordered_json x = {
      {"specVersion", "1.0"},
      {"transparentWithZWrite", false},
      {"renderQueueOffsetNumber", 0},
      {"shadeColorFactor", {Num(kShade * c[0]), Num(kShade * c[1]), Num(kShade * c[2])}},
      {"shadingShiftFactor", 0},
      {"shadingToonyFactor", 0.9},
      {"giEqualizationFactor", 0.9}};
  if (const int t = BaseTexture(gltf_material); t >= 0) x["shadeMultiplyTexture"] = {{"index", t}};
  x["outlineWidthMode"] = m.outline_width > 0 ? "screenCoordinates" : "none";
  if (m.outline_width > 0) {
    x["outlineWidthFactor"] = Num(m.outline_width);
    x["outlineColorFactor"] = {Num(m.outline_color[0]), Num(m.outline_color[1]),
                               Num(m.outline_color[2])};
    x["outlineLightingMixFactor"] = 0;  // MMD's edges are drawn unlit.
  }
  return x;
}

ordered_json MaterialProperties0(const Material& m, const ordered_json& gltf_material) {
  const std::string name = gltf_material.value("name", m.name);
  if (!m.toon)
    return {{"name", name},
            {"shader", "VRM_USE_GLTFSHADER"},
            {"floatProperties", ordered_json::object()},
            {"vectorProperties", ordered_json::object()},
            {"textureProperties", ordered_json::object()},
            {"keywordMap", ordered_json::object()},
            {"tagMap", ordered_json::object()}};
  const auto& c = m.base_color_factor;
  const bool blend = m.alpha_mode == "BLEND" || c[3] < 1.0f;
  ordered_json textures = ordered_json::object();
  if (const int t = BaseTexture(gltf_material); t >= 0)
    textures = {{"_MainTex", t}, {"_ShadeTexture", t}};
  ordered_json keywords = ordered_json::object();
  if (blend) keywords["_ALPHABLEND_ON"] = true;
  return {{"name", name},
          {"shader", "VRM/MToon"},
          {"renderQueue", blend ? 3000 : 2000},
          {"floatProperties",
           {{"_BlendMode", blend ? 2 : 0},
            {"_CullMode", m.double_sided ? 0 : 2},
            {"_ShadeShift", 0},
            {"_ShadeToony", 0.9},
            {"_IndirectLightIntensity", 0.1},
            {"_OutlineWidthMode", m.outline_width > 0 ? 2 : 0},
            {"_OutlineWidth", Num(100.0f * m.outline_width)},
            {"_OutlineColorMode", 0},
            {"_ZWrite", blend ? 0 : 1},
            {"_MToonVersion", 38}}},
          {"vectorProperties",
           {{"_Color", {Num(GammaOf(c[0])), Num(GammaOf(c[1])), Num(GammaOf(c[2])), Num(c[3])}},
            {"_ShadeColor",
             {Num(GammaOf(kShade * c[0])), Num(GammaOf(kShade * c[1])), Num(GammaOf(kShade * c[2])),
              1}},
            {"_OutlineColor",
             {Num(GammaOf(m.outline_color[0])), Num(GammaOf(m.outline_color[1])),
              Num(GammaOf(m.outline_color[2])), 1}},
            {"_MainTex", {0, 0, 1, 1}}}},
          {"textureProperties", textures},
          {"keywordMap", keywords},
          {"tagMap", {{"RenderType", blend ? "Transparent" : "Opaque"}}}};
}

ordered_json MaterialColorBinds(const Rig& rig, const Expression& e) {
  ordered_json binds = ordered_json::array();
  std::vector<float> weights(rig.shapes.size(), 0.0f);
  bool any = false;
  for (const auto& [shape, w] : e.binds) {
    if (shape < weights.size() && !rig.shapes[shape].material_morphs.empty())
      weights[shape] = w, any = true;
  }
  if (!any) return binds;
  std::vector<std::array<float, 4>> colors;
  MorphedMaterialColors(rig, weights, colors);
  for (size_t m = 0; m < colors.size() && m < rig.materials.size(); ++m) {
    const auto& base = rig.materials[m].base_color_factor;
    if (colors[m] == base) continue;
    binds.push_back(
        {{"material", m},
         {"type", "color"},
         {"targetValue",
          {Num(colors[m][0]), Num(colors[m][1]), Num(colors[m][2]), Num(colors[m][3])}}});
  }
  return binds;
}

std::vector<Expression> AppExpressions(const Rig& rig) {
  std::vector<Expression> out;
  for (std::string_view name : kArkitNames) {
    const int s = FindShape(rig, std::string(name));
    if (s < 0) continue;
    Expression e;
    e.name = name;
    e.binds.emplace_back(static_cast<uint32_t>(s), 1.0f);
    out.push_back(std::move(e));
  }
  for (size_t v = 0; v < kVisemeCount && !rig.visemes.empty();
       ++v) {  // sil (and often PP) is the closed mouth: no shape.
    Expression e;
    e.name = kOvrVisemeNames[v];
    e.binds = rig.visemes.binds[v];
    out.push_back(std::move(e));
  }
  return out;
}

}  // namespace facespace::formats::writers
