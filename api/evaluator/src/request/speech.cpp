// Request schema of speech (lip sync from text or audio).
#include <charconv>
#include <cmath>

#include "json_body.h"

namespace facespace::evaluator {

using namespace body;

namespace {

constexpr BodyLimits kSpeechBody{100000};

// RFC 4648 base64 (padding optional, whitespace skipped); false on any other byte.
bool DecodeBase64(std::string_view in, std::string& out) {
  out.clear();
  out.reserve(in.size() / 4 * 3);
  uint32_t acc = 0;
  int bits = 0;
  for (char c : in) {
    int v;
    if (c >= 'A' && c <= 'Z')
      v = c - 'A';
    else if (c >= 'a' && c <= 'z')
      v = c - 'a' + 26;
    else if (c >= '0' && c <= '9')
      v = c - '0' + 52;
    else if (c == '+' || c == '-')
      v = 62;
    else if (c == '/' || c == '_')
      v = 63;
    else if (c == '=' || c == '\n' || c == '\r' || c == ' ')
      continue;
    else
      return false;
    acc = (acc << 6) | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((acc >> bits) & 0xFF);
    }
  }
  return true;
}

// A speech setting (a body member, or a query parameter's text as JSON-ish), into r.
bool SpeechMember(const std::string& key, const json& v, SpeechRequest& r, Status& errors) {
  const std::string ptr = "/" + JsonPointerEscape(key);
  double d = 0;
  if (key == "text" || key == "transcript" || key == "voice") {
    if (!v.is_string())
      errors.fields.push_back({ptr, "must be a string"});
    else
      (key == "text"         ? r.text
       : key == "transcript" ? r.transcript
                             : r.voice) = v.get<std::string>();
  } else if (key == "audio") {
    r.has_audio = true;
    if (!v.is_string() || !DecodeBase64(v.get<std::string>(), r.audio)) {
      errors.fields.push_back({ptr,
                               "must be a WAV file as base64 (or POST the WAV itself as the body, "
                               "Content-Type audio/wav)"});
    }
  } else if (key == "rate" || key == "fps" || key == "strength") {
    if (ReadNumber(Body::kSpeech, key, v, ptr, &d, errors)) {
      if (key == "rate")
        r.rate = static_cast<int>(d);
      else
        (key == "fps" ? r.fps : r.strength) = static_cast<float>(d);
    }
  } else if (key == "format") {
    if (!v.is_string() || !ParseEnum(kFrameFormats, v.get<std::string>(), &r.format)) {
      errors.fields.push_back({ptr, "must be json, ndjson, f32, weights, wav or webm"});
    }
  } else if (key == "with_audio") {
    if (!v.is_boolean() && !(v.is_string() && (v == "true" || v == "false")))
      errors.fields.push_back({ptr, "must be true or false"});
    else
      r.with_audio = v.is_boolean() ? v.get<bool>() : v == "true";
  } else if (key == "gaze") {
    GazeTrackFromJson(v, ptr, r.gaze, errors);
  } else if (key == "blink") {
    r.blink = true;
    BlinkFromJson(v, ptr, r.blink_per_minute, r.blink_seed, errors);
  } else if (key == "weights" || key == "expressions" || key == "controls" || key == "mode" ||
             key == "normals" || key == "vocabulary") {
    MeshMember(key, v, r.render.mesh, false, errors);
  } else if (key == "width" || key == "height" || key == "camera" || key == "view" ||
             key == "background" || key == "supersample" || key == "exposure") {
    RenderMember(key, v, r.render, errors);
  } else {
    return false;
  }
  return true;
}

Status FinishSpeech(SpeechRequest& r, Status errors) {
  if (errors.fields.empty()) {
    if (r.has_audio == !r.text.empty()) {
      errors.fields.push_back(
          {"/text", r.has_audio
                        ? "give text or audio, not both"
                        : "is required: the words to say (or \"audio\": a WAV, as base64)"});
    } else if (!r.transcript.empty() && !r.has_audio) {
      errors.fields.push_back(
          {"/transcript", "aligns audio to its words; with text, the text is what is said"});
    }
  }
  return errors.fields.empty() ? Status::Ok() : Finish(std::move(errors));
}

}  // namespace

Result<SpeechRequest> ParseSpeechRequest(std::string_view text) {
  // A base64 WAV of 60 s at 48 kHz stereo is 15 MB: one string value, so the value count stays
  // small.
  SpeechRequest r;
  Status errors = InvalidArgument("");
  const Status parsed = ReadMembers(text, kSpeechBody, [&](const std::string& key, const json& v) {
    if (!SpeechMember(key, v, r, errors)) UnknownMember("", key, Body::kSpeech, errors);
  });
  if (!parsed.ok()) return parsed;
  if (Status s = FinishSpeech(r, std::move(errors)); !s.ok()) return s;
  return r;
}

Result<SpeechRequest> SpeechRequestOfWav(
    std::string wav, const std::vector<std::pair<std::string, std::string>>& settings) {
  SpeechRequest r;
  r.audio = std::move(wav);
  r.has_audio = true;
  Status errors = InvalidArgument("");
  for (const auto& [key, value] : settings) {
    if (key == "text" || key == "audio") {
      errors.fields.push_back({"/" + key, "the body is the audio; send text in a JSON body"});
      continue;
    }
    // Each setting's text as its declared kind: numbers as numbers, objects and arrays as JSON, the
    // rest as strings.
    const Member* m = FindMember(Body::kSpeech, key);
    json v = value;
    if (m && m->kind == Kind::kSchema) {
      v = json::parse(value, nullptr, false);
      if (v.is_discarded()) v = value;
    } else if (m && (m->kind == Kind::kNumber || m->kind == Kind::kInteger)) {
      double d = 0;
      const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), d);
      if (ec == std::errc() && end == value.data() + value.size() && !value.empty()) {
        if (d == std::floor(d) && std::fabs(d) < 1e15)
          v = static_cast<long long>(d);
        else
          v = d;
      }
    }
    if (!SpeechMember(key, v, r, errors)) UnknownMember("", key, Body::kSpeech, errors);
  }
  if (Status s = FinishSpeech(r, std::move(errors)); !s.ok()) return s;
  return r;
}

}  // namespace facespace::evaluator
