// WebM through libavformat (the muxer, writing into memory), libavcodec (libvpx-vp9, libopus),
// libswscale (RGB to 4:2:0) and libswresample (the audio to Opus's 48 kHz).
#include "facespace/offscreen/video.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/channel_layout.h>
#include <libavutil/log.h>
#include <libavutil/opt.h>
#include <libswresample/swresample.h>
#include <libswscale/swscale.h>
}

#include <algorithm>
#include <cstring>
#include <vector>

#include "internal.h"

namespace facespace::offscreen {

namespace {

std::string AvError(int code) {
  char text[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(code, text, sizeof(text));
  return text;
}

// The file in memory, written and sought by the muxer (it goes back to fill in sizes and cues).
struct Memory {
  std::string bytes;
  int64_t at = 0;
};

int WritePacket(void* opaque, uint8_t* buf, int size) {
  auto* m = static_cast<Memory*>(opaque);
  const size_t end = static_cast<size_t>(m->at) + static_cast<size_t>(size);
  if (end > m->bytes.size()) m->bytes.resize(end);
  std::memcpy(m->bytes.data() + m->at, buf, static_cast<size_t>(size));
  m->at = static_cast<int64_t>(end);
  return size;
}

int64_t Seek(void* opaque, int64_t offset, int whence) {
  auto* m = static_cast<Memory*>(opaque);
  const int64_t size = static_cast<int64_t>(m->bytes.size());
  if (whence == AVSEEK_SIZE) return size;
  int64_t to = offset;
  if ((whence & ~AVSEEK_FORCE) == SEEK_CUR)
    to = m->at + offset;
  else if ((whence & ~AVSEEK_FORCE) == SEEK_END)
    to = size + offset;
  if (to < 0) return AVERROR(EINVAL);
  m->at = to;
  return to;
}

}  // namespace

struct WebmEncoder::State {
  VideoOptions options;
  Memory memory;
  AVFormatContext* format = nullptr;
  AVIOContext* io = nullptr;
  AVCodecContext* video = nullptr;
  AVCodecContext* audio = nullptr;
  AVStream* video_stream = nullptr;
  AVStream* audio_stream = nullptr;
  AVFrame* frame = nullptr;
  AVPacket* packet = nullptr;
  SwsContext* sws = nullptr;
  std::vector<unsigned char> room;
  int64_t next_pts = 0;
  bool header = false;

  ~State() {
    if (header && format) av_write_trailer(format);  // Unfinished: closed so nothing leaks.
    sws_freeContext(sws);
    av_packet_free(&packet);
    av_frame_free(&frame);
    avcodec_free_context(&video);
    avcodec_free_context(&audio);
    if (format) avformat_free_context(format);
    if (io) {
      av_freep(&io->buffer);
      avio_context_free(&io);
    }
  }

  // Every packet the codec has ready, into the file.
  Status Drain(AVCodecContext* codec, AVStream* stream) {
    for (;;) {
      const int r = avcodec_receive_packet(codec, packet);
      if (r == AVERROR(EAGAIN) || r == AVERROR_EOF) return Status::Ok();
      if (r < 0) return Internal("the encoder failed: " + AvError(r));
      av_packet_rescale_ts(packet, codec->time_base, stream->time_base);
      packet->stream_index = stream->index;
      const int w = av_interleaved_write_frame(format, packet);
      av_packet_unref(packet);
      if (w < 0) return Internal("the WebM muxer failed: " + AvError(w));
    }
  }

  // The WebM muxer writing into `memory`, a packet and a frame.
  Status OpenMuxer() {
    if (avformat_alloc_output_context2(&format, nullptr, "webm", nullptr) < 0 || !format)
      return Internal("libavformat has no WebM muxer");
    constexpr int kBuffer = 1 << 16;
    auto* buffer = static_cast<unsigned char*>(av_malloc(kBuffer));
    io = avio_alloc_context(buffer, kBuffer, 1, &memory, nullptr, WritePacket, Seek);
    if (!io) return Internal("out of memory");
    format->pb = io;
    format->flags |= AVFMT_FLAG_CUSTOM_IO;
    packet = av_packet_alloc();
    frame = av_frame_alloc();
    return Status::Ok();
  }

  // Video: VP9 at constant quality, real-time speed, a key frame every two seconds.
  Status OpenVideo(const AVCodec* vp9) {
    const VideoOptions& o = options;
    const AVRational rate = av_d2q(o.fps, 1001000);
    video = avcodec_alloc_context3(vp9);
    video->width = o.width;
    video->height = o.height;
    video->pix_fmt = AV_PIX_FMT_YUV420P;
    video->time_base = av_inv_q(rate);
    video->framerate = rate;
    video->gop_size = std::max(1, static_cast<int>(2 * o.fps));
    video->bit_rate = 0;
    video->thread_count = std::max(1, o.threads);
    video->colorspace = AVCOL_SPC_SMPTE170M;  // libswscale's default matrix (BT.601), as tagged.
    video->color_range = AVCOL_RANGE_MPEG;
    if (format->oformat->flags & AVFMT_GLOBALHEADER) video->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
    AVDictionary* vopts = nullptr;
    av_dict_set_int(&vopts, "crf", std::clamp(o.crf, 0, 63), 0);
    av_dict_set(&vopts, "deadline", "realtime", 0);
    av_dict_set_int(&vopts, "cpu-used", 8, 0);
    av_dict_set_int(&vopts, "row-mt", 1, 0);
    av_dict_set_int(&vopts, "lag-in-frames", 0, 0);
    const int r = avcodec_open2(video, vp9, &vopts);
    av_dict_free(&vopts);
    if (r < 0) return Internal("libvpx-vp9 would not open: " + AvError(r));
    video_stream = avformat_new_stream(format, nullptr);
    avcodec_parameters_from_context(video_stream->codecpar, video);
    video_stream->time_base = video->time_base;
    video_stream->avg_frame_rate = rate;
    return Status::Ok();
  }

  // Audio: Opus at 48 kHz, mono.
  Status OpenAudio(const AVCodec* opus) {
    audio = avcodec_alloc_context3(opus);
    audio->sample_rate = 48000;
    audio->sample_fmt = AV_SAMPLE_FMT_FLT;
    av_channel_layout_default(&audio->ch_layout, 1);
    audio->bit_rate = 48000;
    audio->time_base = AVRational{1, 48000};
    if (format->oformat->flags & AVFMT_GLOBALHEADER) audio->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
    const int r = avcodec_open2(audio, opus, nullptr);
    if (r < 0) return Internal("libopus would not open: " + AvError(r));
    audio_stream = avformat_new_stream(format, nullptr);
    avcodec_parameters_from_context(audio_stream->codecpar, audio);
    audio_stream->time_base = audio->time_base;
    return Status::Ok();
  }

  // The whole soundtrack (48 kHz) fed in the codec's frames, the last padded with silence.
  Status EncodeAudio(std::span<const float> pcm) {
    const int n = audio->frame_size > 0 ? audio->frame_size : 960;
    AVFrame* f = av_frame_alloc();
    Status result = Status::Ok();
    for (size_t at = 0; at < pcm.size() && result.ok(); at += static_cast<size_t>(n)) {
      f->nb_samples = n;
      f->format = AV_SAMPLE_FMT_FLT;
      f->sample_rate = 48000;
      av_channel_layout_copy(&f->ch_layout, &audio->ch_layout);
      if (av_frame_get_buffer(f, 0) < 0) {
        result = Internal("out of memory");
        break;
      }
      auto* dst = reinterpret_cast<float*>(f->data[0]);
      const size_t take = std::min(static_cast<size_t>(n), pcm.size() - at);
      std::copy_n(pcm.data() + at, take, dst);
      std::fill(dst + take, dst + n, 0.0f);
      f->pts = static_cast<int64_t>(at);
      const int r = avcodec_send_frame(audio, f);
      av_frame_unref(f);
      result = r < 0 ? Internal("libopus failed: " + AvError(r)) : Drain(audio, audio_stream);
    }
    av_frame_free(&f);
    if (!result.ok()) return result;
    avcodec_send_frame(audio, nullptr);
    return Drain(audio, audio_stream);
  }
};

namespace {

// Mono samples at `rate` resampled to 48 kHz (what the filter still holds flushed), or empty when
// libswresample will not start.
bool ResampleTo48k(std::span<const float> samples, int rate, std::vector<float>& pcm) {
  SwrContext* swr = nullptr;
  AVChannelLayout mono;
  av_channel_layout_default(&mono, 1);
  if (swr_alloc_set_opts2(&swr, &mono, AV_SAMPLE_FMT_FLT, 48000, &mono, AV_SAMPLE_FMT_FLT, rate, 0,
                          nullptr) < 0 ||
      swr_init(swr) < 0) {
    swr_free(&swr);
    return false;
  }
  pcm.assign(
      static_cast<size_t>(swr_get_out_samples(swr, static_cast<int>(samples.size()))) + 48000,
      0.0f);
  const uint8_t* in[] = {reinterpret_cast<const uint8_t*>(samples.data())};
  uint8_t* out[] = {reinterpret_cast<uint8_t*>(pcm.data())};
  int got =
      swr_convert(swr, out, static_cast<int>(pcm.size()), in, static_cast<int>(samples.size()));
  int total = std::max(0, got);
  while (got > 0 && static_cast<size_t>(total) < pcm.size()) {
    uint8_t* rest[] = {reinterpret_cast<uint8_t*>(pcm.data() + total)};
    got = swr_convert(swr, rest, static_cast<int>(pcm.size()) - total, nullptr, 0);
    total += std::max(0, got);
  }
  swr_free(&swr);
  pcm.resize(static_cast<size_t>(total));
  return true;
}

}  // namespace

WebmEncoder::WebmEncoder(std::unique_ptr<State> state) : state_(std::move(state)) {}
WebmEncoder::~WebmEncoder() = default;

// The muxer, VP9 and (with samples) Opus opened, the header written, the whole soundtrack encoded
// at once; then frames come one at a time (Add).
Result<std::unique_ptr<WebmEncoder>> WebmEncoder::Start(const VideoOptions& o,
                                                        std::span<const float> samples,
                                                        int audio_rate) {
  if (o.width < 16 || o.width > 4096 || o.width % 2)
    return InvalidField("/width", "a video's width is even, from 16 to 4096");
  if (o.height < 16 || o.height > 4096 || o.height % 2)
    return InvalidField("/height", "a video's height is even, from 16 to 4096");
  if (!(o.fps >= 1.0 && o.fps <= 120.0))
    return InvalidField("/fps", "a video has 1 to 120 frames a second");
  av_log_set_level(AV_LOG_ERROR);  // libvpx's banner and the muxer's notes are not ours to print.
  auto st = std::make_unique<State>();
  st->options = o;
  const AVCodec* vp9 = avcodec_find_encoder_by_name("libvpx-vp9");
  const AVCodec* opus = avcodec_find_encoder_by_name("libopus");
  if (!vp9 || !opus) return Internal("libavcodec has no libvpx-vp9 or libopus encoder");
  if (Status s = st->OpenMuxer(); !s.ok()) return s;
  if (Status s = st->OpenVideo(vp9); !s.ok()) return s;
  const bool has_audio = !samples.empty() && audio_rate > 0;
  if (has_audio) {
    if (Status s = st->OpenAudio(opus); !s.ok()) return s;
  }
  if (const int r = avformat_write_header(st->format, nullptr); r < 0)
    return Internal("the WebM header could not be written: " + AvError(r));
  st->header = true;
  if (has_audio) {
    std::vector<float> pcm;
    if (!ResampleTo48k(samples, audio_rate, pcm)) return Internal("libswresample would not start");
    if (Status s = st->EncodeAudio(pcm); !s.ok()) return s;
  }
  st->frame->format = AV_PIX_FMT_YUV420P;
  st->frame->width = o.width;
  st->frame->height = o.height;
  if (av_frame_get_buffer(st->frame, 0) < 0) return Internal("out of memory");
  st->sws = sws_getContext(o.width, o.height, AV_PIX_FMT_RGB24, o.width, o.height,
                           AV_PIX_FMT_YUV420P, SWS_BILINEAR, nullptr, nullptr, nullptr);
  if (!st->sws) return Internal("libswscale would not start");
  return std::unique_ptr<WebmEncoder>(new WebmEncoder(std::move(st)));
}

Status WebmEncoder::Add(const picture::Image& image) {
  State& st = *state_;
  if (image.width != st.options.width || image.height != st.options.height) {
    return Internal("a frame of " + std::to_string(image.width) + "x" +
                    std::to_string(image.height) + " in a video of " +
                    std::to_string(st.options.width) + "x" + std::to_string(st.options.height));
  }
  const std::span<const unsigned char> rgb = Pixels8(image, false, st.room, st.options.helper_cpu);
  if (av_frame_make_writable(st.frame) < 0) return Internal("out of memory");
  const uint8_t* src[] = {rgb.data()};
  const int stride[] = {3 * image.width};
  sws_scale(st.sws, src, stride, 0, image.height, st.frame->data, st.frame->linesize);
  st.frame->pts = st.next_pts++;
  const int r = avcodec_send_frame(st.video, st.frame);
  if (r < 0) return Internal("libvpx-vp9 failed: " + AvError(r));
  return st.Drain(st.video, st.video_stream);
}

Result<std::string> WebmEncoder::Finish() {
  State& st = *state_;
  avcodec_send_frame(st.video, nullptr);
  if (Status s = st.Drain(st.video, st.video_stream); !s.ok()) return s;
  st.header = false;
  const int r = av_write_trailer(st.format);
  if (r < 0) return Internal("the WebM trailer could not be written: " + AvError(r));
  avio_flush(st.io);
  return std::move(st.memory.bytes);
}

}  // namespace facespace::offscreen
