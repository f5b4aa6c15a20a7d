// WAV in and out, resampling and voice activity: audio as plain arrays, no library.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "facespace/speech/speech.h"

namespace facespace::speech {

namespace {

uint32_t U32(std::string_view b, size_t at) {
  return static_cast<uint32_t>(static_cast<unsigned char>(b[at])) |
         static_cast<uint32_t>(static_cast<unsigned char>(b[at + 1])) << 8 |
         static_cast<uint32_t>(static_cast<unsigned char>(b[at + 2])) << 16 |
         static_cast<uint32_t>(static_cast<unsigned char>(b[at + 3])) << 24;
}
uint16_t U16(std::string_view b, size_t at) {
  return static_cast<uint16_t>(static_cast<unsigned char>(b[at]) |
                               static_cast<unsigned char>(b[at + 1]) << 8);
}

Status Invalid(const std::string& message) {
  return WithReason(InvalidField("/audio", message), "invalid-audio");
}

void Put16(std::string& out, uint16_t v) {
  out += static_cast<char>(v & 0xFF);
  out += static_cast<char>(v >> 8);
}
void Put32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out += static_cast<char>((v >> (8 * i)) & 0xFF);
}

// One sample in [-1, 1]: PCM 8 (unsigned), 16, 24, 32, or float 32 (format 3; not finite: 0).
float SampleAt(const unsigned char* s, uint16_t format, uint16_t bits) {
  if (format == 3) {
    float v;
    std::memcpy(&v, s, 4);
    return std::isfinite(v) ? std::clamp(v, -1.0f, 1.0f) : 0.0f;
  }
  if (bits == 8) return (static_cast<int>(s[0]) - 128) / 128.0f;
  if (bits == 16) return static_cast<int16_t>(s[0] | s[1] << 8) / 32768.0f;
  if (bits == 24) {
    const int32_t x =
        static_cast<int32_t>(static_cast<uint32_t>(s[0]) << 8 | static_cast<uint32_t>(s[1]) << 16 |
                             static_cast<uint32_t>(s[2]) << 24);
    return static_cast<float>(x) / 2147483648.0f;
  }
  int32_t x;
  std::memcpy(&x, s, 4);
  return static_cast<float>(x) / 2147483648.0f;
}

}  // namespace

bool LooksLikeWav(std::string_view bytes) {
  return bytes.size() >= 12 && bytes.substr(0, 4) == "RIFF" && bytes.substr(8, 4) == "WAVE";
}

Result<WavLayout> ReadWavLayout(std::string_view b) {
  if (!LooksLikeWav(b)) return Invalid("not a WAV file (no RIFF/WAVE header); send 16-bit PCM WAV");
  size_t at = 12;
  bool have_fmt = false;
  WavLayout w;
  while (at + 8 <= b.size()) {
    const std::string_view id = b.substr(at, 4);
    const uint32_t size = U32(b, at + 4);
    const size_t body = at + 8;
    if (id == "fmt ") {
      if (size < 16 || body + 16 > b.size()) return Invalid("its fmt chunk is cut short");
      w.format = U16(b, body);
      w.channels = U16(b, body + 2);
      w.rate = static_cast<int>(U32(b, body + 4) & 0x7FFFFFFF);
      w.bits = U16(b, body + 14);
      if (w.format == 0xFFFE) {  // WAVE_FORMAT_EXTENSIBLE: the sub-format's first two bytes.
        if (size < 40 || body + 40 > b.size())
          return Invalid("its extensible fmt chunk is cut short");
        w.format = U16(b, body + 24);
      }
      have_fmt = true;
    } else if (id == "data") {
      if (!have_fmt) return Invalid("its data comes before its fmt chunk");
      if (w.format != 1 && w.format != 3)
        return Invalid("format " + std::to_string(w.format) +
                       " is not PCM or float (send 16-bit PCM WAV)");
      if (w.format == 1 && w.bits != 8 && w.bits != 16 && w.bits != 24 && w.bits != 32)
        return Invalid(std::to_string(w.bits) + "-bit PCM is not read (8, 16, 24 or 32)");
      if (w.format == 3 && w.bits != 32)
        return Invalid(std::to_string(w.bits) + "-bit float is not read (32)");
      if (w.channels < 1 || w.channels > 8)
        return Invalid(std::to_string(w.channels) + " channels (1 to 8 are read)");
      if (w.rate < 8000 || w.rate > 192000)
        return Invalid("a rate of " + std::to_string(w.rate) + " Hz (8 to 192 kHz are read)");
      const size_t frame = static_cast<size_t>(w.channels) * (w.bits / 8);
      const size_t available =
          std::min<size_t>(size, b.size() - body);  // Streamed WAVs say 0 or ~0: what is there.
      w.frames = (size == 0 || size == 0xFFFFFFFFu ? b.size() - body : available) / frame;
      w.data = body;
      return w;
    }
    if (size > b.size() - body) break;
    at = body + size + (size & 1);  // Chunks are padded to even sizes.
  }
  return Invalid(have_fmt ? "it has no data chunk" : "it has no fmt chunk");
}

Result<Audio> ReadWav(std::string_view b, float max_seconds) {
  auto layout = ReadWavLayout(b);
  if (!layout.ok()) return layout.status();
  const WavLayout& w = layout.value();
  if (w.seconds() > max_seconds) {
    return WithReason(
        InvalidField("/audio",
                     std::to_string(w.seconds()).substr(0, 6) + " s of audio, over the limit of " +
                         std::to_string(static_cast<int>(max_seconds)) + " s",
                     StatusCode::kResourceExhausted),
        "audio-too-long");
  }
  const size_t channels = w.channels, bytes = w.bits / 8u, frame = channels * bytes;
  Audio audio;
  audio.rate = w.rate;
  audio.samples.resize(w.frames);
  const unsigned char* p = reinterpret_cast<const unsigned char*>(b.data() + w.data);
  const float scale = 1.0f / static_cast<float>(channels);
  for (size_t i = 0; i < w.frames; ++i) {
    float sum = 0.0f;
    for (size_t c = 0; c < channels; ++c)
      sum += SampleAt(p + i * frame + c * bytes, w.format, w.bits);
    audio.samples[i] = sum * scale;
  }
  return audio;
}

std::string WriteWav(const Audio& audio) {
  const uint32_t data = static_cast<uint32_t>(audio.samples.size() * 2);
  std::string out;
  out.reserve(44 + data);
  out += "RIFF";
  Put32(out, 36 + data);
  out += "WAVEfmt ";
  Put32(out, 16);
  Put16(out, 1);
  Put16(out, 1);
  Put32(out, static_cast<uint32_t>(audio.rate));
  Put32(out, static_cast<uint32_t>(audio.rate) * 2);
  Put16(out, 2);
  Put16(out, 16);
  out += "data";
  Put32(out, data);
  for (float s : audio.samples)
    Put16(out, static_cast<uint16_t>(
                   static_cast<int16_t>(std::lround(std::clamp(s, -1.0f, 1.0f) * 32767.0f))));
  return out;
}

Audio Resample(const Audio& audio, int rate) {
  if (audio.rate == rate || audio.rate <= 0 || rate <= 0) return audio;
  Audio out;
  out.rate = rate;
  const double ratio = static_cast<double>(rate) / audio.rate;
  const size_t n = static_cast<size_t>(std::floor(audio.samples.size() * ratio));
  out.samples.resize(n);
  // Windowed sinc (Hann, 16 zero crossings each side of the lower rate's) with its cutoff at the
  // lower Nyquist.
  const double cutoff = std::min(1.0, ratio);  // Of the input's Nyquist.
  constexpr int kZeros = 16;
  const double half = kZeros / cutoff;  // Input samples each side.
  const auto& in = audio.samples;
  const long long size = static_cast<long long>(in.size());
  for (size_t i = 0; i < n; ++i) {
    const double center = i / ratio;
    const long long lo = std::max(0LL, static_cast<long long>(std::ceil(center - half)));
    const long long hi = std::min(size - 1, static_cast<long long>(std::floor(center + half)));
    double sum = 0.0, norm = 0.0;
    for (long long k = lo; k <= hi; ++k) {
      const double x = (k - center) * cutoff;
      const double sinc = x == 0.0 ? 1.0 : std::sin(M_PI * x) / (M_PI * x);
      const double window = 0.5 + 0.5 * std::cos(M_PI * (k - center) / half);
      const double w = sinc * window;
      sum += w * in[static_cast<size_t>(k)];
      norm += w;
    }
    out.samples[i] = norm != 0.0 ? static_cast<float>(sum / norm) : 0.0f;
  }
  return out;
}

std::vector<bool> VoiceActivity(const Audio& audio) {
  const size_t hop = static_cast<size_t>(audio.rate / 100);
  if (hop == 0) return {};
  const size_t frames = audio.samples.size() / hop;
  std::vector<float> energy(frames, 0.0f);
  std::vector<bool> voiced(frames, false);
  const auto& x = audio.samples;
  const size_t window = 3 * hop;  // 30 ms: two periods of a 60 Hz voice.
  const size_t min_lag = static_cast<size_t>(audio.rate / 400),
               max_lag = static_cast<size_t>(audio.rate / 60);
  float loudest = 0.0f;
  for (size_t f = 0; f < frames; ++f) {
    double e = 0.0;
    for (size_t i = f * hop; i < (f + 1) * hop; ++i) e += static_cast<double>(x[i]) * x[i];
    energy[f] = static_cast<float>(std::sqrt(e / hop));
    loudest = std::max(loudest, energy[f]);
  }
  // A voice: louder than -50 dBFS and 30 dB under the loudest frame, and periodic (normalized
  // autocorrelation over 0.5 at a pitch lag).
  const float floor = std::max(0.00316f, 0.0316f * loudest);
  for (size_t f = 0; f < frames; ++f) {
    if (energy[f] < floor) continue;
    const size_t start = f * hop;
    if (start + window + max_lag > x.size()) continue;
    double e0 = 0.0;
    for (size_t i = 0; i < window; ++i) e0 += static_cast<double>(x[start + i]) * x[start + i];
    double best = 0.0;
    for (size_t lag = std::max<size_t>(min_lag, 1); lag <= max_lag; ++lag) {
      double c = 0.0, e1 = 0.0;
      for (size_t i = 0; i < window; ++i) {
        c += static_cast<double>(x[start + i]) * x[start + i + lag];
        e1 += static_cast<double>(x[start + i + lag]) * x[start + i + lag];
      }
      if (e0 > 0.0 && e1 > 0.0) best = std::max(best, c / std::sqrt(e0 * e1));
    }
    voiced[f] = best > 0.5;
  }
  // Speech: within 0.2 s of a voiced frame, and not under the floor for long.
  std::vector<bool> active(frames, false);
  constexpr size_t kMargin = 20;
  for (size_t f = 0; f < frames; ++f) {
    if (!voiced[f]) continue;
    const size_t lo = f >= kMargin ? f - kMargin : 0,
                 hi = std::min<size_t>(frames, f + kMargin + 1);
    for (size_t g = lo; g < hi; ++g) active[g] = true;
  }
  return active;
}

}  // namespace facespace::speech
