// Speech recognized while it is heard (speech.h, LiveRecognizer): PocketSphinx fed chunk by chunk,
// its best path read back as it grows, and what lies far enough behind the newest audio given out.
#include <algorithm>
#include <mutex>

#include "facespace/speech/speech.h"
#include "sphinx_decoder.h"

namespace facespace::speech {

namespace {

constexpr int kSamplesPerFrame = 160;  // 10 ms at 16 kHz.

// How many decoders the live recognizers hold: at most kMaxLiveDecoders.
struct Pool {
  std::mutex mu;
  int made = 0;
};
Pool& ThePool() {
  static Pool p;
  return p;
}

}  // namespace

Result<std::unique_ptr<LiveRecognizer>> LiveRecognizer::Open() {
  Pool& pool = ThePool();
  {
    std::lock_guard<std::mutex> lock(pool.mu);
    if (pool.made >= kMaxLiveDecoders) {
      return WithReason(
          ResourceExhausted("every live recognizer (" + std::to_string(kMaxLiveDecoders) +
                            ") is in use; retry shortly"),
          "busy");
    }
    ++pool.made;
  }
  ps_decoder_t* ps = NewAllPhoneDecoder();
  if (!ps) {
    std::lock_guard<std::mutex> lock(pool.mu);
    --pool.made;
    return Internal(
        "PocketSphinx could not start (its US English model, pocketsphinx-en-us, is missing)");
  }
  return std::unique_ptr<LiveRecognizer>(new LiveRecognizer(ps));
}

LiveRecognizer::~LiveRecognizer() {
  auto* ps = static_cast<ps_decoder_t*>(ps_);
  if (in_utterance_) ps_end_utt(ps);
  // Not reused: a decoder given a second utterance here gave no partial segments in it
  // (PocketSphinx 5prealpha's all-phone search); a new one takes 90 ms to make.
  FreeDecoder(ps);
  std::lock_guard<std::mutex> lock(ThePool().mu);
  --ThePool().made;
}

void LiveRecognizer::Take(int before, std::vector<TimedPhoneme>& out) {
  auto* ps = static_cast<ps_decoder_t*>(ps_);
  int32 score = 0;
  ps_get_hyp(ps, &score);  // The best path so far, for the segments.
  Audio window;
  window.rate = 16000;
  const int frames = static_cast<int>(audio_.size()) / kSamplesPerFrame;
  // The voice detector over what is given out now and half a second before it (its margins reach
  // 0.2 s).
  const int from = std::max(0, taken_ - 50);
  window.samples.reserve(audio_.size() - static_cast<size_t>(from) * kSamplesPerFrame);
  for (size_t i = static_cast<size_t>(from) * kSamplesPerFrame; i < audio_.size(); ++i)
    window.samples.push_back(audio_[i] / 32768.0f);
  const std::vector<bool> active = VoiceActivity(window);
  for (ps_seg_t* seg = ps_seg_iter(ps); seg; seg = ps_seg_next(seg)) {
    int sf = 0, ef = 0;
    ps_seg_frames(seg, &sf, &ef);
    if (sf < taken_) continue;
    if (ef >= before || ef >= frames) {
      ps_seg_free(seg);
      break;
    }
    AppendSegment(out, ps_seg_word(seg), static_cast<float>(offset_ + sf * 0.01),
                  static_cast<float>(offset_ + (ef + 1) * 0.01), Heard(active, from, sf, ef));
    taken_ = ef + 1;
  }
}

Status LiveRecognizer::Feed(std::span<const int16_t> pcm, std::vector<TimedPhoneme>& sure) {
  auto* ps = static_cast<ps_decoder_t*>(ps_);
  if (!in_utterance_) {
    if (ps_start_utt(ps) < 0) return Internal("PocketSphinx could not start an utterance");
    in_utterance_ = true;
  }
  audio_.insert(audio_.end(), pcm.begin(), pcm.end());
  if (ps_process_raw(ps, pcm.data(), pcm.size(), FALSE, FALSE) < 0)
    return Internal("PocketSphinx failed on the audio");
  const int frames = static_cast<int>(audio_.size()) / kSamplesPerFrame;
  Take(frames - kLagFrames, sure);
  if (audio_.size() >=
      static_cast<size_t>(kUtteranceSeconds * 16000)) {  // Bounded: a new utterance.
    if (Status s = Finish(sure); !s.ok()) return s;
  }
  return Status::Ok();
}

Status LiveRecognizer::Finish(std::vector<TimedPhoneme>& rest) {
  auto* ps = static_cast<ps_decoder_t*>(ps_);
  if (!in_utterance_) return Status::Ok();
  if (ps_end_utt(ps) < 0) return Internal("PocketSphinx could not end the utterance");
  in_utterance_ = false;
  const int frames = static_cast<int>(audio_.size()) / kSamplesPerFrame;
  Take(frames + 1, rest);
  if (frames > taken_)
    AppendSegment(rest, "SIL", static_cast<float>(offset_ + taken_ * 0.01),
                  static_cast<float>(offset_ + frames * 0.01), false);
  offset_ += static_cast<double>(audio_.size()) / 16000.0;
  audio_.clear();
  taken_ = 0;
  return Status::Ok();
}

}  // namespace facespace::speech
