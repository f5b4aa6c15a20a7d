// libFuzzer: speech's readers of outside bytes. First byte 0: the rest is a WAV (ReadWav, then
// resampled to PocketSphinx's 16 kHz and through the voice detector). Else: lines "NAME START END"
// of timed phonemes, as a recognizer could give them (any names, any times), to visemes and
// FaceCap's speech keys, which must always make a valid sequence (times strictly increasing, a
// weight per shape, finite).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "facespace/engine/speech.h"
#include "facespace/formats/io.h"
#include "facespace/speech/speech.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace facespace;
  if (size == 0) return 0;
  const std::string_view rest(reinterpret_cast<const char*>(data) + 1, size - 1);
  if (data[0] == 0) {
    auto audio = speech::ReadWav(
        rest, 0.25f);  // Short: the fuzzer's time goes to the parser, not the pitch search.
    if (!audio.ok()) return 0;
    const speech::Audio resampled = speech::Resample(audio.value(), 16000);
    const std::vector<bool> voiced = speech::VoiceActivity(resampled);
    if (voiced.size() > resampled.samples.size() / 160 + 1) std::abort();
    return 0;
  }
  static const Rig rig = [] {
    auto r = facespace::formats::LoadRigFile(FACESPACE_SOURCE_DIR "/assets/facecap/facecap.glb");
    if (!r.ok()) std::abort();
    return std::move(r.value());
  }();
  std::vector<TimedPhoneme> phonemes;
  std::istringstream in{std::string(rest)};
  std::string name;
  float start = 0, end = 0;
  while (phonemes.size() < 2000 && in >> name >> start >> end)
    phonemes.push_back({name, start, end});
  const std::vector<TimedViseme> visemes = VisemesOfPhonemes(phonemes);
  for (size_t i = 0; i < visemes.size(); ++i) {
    if (!(visemes[i].end > visemes[i].start) ||
        (i && visemes[i].start < visemes[i - 1].end - 1e-4f))
      std::abort();
  }
  if (visemes.empty() || !(visemes.back().end - visemes.front().start < 1e6f)) return 0;
  const std::vector<float> base(rig.shapes.size(), 0.0f);
  const Sequence seq = SpeechSequence(rig, visemes, base);
  if (!ValidateSequence(seq, rig.shapes.size()).ok()) std::abort();
  return 0;
}
