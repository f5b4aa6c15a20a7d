// WebM video in memory: VP9 (libvpx) frames and Opus audio, through Debian's libavcodec and
// libavformat, as browsers play them. Frames are rendered images (render.h); the audio is mono.
#pragma once

#include <memory>
#include <span>
#include <string>

#include "facespace/engine/status.h"
#include "facespace/offscreen/render.h"

namespace facespace::offscreen {

struct VideoOptions {
  int width = 512, height = 512;  // Even (4:2:0 chroma), 16 to 4096.
  double fps = 30.0;              // 1 to 120.
  int crf = 32;                   // VP9's constant quality, 0 (best) to 63.
  int threads = 1;                // Encoder threads.
  // Where the frames' conversion helpers' CPU is charged (facespace/engine/cpu.h); null: nowhere.
  HelperCpu* helper_cpu = nullptr;
};

class WebmEncoder {
 public:
  ~WebmEncoder();
  WebmEncoder(const WebmEncoder&) = delete;
  WebmEncoder& operator=(const WebmEncoder&) = delete;

  // An encoder with the whole audio already in (Opus, resampled to 48 kHz); `audio` may be empty
  // (no audio track). Errors: options out of range (InvalidArgument naming /width, /height or
  // /fps), a codec missing from libavcodec (Internal).
  static Result<std::unique_ptr<WebmEncoder>> Start(const VideoOptions& options,
                                                    std::span<const float> audio, int audio_rate);

  // The next frame, options.width x options.height (8-bit or float; alpha composited over white).
  Status Add(const picture::Image& frame);

  // The file: every frame encoded, the streams closed.
  Result<std::string> Finish();

 private:
  struct State;
  explicit WebmEncoder(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace facespace::offscreen
