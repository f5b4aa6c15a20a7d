// GET /v1/rigs/{id}/live, upgraded to a WebSocket (issue 53): one face per socket. Text messages
// set the state ({"weights"}, {"expressions"}, {"gaze"}, {"pose"}, {"controls"}, merged into the
// current point as the mesh route reads them); each change is answered by one binary message, a
// 16-byte header then the same bytes as GET /mesh?format=f32 for that point (or, after {"frames":
// ...}, its weights or its moved positions packed), at most 60 a second (the hub coalesces). The
// session's UDP side (VMC, iFacialMocap) is live_mocap.h's.
#include <cstring>
#include <nlohmann/json.hpp>

#include "../http/cost.h"
#include "../http/problem.h"
#include "facespace/evaluator/members.h"
#include "facespace/formats/frames.h"
#include "facespace/lipsync/lipsync.h"
#include "facespace/net/framing.h"
#include "facespace/net/live_hub.h"
#include "facespace/speech/speech.h"
#include "live_landmarks.h"
#include "live_listen.h"
#include "live_mocap.h"
#include "live_say.h"
#include "routes.h"

namespace facespace::http {

namespace {

using nlohmann::json;

// The header of a binary message: tag, frame number, the newest "id" the frame reflects, reserved.
constexpr char kMeshTag[4] = {'m', 'e', 's', 'h'};
constexpr char kWeightsTag[4] = {'w', 'g', 't', 's'};
constexpr char kKeyTag[4] = {'d', 'k', 'e', 'y'};
constexpr char kDeltaTag[4] = {'d', 'l', 't', 'a'};
constexpr double kDeltaError = 1e-4;  // Delta frames' grid step, of the face's diagonal.
constexpr size_t kHeaderBytes = 16;

// The members a state message may carry, merged into the point; and the others it may carry.
constexpr std::string_view kMerged[] = {"weights", "expressions", "controls", "gaze"};

class FaceSession final : public net::LiveHandler {
 public:
  FaceSession(ServerState& ctx, std::shared_ptr<const evaluator::StoredRig> rig, json limits)
      : ctx_(ctx), rig_(std::move(rig)), limits_(std::move(limits)) {
    request_.format = formats::MeshFormat::kF32;
    ResolvePoint(rig_->rig, request_, point_);  // The rest point: every weight 0.
  }

  void Open(Out& out) override {
    out.texts.push_back(json{
        {"event", "ready"},
        {"rig", rig_->id},
        {"version", rig_->version},
        {"header_bytes", kHeaderBytes},
        {"limits", limits_}}.dump());
    out.frame_wanted = true;  // The face as it starts.
  }

  void OnText(std::string_view text, Out& out) override {
    json m = json::parse(text, nullptr, false);
    if (m.is_discarded() || !m.is_object()) {
      out.texts.push_back(ErrorEvent(
          "malformed-message", "a message is a JSON object: {\"weights\": {\"jawOpen\": 0.5}}"));
      return;
    }
    if (m.contains("listen")) return Listen(m, out);
    if (m.contains("vmc")) {
      out.frame_wanted |= mocap_.Vmc(m, rig_->rig, ctx_.options.vmc_hosts, out.texts);
      return;
    }
    if (m.contains("frames")) return SetFrames(m, out);
    for (MocapProtocol p : {MocapProtocol::kVmc, MocapProtocol::kIFacialMocap}) {
      if (m.contains(MocapMember(p)))
        return mocap_.Listen(p, m, ctx_.options.vmc_hosts, wake_, out.texts);
    }
    if (m.contains("landmarks")) return Landmarks(m, out);
    if (m.contains("say") || m.contains("stop")) return Speech(m, out);
    json next = state_;
    if (mocap_weights_ && m.contains("weights") && !m.contains("vocabulary")) {
      // The weights a VMC or iFacialMocap port set are ARKit's: the rig's own start over.
      next.erase("vocabulary");
      next.erase("weights");
    }
    uint32_t id = last_id_;
    for (auto it = m.begin(); it != m.end(); ++it) {
      const std::string& key = it.key();
      if (key == "id") {
        if (!it->is_number_unsigned() || it->get<uint64_t>() > UINT32_MAX) {
          out.texts.push_back(
              ErrorEvent("invalid-message", "id must be an integer from 0 to 4294967295", "/id"));
          return;
        }
        id = it->get<uint32_t>();
      } else if (key == "pose") {
        next["pose"] = *it;
      } else if (key == "vocabulary") {
        if (next.value("vocabulary", json()) != *it) next.erase("weights");
        next["vocabulary"] = *it;
      } else if (std::find(std::begin(kMerged), std::end(kMerged), key) != std::end(kMerged)) {
        if (!it->is_object()) {
          out.texts.push_back(ErrorEvent(
              "invalid-message", key + " must be an object of names and values", "/" + key));
          return;
        }
        json& into = next[key];
        if (!into.is_object()) into = json::object();
        for (auto v = it->begin(); v != it->end(); ++v) {
          if (v->is_null())
            into.erase(v.key());  // null: back to the rest value.
          else
            into[v.key()] = *v;
        }
        if (into.empty()) next.erase(key);
      } else {
        std::string valid;  // The message's members: its table (facespace/evaluator/members.h).
        for (const evaluator::Member& k : Members(evaluator::Body::kLive))
          valid += (valid.empty() ? "" : ", ") + std::string(k.name);
        out.texts.push_back(ErrorEvent(
            "unknown-member", "unknown member '" + key.substr(0, 64) + "'; valid: " + valid,
            "/" + key.substr(0, 64)));
        return;
      }
    }
    if (Status s = Show(next); !s.ok()) return Refuse(s, out);
    if (m.contains("weights") || m.contains("vocabulary")) mocap_weights_ = false;
    state_ = std::move(next);
    last_id_ = id;
    out.frame_wanted = true;
    SayWarnings(out);
  }

  void OnBinary(std::string_view bytes, Out& out) override {
    if (!listener_) {
      out.close = true;
      out.code = net::ws::CloseCode::kUnsupportedData;
      out.reason = "binary messages are audio, and need {\"listen\": ...} first";
      return;
    }
    if (bytes.size() % 2)
      return out.texts.push_back(
          ErrorEvent("invalid-audio", "audio is 16-bit samples: an even number of bytes"));
    std::vector<int16_t> pcm(bytes.size() / 2);
    std::memcpy(pcm.data(), bytes.data(), bytes.size());  // Little-endian, as this machine.
    if (Status s = listener_->Feed(pcm); !s.ok()) {
      // Faster than it plays: the session ends (a client that streams a microphone never gets
      // here).
      out.close = true;
      out.code = net::ws::CloseCode::kPolicy;
      out.reason = s.message.substr(0, 120);
    }
  }

  // What the listener's thread heard since the last turn: visemes (and mouth frames); its end.
  void Poll(Out& out) override {
    PollMocap(out);
    if (!listener_) return;
    if (Status s = listener_->Take(heard_); !s.ok()) Refuse(s, out);
    if (!listener_->Ended()) return SayHeard(false, out);
    SayHeard(true, out);
    DropListener();
    out.texts.push_back(json{{"event", "listen"}, {"state", "end"}}.dump());
  }

  // The listener let go (its thread joined outside the lock, which Cancel takes from the hub's
  // loop).
  void DropListener() {
    std::unique_ptr<LiveListener> old;
    std::lock_guard<std::mutex> lock(listener_mu_);
    old = std::move(listener_);
  }

  double TakeHelperCpu() override {
    double cpu = (listener_ ? listener_->TakeCpu() : 0.0) + speaker_.TakeCpu();
    cpu += mocap_.TakeCpu();
    return cpu;
  }

  bool MakeFrame(std::string& message, Out& out) override {
    mocap_.Send(point_.weights);  // The same face to the VTubers' apps.
    if (frames_ == Frames::kWeights) return WeightsFrame(message);
    auto ws =
        ctx_.workspaces.Acquire(stop_.get_token(), nullptr);  // f32 frames: no helper threads.
    ctx_.metrics.CountBlends(1);
    auto enc = ctx_.evaluator.Run(
        rig_, point_, evaluator::OutputSpec::Mesh(request_, formats::MeshFormat::kF32), *ws);
    if (!enc.ok()) {
      out.texts.push_back(ErrorEvent(enc.status().reason.empty() ? "error" : enc.status().reason,
                                     enc.status().message));
      return false;
    }
    const auto pieces = enc->pieces();
    if (frames_ == Frames::kDelta) return DeltaFrame(pieces, message);
    message.reserve(kHeaderBytes + pieces[0].size() + pieces[1].size());
    Header(kMeshTag, message);
    message.append(pieces[0]).append(pieces[1]);
    return true;
  }

  void Attach(net::LivePost post, net::LiveWake wake) override {
    speaker_.Attach(std::move(post));
    wake_ = std::move(wake);
  }
  void Cancel() override {
    stop_.request_stop();
    speaker_.Stop();
    std::lock_guard<std::mutex> lock(listener_mu_);
    if (listener_) listener_->Cancel();
    mocap_.Cancel();
  }
  void End() override {
    speaker_.Close();
    DropListener();  // Its thread joined (stopped by Cancel).
    mocap_.Close();
  }

 private:
  void Header(const char (&tag)[4], std::string& message) {
    message.append(tag, 4);
    PutU32(message, ++frame_);
    PutU32(message, last_id_);
    PutU32(message, 0);
  }

  // "wgts": the shapes' weights (u32 count, float32 each, the rig's order) and, posed, every
  // node's local transform (u32 count, 10 float32 each: translation, rotation xyzw, scale): what a
  // client blending the rig's glb itself applies, as the server does.
  bool WeightsFrame(std::string& message) {
    const std::vector<float>& w = point_.weights;
    const size_t nodes = point_.posed ? point_.pose.local.size() : 0;
    message.reserve(kHeaderBytes + 8 + 4 * w.size() + 40 * nodes);
    Header(kWeightsTag, message);
    PutU32(message, static_cast<uint32_t>(w.size()));
    PutU32(message, static_cast<uint32_t>(nodes));
    message.append(reinterpret_cast<const char*>(w.data()), 4 * w.size());
    for (size_t n = 0; n < nodes; ++n) {
      const Transform& t = point_.pose.local[n];
      message.append(reinterpret_cast<const char*>(t.translation.data()), 12);
      message.append(reinterpret_cast<const char*>(t.rotation.data()), 16);
      message.append(reinterpret_cast<const char*>(t.scale.data()), 12);
    }
    return true;
  }

  // "dkey" or "dlta": the positions of the f32 frame (its first half) as 16-bit grid coordinates,
  // whole or what moved since the last (formats/frames.h).
  bool DeltaFrame(std::span<const std::string_view> pieces, std::string& message) {
    size_t total = 0;
    for (std::string_view p : pieces) total += p.size();
    positions_.resize(total / 8);  // Positions are half of the floats.
    size_t at = 0;
    for (std::string_view p : pieces) {
      const size_t n = std::min(p.size(), positions_.size() * 4 - at);
      std::memcpy(reinterpret_cast<char*>(positions_.data()) + at, p.data(), n);
      at += n;
    }
    const size_t start = message.size();
    Header(kDeltaTag, message);
    if (delta_.Encode(positions_, message)) std::memcpy(message.data() + start, kKeyTag, 4);
    return true;
  }

  // {"frames": {"kind": "f32" | "weights" | "delta"}}: what the binary frames carry from the next
  // one; delta starts with a keyframe (asking again asks for one).
  void SetFrames(const json& m, Out& out) {
    const json& f = m["frames"];
    if (m.size() != 1)
      return out.texts.push_back(
          ErrorEvent("invalid-message", "frames goes alone in its message", "/frames"));
    Status errors = Status::Ok();
    if (!f.is_object() || !f.contains("kind") || !f["kind"].is_string())
      errors.AddField("/frames", "frames is {\"kind\": \"f32\" | \"weights\" | \"delta\"}");
    else
      evaluator::RefuseUnknown(f, "/frames", evaluator::Body::kLiveFrames, errors);
    if (!errors.fields.empty()) return Refuse(FieldErrors(std::move(errors)), out);
    const std::string kind = f["kind"].get<std::string>();
    json event = {{"event", "frames"}, {"kind", kind}};
    if (kind == "f32") {
      frames_ = Frames::kF32;
    } else if (kind == "weights") {
      frames_ = Frames::kWeights;
      event.update({{"shapes", rig_->rig.shapes.size()}});
    } else if (kind == "delta") {
      frames_ = Frames::kDelta;
      delta_.Keyframe();
      event.update({{"error", kDeltaError}});  // Of the diagonal, a vertex at most.
    } else {
      return out.texts.push_back(
          ErrorEvent("invalid-message", "kind is f32, weights or delta", "/frames/kind"));
    }
    out.texts.push_back(event.dump());
    out.frame_wanted = true;  // The face as it is, in the new kind.
  }

  // {"say": {"text", "voice", "rate"}} queued for the speaker; {"stop": true} ends the speech.
  void Speech(const json& m, Out& out) {
    for (auto it = m.begin(); it != m.end(); ++it) {
      if (it.key() != "say" && it.key() != "stop") {
        return out.texts.push_back(ErrorEvent(
            "invalid-message",
            "say and stop go alone in their message, not with '" + it.key().substr(0, 64) + "'",
            "/" + it.key().substr(0, 64)));
      }
    }
    if (m.contains("stop")) {
      if (m["stop"] != true)
        return out.texts.push_back(ErrorEvent("invalid-message", "stop must be true", "/stop"));
      if (!speaker_.Stop()) out.texts.push_back(json{{"event", "say"}, {"state", "idle"}}.dump());
      return;
    }
    const json& say = m["say"];
    if (!say.is_object() || !say.contains("text") || !say["text"].is_string()) {
      return out.texts.push_back(
          ErrorEvent("invalid-message",
                     "say is {\"text\": \"...\", \"voice\": \"en-us\", \"rate\": 175}", "/say"));
    }
    if (Status s = CanSpeak(rig_->rig); !s.ok()) return Refuse(s, out);
    std::string voice = kDefaultVoice;
    int rate = 175;
    for (auto it = say.begin(); it != say.end(); ++it) {
      const std::string where = "/say/" + it.key().substr(0, 64);
      if (!FindMember(evaluator::Body::kLiveSay, it.key())) {
        return out.texts.push_back(ErrorEvent(
            "unknown-member", "say takes text, voice (a string) and rate (words a minute)", where));
      }
      if (it.key() == "voice" && it->is_string())
        voice = it->get<std::string>();
      else if (it.key() == "rate" && it->is_number_integer())
        rate = it->get<int>();
      else if (it.key() != "text")
        return out.texts.push_back(ErrorEvent(
            "invalid-message", "voice is a string and rate an integer (words a minute)", where));
    }
    if (Status s = speaker_.Say(say["text"].get<std::string>(), voice, rate); !s.ok())
      Refuse(s, out, "/say");
  }

  // {"landmarks": {"scheme", "image", "points"}, "id": N}: a tracker's frame as the face's weights
  // (they replace the weights, in the rig's own names), answered by a frame and a weights event.
  void Landmarks(const json& m, Out& out) {
    uint32_t id = last_id_;
    for (auto it = m.begin(); it != m.end(); ++it) {
      if (it.key() == "id" && it->is_number_unsigned() && it->get<uint64_t>() <= UINT32_MAX)
        id = it->get<uint32_t>();
      else if (it.key() != "landmarks")
        return out.texts.push_back(
            ErrorEvent("invalid-message", "landmarks go alone in their message, with an id at most",
                       "/" + it.key().substr(0, 64)));
    }
    json weights, head;
    if (Status s = landmarks_.Feed(ctx_, *rig_, m["landmarks"], stop_.get_token(), weights, head);
        !s.ok())
      return Refuse(s, out);
    json next = state_;
    next.erase("vocabulary");
    next["weights"] = weights;
    if (weights.empty()) next.erase("weights");
    if (Status s = Show(next); !s.ok()) return Refuse(s, out);
    state_ = std::move(next);
    last_id_ = id;
    out.frame_wanted = true;
    out.texts.push_back(
        json{{"event", "weights"}, {"id", id}, {"weights", weights}, {"head", head}}.dump());
    SayWarnings(out);
  }

  // Each inlet's newest face (live_mocap.h) as the face's weights, in ARKit's names.
  void PollMocap(Out& out) {
    mocap_.Poll(faces_, out.texts);
    for (json& weights : faces_) {
      json next = state_;
      next["vocabulary"] = "arkit";
      next["weights"] = std::move(weights);
      if (Status s = Show(next); !s.ok()) {
        Refuse(s, out);
        continue;
      }
      state_ = std::move(next);
      mocap_weights_ = true;
      out.frame_wanted = true;
      SayWarnings(out);
    }
  }

  // {"listen": {"rate": 16000, "frames": false}} starts hearing binary audio; {"listen": false}
  // ends it.
  void Listen(const json& m, Out& out) {
    const json& l = m["listen"];
    if (m.size() != 1)
      return out.texts.push_back(
          ErrorEvent("invalid-message", "listen goes alone in its message", "/listen"));
    if (l == false) {
      // The end event follows the last visemes, once the listener's thread has decoded what waits
      // (Poll).
      if (listener_) return listener_->Finish();
      return out.texts.push_back(json{{"event", "listen"}, {"state", "end"}}.dump());
    }
    if (!l.is_object())
      return out.texts.push_back(ErrorEvent(
          "invalid-message", "listen is {\"rate\": 16000, \"frames\": false} or false", "/listen"));
    for (auto it = l.begin(); it != l.end(); ++it) {
      const std::string where = "/listen/" + it.key().substr(0, 64);
      if (it.key() == "rate" && (!it->is_number_integer() || it->get<int>() != 16000)) {
        return out.texts.push_back(ErrorEvent("invalid-message",
                                              "the audio's rate must be 16000 (16-bit mono PCM; a "
                                              "browser resamples with an AudioContext of 16 kHz)",
                                              where));
      }
      if (it.key() == "frames" && !it->is_boolean())
        return out.texts.push_back(
            ErrorEvent("invalid-message", "frames must be true or false", where));
      if (!FindMember(evaluator::Body::kLiveListen, it.key()))
        return out.texts.push_back(
            ErrorEvent("unknown-member", "listen takes rate and frames", where));
    }
    if (Status s = CanSpeak(rig_->rig); !s.ok()) return Refuse(s, out);
    if (listener_)
      return out.texts.push_back(ErrorEvent(
          "invalid-message", "already listening: {\"listen\": false} ends it", "/listen"));
    auto opened = LiveListener::Open(wake_);
    if (!opened.ok()) return Refuse(opened.status(), out);
    {
      std::lock_guard<std::mutex> lock(listener_mu_);
      listener_ = std::move(opened.value());
    }
    listen_frames_ = l.value("frames", false);
    heard_.clear();
    out.texts.push_back(json{{"event", "listen"}, {"state", "start"}, {"rate", 16000}}.dump());
  }

  // The visemes of what was heard, each once it is sure (the last held until the next begins,
  // unless `all`).
  void SayHeard(bool all, Out& out) {
    if (heard_.empty()) return;
    std::vector<TimedViseme> v = VisemesOfPhonemes(heard_);
    const size_t n = all ? v.size() : (v.size() > 1 ? v.size() - 1 : 0);
    for (size_t i = 0; i < n; ++i) {
      out.texts.push_back(lipsync::TimedVisemeJson(v[i], 0));
      if (listen_frames_) Mouth(v[i].viseme, out);
    }
    if (n == 0) return;
    const float done = v[n - 1].end;
    heard_.erase(std::remove_if(heard_.begin(), heard_.end(),
                                [done](const TimedPhoneme& p) { return p.end <= done + 1e-6f; }),
                 heard_.end());
  }

  // With frames: the face the sliders set with the viseme's shapes on top, as a frame.
  void Mouth(Viseme v, Out& out) {
    if (Show(state_, rig_->rig.visemes.binds[static_cast<size_t>(v)]).ok()) out.frame_wanted = true;
  }

  // The point a state (the mesh route's members) makes, read as POST /mesh reads it, with `mouth`
  // (a viseme's shapes, in the rig's own names) on top, becomes the one the frames show; an error
  // leaves the shown point as it was.
  Status Show(json body, std::span<const std::pair<uint32_t, float>> mouth = {}) {
    body["format"] = "f32";
    auto request = evaluator::ParseMeshRequest(body.dump());
    if (!request.ok()) return request.status();
    AttachVocabulary(ctx_, request.value());
    evaluator::ResolvedPoint point;
    if (Status s = ResolvePoint(rig_->rig, request.value(), point); !s.ok()) return s;
    if (!mouth.empty()) {
      for (const auto& [shape, weight] : mouth)
        point.weights[shape] = std::min(1.0f, point.weights[shape] + weight);
      evaluator::CheckPoint(rig_->rig, request->options.mode, point);
    }
    request_ = std::move(request.value());
    point_ = std::move(point);
    return Status::Ok();
  }

  // A status as an error event, at its first field's pointer, else at `where`.
  void Refuse(const Status& s, Out& out, const std::string& where = "") {
    out.texts.push_back(StatusEvent(s, where));
  }

  // The point's warnings (extrapolation, out of range ...) when they change: never silent.
  void SayWarnings(Out& out) {
    json list = json::array();
    for (const Warning& w : point_.report.warnings)
      list.push_back({{"code", w.code}, {"message", w.message}});
    if (list == last_warnings_) return;
    out.texts.push_back(json{
        {"event", "warnings"},
        {"id", last_id_},
        {"sum", point_.report.sum},
        {"warnings", list}}.dump());
    last_warnings_ = std::move(list);
  }

  ServerState& ctx_;
  std::shared_ptr<const evaluator::StoredRig> rig_;
  json limits_;
  json state_ = json::object();
  evaluator::MeshRequest request_;
  evaluator::ResolvedPoint point_;
  uint32_t frame_ = 0, last_id_ = 0;
  json last_warnings_ = json::array();
  std::stop_source stop_;
  net::LiveWake wake_;
  // While listening: a decoder and a thread of its own. Set and reset by turns under listener_mu_,
  // which Cancel takes from the hub's loop; turns read it without.
  std::mutex listener_mu_;
  std::unique_ptr<LiveListener> listener_;
  std::vector<TimedPhoneme> heard_;  // Phonemes heard and not yet given as visemes.
  bool listen_frames_ = false;
  LiveLandmarks landmarks_;
  enum class Frames : uint8_t { kF32, kWeights, kDelta };
  Frames frames_ = Frames::kF32;
  formats::DeltaFrames delta_{static_cast<float>(kDeltaError)};
  std::vector<float> positions_;  // A delta frame's, kept: no allocation a frame.
  // VMC out, and the UDP ports listened on (set by turns under listener_mu_, as the listener).
  LiveMocap mocap_;
  std::vector<json> faces_;     // What the inlets received, a turn's.
  bool mocap_weights_ = false;  // The state's weights are an inlet's (ARKit's names).
  LiveSpeaker speaker_;  // Last: its thread posts through the session until it is joined (End).
};

bool HasToken(const httplib::Request& req, const char* header, std::string_view token) {
  const std::string value = req.get_header_value(header);
  size_t at = 0;
  while (at <= value.size()) {
    size_t end = value.find(',', at);
    if (end == std::string::npos) end = value.size();
    std::string_view part(value.data() + at, end - at);
    while (!part.empty() && (part.front() == ' ' || part.front() == '\t')) part.remove_prefix(1);
    while (!part.empty() && (part.back() == ' ' || part.back() == '\t')) part.remove_suffix(1);
    if (net::EqualsIgnoreCase(part, token)) return true;
    at = end + 1;
  }
  return false;
}

// The session's place, given back unless the hub took the socket.
struct SessionPlace {
  SessionPlace(net::LiveHub& h, std::string i) : hub(h), ip(std::move(i)) {}
  SessionPlace(const SessionPlace&) = delete;
  SessionPlace& operator=(const SessionPlace&) = delete;
  net::LiveHub& hub;
  std::string ip;
  bool taken = false;
  ~SessionPlace() {
    if (!taken) hub.Unreserve(ip);
  }
};

}  // namespace

void GetLive(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  if (!stored) return;
  if (!HasToken(req, "Upgrade", "websocket") || !HasToken(req, "Connection", "upgrade")) {
    res.set_header("Upgrade", "websocket");
    return SendProblem(req, res, Problem::kUpgradeRequired,
                       "this route is a WebSocket (RFC 6455): ask with Upgrade: websocket and "
                       "Connection: Upgrade");
  }
  if (req.get_header_value("Sec-WebSocket-Version") != "13") {
    res.set_header("Sec-WebSocket-Version", "13");
    return SendProblem(req, res, Problem::kUpgradeRequired, "Sec-WebSocket-Version must be 13");
  }
  const std::string key = req.get_header_value("Sec-WebSocket-Key");
  if (!net::ws::ValidClientKey(key))
    return SendProblem(req, res, Problem::kBadRequest,
                       "Sec-WebSocket-Key must be the base64 of 16 bytes");
  // The cost, stated before the session: a frame's blend and encoding, at most 60 a second; the
  // session may spend twice that over its lifetime, and lasts at most --live-seconds.
  const Cost frame = MeshCost(stored->rig, formats::MeshFormat::kF32,
                              SIZE_MAX);  // Any shapes a message may weight.
  const double per_second = 60 * frame.seconds;
  if (!WithinBudget(ctx, req, res, {per_second, "/live", "60 frames a second x " + frame.formula}))
    return;
  const bool keyed = CarriesKey(ctx, req);
  net::SessionBounds bounds;
  bounds.lifetime =
      std::chrono::seconds(keyed ? ctx.options.keyed_live_seconds : ctx.options.live_seconds);
  bounds.cpu_seconds = 2 * per_second * static_cast<double>(bounds.lifetime.count()) + 1;
  if (!ctx.live.Reserve(req.remote_addr)) {
    res.set_header("Retry-After", "5");
    return SendProblem(req, res, Problem::kTooManySessions,
                       "the server holds as many live sessions as it takes, in all or from this "
                       "address (--max-live-sessions, --max-client-live-sessions)");
  }
  auto place = std::make_shared<SessionPlace>(ctx.live, req.remote_addr);
  const net::LiveLimits& l = ctx.live.limits();
  json limits = {
      {"fps", std::lround(1e6 / static_cast<double>(std::max<long>(1, l.frame_interval.count())))},
      {"max_message_bytes", l.max_message},
      {"max_messages_per_second", l.max_rate},
      {"seconds", bounds.lifetime.count()},
      {"cpu_seconds", bounds.cpu_seconds}};
  auto session = std::make_shared<std::unique_ptr<net::LiveHandler>>(
      std::make_unique<FaceSession>(ctx, stored, limits));
  const std::string head =
      "HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: "
      "Upgrade\r\nSec-WebSocket-Accept: " +
      net::ws::AcceptKey(key) + "\r\nFacespace-Cost: " + std::to_string(per_second) + "\r\n\r\n";
  const std::string ip = req.remote_addr;
  const bool upgraded = net::UpgradeConnection(
      req, head, [&ctx, place, session, ip, bounds](int fd, std::string buffered) {
        place->taken = true;
        ctx.live.Adopt(fd, ip, std::move(buffered), std::move(*session), bounds);
      });
  if (!upgraded)
    return SendProblem(req, res, Problem::kNotImplemented,
                       "this server's connections cannot be upgraded");
  res.status = 101;
}

}  // namespace facespace::http
