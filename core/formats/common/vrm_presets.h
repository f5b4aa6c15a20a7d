// VRM 0.x's preset expression names and 1.0's for the same faces: read by the importer (a 0.x blend
// shape group's presetName to our name) and written by the 0.x exporter (the other way; a face
// without a 0.x preset is "unknown" there, by its name).
#pragma once

namespace facespace::formats::vrm_presets {

struct PresetName {
  const char* one;   // VRM 1.0's (ours).
  const char* zero;  // VRM 0.x's.
};
// clang-format off
inline constexpr PresetName kPresets[] = {
    {"happy", "joy"}, {"angry", "angry"}, {"sad", "sorrow"}, {"relaxed", "fun"},
    {"aa", "a"}, {"ih", "i"}, {"ou", "u"}, {"ee", "e"},
    {"oh", "o"}, {"blink", "blink"}, {"blinkLeft", "blink_l"}, {"blinkRight", "blink_r"},
    {"lookUp", "lookup"}, {"lookDown", "lookdown"}, {"lookLeft", "lookleft"},
    {"lookRight", "lookright"}, {"neutral", "neutral"}};
// clang-format on

}  // namespace facespace::formats::vrm_presets
