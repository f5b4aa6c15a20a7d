// GET /v1/rigs/{id}/live, upgraded to a WebSocket (issue 53): one face per socket. Text messages
// set the state ({"weights"}, {"expressions"}, {"gaze"}, {"pose"}, {"controls"}, merged into the
// current point as the mesh route reads them); each change is answered by one binary message, a
// 16-byte header then the same bytes as GET /mesh?format=f32 for that point, at most 60 a second
// (the hub coalesces).
#include <array>
#include <nlohmann/json.hpp>
#include <optional>

#include "../http/cost.h"
#include "../http/problem.h"
#include "facespace/engine/face.h"
#include "facespace/engine/retarget.h"
#include "facespace/evaluator/members.h"
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
    if (m.contains("vmc")) return Vmc(m, out);
    if (m.contains("listen_vmc")) return ListenMocap(MocapProtocol::kVmc, m, out);
    if (m.contains("listen_ifacialmocap")) return ListenMocap(MocapProtocol::kIFacialMocap, m, out);
    if (m.contains("landmarks")) return Landmarks(m, out);
    if (m.contains("say") || m.contains("stop")) return Speech(m, out);
    json next = state_;
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
    for (const auto& inlet : inlets_) cpu += inlet->TakeCpu();
    return cpu;
  }

  bool MakeFrame(std::string& message, Out& out) override {
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
    message.reserve(kHeaderBytes + pieces[0].size() + pieces[1].size());
    message.append(kMeshTag, 4);
    PutU32(message, ++frame_);
    PutU32(message, last_id_);
    PutU32(message, 0);
    message.append(pieces[0]).append(pieces[1]);
    if (vmc_) vmc_->Send(point_.weights);  // The same face to the VTubers' apps.
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
    for (const auto& inlet : inlets_) inlet->Cancel();
  }
  void End() override {
    speaker_.Close();
    DropListener();  // Its thread joined (stopped by Cancel).
    CloseInlets(std::nullopt);
  }

 private:
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

  // {"vmc": {"port": 39539, "host": "127.0.0.1"}} adds a receiver of the frames' faces; {"vmc":
  // false} stops sending.
  void Vmc(const json& m, Out& out) {
    const json& v = m["vmc"];
    if (m.size() != 1)
      return out.texts.push_back(
          ErrorEvent("invalid-message", "vmc goes alone in its message", "/vmc"));
    if (v == false) {
      vmc_.reset();
      return out.texts.push_back(json{{"event", "vmc"}, {"state", "stopped"}}.dump());
    }
    if (!v.is_object() || !v.contains("port"))
      return out.texts.push_back(ErrorEvent(
          "invalid-message", "vmc is {\"port\": 39539, \"host\": \"127.0.0.1\"} or false", "/vmc"));
    Status errors = Status::Ok();
    evaluator::RefuseUnknown(v, "/vmc", evaluator::Body::kLiveVmc, errors);
    double port = 0;
    evaluator::ReadNumber(evaluator::Body::kLiveVmc, "port", v["port"], "/vmc/port", &port, errors);
    const json host = v.value("host", json("127.0.0.1"));
    if (!host.is_string()) errors.AddField("/vmc/host", "host is a string, as 127.0.0.1");
    if (!errors.fields.empty()) return Refuse(Fielded(std::move(errors)), out);
    const std::string h = host.get<std::string>();
    if (Status s = CheckMocapHost(h, ctx_.options.vmc_hosts, "/vmc/host"); !s.ok())
      return Refuse(s, out);
    if (!vmc_) vmc_ = std::make_unique<VmcSender>(rig_->rig);
    if (Status s = vmc_->Add(h, static_cast<int>(port)); !s.ok()) return Refuse(s, out);
    out.texts.push_back(json{
        {"event", "vmc"},
        {"state", "sending"},
        {"host", h},
        {"port", static_cast<int>(port)},
        {"targets",
         vmc_->targets()}}.dump());
    out.frame_wanted = true;  // The face as it is, to the new receiver.
  }

  // {"listen_vmc": {"port": P}} or {"listen_ifacialmocap": ...} opens a UDP port whose datagrams
  // drive the face; false closes this protocol's ports.
  void ListenMocap(MocapProtocol protocol, const json& m, Out& out) {
    const std::string member(MocapMember(protocol)), where = "/" + member;
    const json& v = m[member];
    if (m.size() != 1)
      return out.texts.push_back(
          ErrorEvent("invalid-message", member + " goes alone in its message", where));
    if (v == false) {
      MocapInlet::Counts n;
      for (const auto& inlet : inlets_) {
        if (inlet->protocol() != protocol) continue;
        const MocapInlet::Counts c = inlet->counts();
        n.packets += c.packets;
        n.dropped += c.dropped;
        n.malformed += c.malformed;
      }
      CloseInlets(protocol);
      return out.texts.push_back(json{
          {"event", member},
          {"state", "end"},
          {"packets", n.packets},
          {"dropped", n.dropped},
          {"malformed", n.malformed}}.dump());
    }
    if (!v.is_object() || !v.contains("port"))
      return out.texts.push_back(
          ErrorEvent("invalid-message", member + " is {\"port\": N} or false", where));
    Status errors = Status::Ok();
    evaluator::RefuseUnknown(v, where, evaluator::Body::kLiveInlet, errors);
    double port = 0;
    if (evaluator::ReadNumber(evaluator::Body::kLiveInlet, "port", v["port"], where + "/port",
                              &port, errors) &&
        port > 0 && port < 1024)
      errors.AddField(where + "/port", "a port from 1024 to 65535, or 0 for any free one");
    if (!errors.fields.empty()) return Refuse(Fielded(std::move(errors)), out);
    if (inlets_.size() >= kMaxInlets)
      return out.texts.push_back(ErrorEvent(
          "too-many-ports", "a session listens on at most 4 ports; false closes them", where));
    auto opened = MocapInlet::Open(protocol, static_cast<int>(port), ctx_.options.vmc_hosts, wake_);
    if (!opened.ok()) return Refuse(opened.status(), out);
    const int bound = opened.value()->port();
    {
      std::lock_guard<std::mutex> lock(listener_mu_);
      inlets_.push_back(std::move(opened.value()));
    }
    out.texts.push_back(json{{"event", member}, {"state", "start"}, {"port", bound}}.dump());
  }

  // The inlets of `protocol` (all without one) closed, their threads joined outside the lock.
  void CloseInlets(std::optional<MocapProtocol> protocol) {
    std::vector<std::unique_ptr<MocapInlet>> closing;
    std::lock_guard<std::mutex> lock(listener_mu_);
    for (auto& inlet : inlets_) {
      if (!protocol || inlet->protocol() == *protocol) closing.push_back(std::move(inlet));
    }
    std::erase(inlets_, nullptr);
  }

  // Each inlet's newest face as the face's weights in ARKit's names: its ARKit values and its VRM
  // presets' places (vocabulary.cpp's tables), the larger on each axis, so a sender of both
  // (perfect sync beside the presets made from it) does not count a blink twice.
  void PollMocap(Out& out) {
    for (const auto& inlet : inlets_) {
      if (!inlet->Take(mocap_)) continue;
      const std::string where = "/" + std::string(MocapMember(inlet->protocol()));
      if (!mocap_.error.empty())
        out.texts.push_back(
            ErrorEvent("malformed-datagram",
                       "port " + std::to_string(inlet->port()) + ": " + mocap_.error, where));
      if (!mocap_.fresh) continue;
      std::array<float, kArkitAxes> point{};
      json unknown = json::array();
      for (const auto& [name, value] : mocap_.values) {
        auto terms = Place(Vocabulary::kArkit, name);
        if (terms.empty()) terms = Place(Vocabulary::kVrm, PresetOfVmcName(name));
        if (terms.empty() && unknown.size() < 8 && PresetOfVmcName(name).empty())
          unknown.push_back(name);
        for (const AxisTerm& t : terms) point[t.axis] = std::max(point[t.axis], value * t.amount);
      }
      if (unknown != last_unknown_) {
        out.texts.push_back(json{
            {"event", "mocap"},
            {"source", where.substr(1)},
            {"port", inlet->port()},
            {"unknown",
             unknown}}.dump());
        last_unknown_ = unknown;
      }
      json next = state_, weights = json::object();
      for (int a = 0; a < kArkitAxes; ++a) {
        if (point[a] > 0.0f) weights[std::string(kArkitNames[a])] = point[a];
      }
      next["vocabulary"] = "arkit";
      next["weights"] = std::move(weights);
      if (Status s = Show(next); !s.ok()) {
        Refuse(s, out, where);
        continue;
      }
      state_ = std::move(next);
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
      out.texts.push_back(VisemeEvent(v[i]));
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

  // The fields a member table's reader listed as one status, worded by the first.
  static Status Fielded(Status s) {
    s.code = StatusCode::kInvalidArgument;
    s.message = s.fields[0].message;
    return s;
  }

  // A status as an error event, at its first field's pointer, else at `where`.
  void Refuse(const Status& s, Out& out, const std::string& where = "") {
    out.texts.push_back(ErrorEvent(s.reason.empty() ? "invalid-message" : s.reason, s.message,
                                   s.fields.empty() ? where : s.fields[0].pointer));
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
  // VMC out, and the UDP ports listened on (set by turns under listener_mu_, as the listener).
  static constexpr size_t kMaxInlets = 4;
  std::unique_ptr<VmcSender> vmc_;
  std::vector<std::unique_ptr<MocapInlet>> inlets_;
  MocapFrame mocap_;
  json last_unknown_ = json::array();
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
struct Place {
  Place(net::LiveHub& h, std::string i) : hub(h), ip(std::move(i)) {}
  Place(const Place&) = delete;
  Place& operator=(const Place&) = delete;
  net::LiveHub& hub;
  std::string ip;
  bool taken = false;
  ~Place() {
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
  auto place = std::make_shared<Place>(ctx.live, req.remote_addr);
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
