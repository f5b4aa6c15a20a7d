#include "live_mocap.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>

#include "facespace/engine/cpu.h"
#include "facespace/engine/face.h"
#include "facespace/evaluator/members.h"
#include "facespace/net/mocap.h"
#include "live_say.h"

namespace facespace::http {

namespace {

// VRM 0.x's preset names as VMC sends them, in kExpressionPresets' order.
constexpr std::string_view kVmcPresets[] = {
    "Joy",     "Angry",  "Sorrow",   "Fun",      "Surprised", "A",
    "I",       "U",      "E",        "O",        "Blink",     "Blink_L",
    "Blink_R", "LookUp", "LookDown", "LookLeft", "LookRight", "Neutral"};
static_assert(std::size(kVmcPresets) == std::size(kExpressionPresets));

constexpr std::string_view kBlendVal = "/VMC/Ext/Blend/Val";
constexpr std::string_view kBlendApply = "/VMC/Ext/Blend/Apply";

std::atomic<size_t> inlets_open{0};

bool ParseIpv4(const std::string& host, in_addr& out) {
  return inet_pton(AF_INET, host.c_str(), &out) == 1;
}

bool IsLoopback(uint32_t network_order) { return (ntohl(network_order) >> 24) == 127; }

}  // namespace

Status CheckMocapHost(const std::string& host, std::span<const std::string> allowed,
                      const std::string& pointer) {
  in_addr a{};
  if (!ParseIpv4(host, a))
    return InvalidField(pointer, "host is an IPv4 address, as 127.0.0.1 (names are not looked up)");
  if (IsLoopback(a.s_addr) || std::find(allowed.begin(), allowed.end(), host) != allowed.end())
    return Status::Ok();
  return WithReason(
      InvalidField(pointer,
                   "this server talks VMC and iFacialMocap with this machine only; its "
                   "operator allows other hosts with serve --vmc-hosts"),
      "host-not-allowed");
}

// ---- out ----

VmcSender::VmcSender(const Rig& rig) : places_(ShapePlaces(rig)) {}

VmcSender::~VmcSender() {
  for (int fd : fds_) close(fd);
}

Status VmcSender::Add(const std::string& host, int port) {
  if (fds_.size() >= kMaxTargets)
    return WithReason(InvalidField("/vmc", "at most " + std::to_string(kMaxTargets) +
                                               " VMC receivers a session; {\"vmc\": false} "
                                               "stops sending"),
                      "too-many-targets");
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<uint16_t>(port));
  if (!ParseIpv4(host, to.sin_addr)) return InvalidField("/vmc/host", "not an IPv4 address");
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) return WithReason(ResourceExhausted("no socket for VMC"), "busy");
  if (connect(fd, reinterpret_cast<const sockaddr*>(&to), sizeof(to)) != 0) {
    const std::string why = std::strerror(errno);
    close(fd);
    return InvalidField("/vmc/host", "cannot send there: " + why);
  }
  fds_.push_back(fd);
  return Status::Ok();
}

void VmcSender::Flush(bool last) {
  if (last) {
    message_.clear();
    net::AppendOscMessage(message_, kBlendApply);
    net::AppendOscElement(bundle_, message_);
  }
  for (int fd : fds_) {
    if (send(fd, bundle_.data(), bundle_.size(), MSG_DONTWAIT | MSG_NOSIGNAL) ==
        static_cast<ssize_t>(bundle_.size()))
      ++sent_;
    else
      ++failed_;  // A receiver not there (ECONNREFUSED), a full buffer: the next frame follows.
  }
  bundle_.clear();
  net::BeginOscBundle(bundle_);
}

void VmcSender::Send(std::span<const float> weights) {
  if (fds_.empty()) return;
  std::array<float, kArkitAxes> arkit;
  std::array<float, std::size(kExpressionPresets)> presets;
  ArkitOfWeights(places_, weights, arkit);
  PresetsOfArkit(arkit, presets);
  bundle_.clear();
  net::BeginOscBundle(bundle_);
  const size_t apply = 4 + 24;  // The Apply message as an element.
  auto add = [&](std::string_view name, float value) {
    message_.clear();
    net::AppendOscMessage(message_, kBlendVal, name, value);
    if (bundle_.size() + 4 + message_.size() + apply > kMaxDatagram) Flush(false);
    net::AppendOscElement(bundle_, message_);
  };
  for (size_t k = 0; k < presets.size(); ++k) add(kVmcPresets[k], presets[k]);
  for (int k = 0; k < kArkitAxes; ++k) add(kArkitNames[k], arkit[k]);
  Flush(true);
}

// ---- in ----

std::string_view PresetOfVmcName(std::string_view name) {
  auto same = [](std::string_view a, std::string_view b) {
    return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
             return std::tolower(static_cast<unsigned char>(x)) ==
                    std::tolower(static_cast<unsigned char>(y));
           });
  };
  for (size_t k = 0; k < std::size(kVmcPresets); ++k) {
    if (same(name, kVmcPresets[k]) || same(name, kExpressionPresets[k]))
      return kExpressionPresets[k];
  }
  return {};
}

std::string_view MocapMember(MocapProtocol p) {
  return p == MocapProtocol::kVmc ? "listen_vmc" : "listen_ifacialmocap";
}

Result<std::unique_ptr<MocapInlet>> MocapInlet::Open(MocapProtocol protocol, int port,
                                                     std::span<const std::string> allowed,
                                                     std::function<void()> wake) {
  const std::string where = "/" + std::string(MocapMember(protocol)) + "/port";
  std::vector<uint32_t> hosts;
  for (const std::string& h : allowed) {
    in_addr a{};
    if (ParseIpv4(h, a)) hosts.push_back(a.s_addr);
  }
  if (inlets_open.fetch_add(1) >= kMaxInAll) {
    inlets_open.fetch_sub(1);
    return WithReason(InvalidField(where, "the server listens on as many UDP ports as it takes"),
                      "busy");
  }
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in at{};
  at.sin_family = AF_INET;
  at.sin_port = htons(static_cast<uint16_t>(port));
  at.sin_addr.s_addr = htonl(hosts.empty() ? INADDR_LOOPBACK : INADDR_ANY);
  socklen_t len = sizeof(at);
  if (fd < 0 || bind(fd, reinterpret_cast<const sockaddr*>(&at), sizeof(at)) != 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&at), &len) != 0) {
    const int e = errno;
    if (fd >= 0) close(fd);
    inlets_open.fetch_sub(1);
    if (e == EADDRINUSE)
      return WithReason(InvalidField(where, "port " + std::to_string(port) + " is in use"),
                        "port-in-use");
    return InvalidField(where, std::string("cannot listen there: ") + std::strerror(e));
  }
  return std::unique_ptr<MocapInlet>(
      new MocapInlet(protocol, fd, ntohs(at.sin_port), std::move(hosts), std::move(wake)));
}

MocapInlet::MocapInlet(MocapProtocol protocol, int fd, int port, std::vector<uint32_t> allowed,
                       std::function<void()> wake)
    : protocol_(protocol),
      fd_(fd),
      port_(port),
      allowed_(std::move(allowed)),
      wake_(std::move(wake)),
      stop_fd_(eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK)) {
  thread_ = std::jthread([this](std::stop_token stop) { Run(stop); });
}

MocapInlet::~MocapInlet() {
  Cancel();
  if (thread_.joinable()) thread_.join();
  close(fd_);
  if (stop_fd_ >= 0) close(stop_fd_);
  inlets_open.fetch_sub(1);
}

// The thread's poll wakes at once (the hub's loop joins it at the session's end: no wait there).
void MocapInlet::Cancel() {
  thread_.request_stop();
  const uint64_t one = 1;
  if (stop_fd_ >= 0) {
    const ssize_t n = write(stop_fd_, &one, sizeof(one));
    (void)n;  // It fails only when a wake is already pending.
  }
}

bool MocapInlet::Take(MocapFrame& out) {
  std::lock_guard<std::mutex> lock(mu_);
  const auto now = std::chrono::steady_clock::now();
  const bool say_error = !frame_.error.empty() && now >= next_error_;
  if (!fresh_ && !say_error) return false;
  out.fresh = fresh_;
  if (fresh_) out.values.swap(frame_.values);
  out.packets = frame_.packets;
  out.dropped = frame_.dropped;
  out.malformed = frame_.malformed;
  out.error.clear();
  if (say_error) {
    out.error.swap(frame_.error);
    next_error_ = now + std::chrono::seconds(1);  // Garbage at any rate: an event a second.
  }
  fresh_ = false;
  return true;
}

MocapInlet::Counts MocapInlet::counts() {
  std::lock_guard<std::mutex> lock(mu_);
  return {frame_.packets, frame_.dropped, frame_.malformed};
}

double MocapInlet::TakeCpu() {
  std::lock_guard<std::mutex> lock(mu_);
  return std::exchange(cpu_, 0.0);
}

void MocapInlet::Publish() {
  bool wake;
  {
    std::lock_guard<std::mutex> lock(mu_);
    frame_.values.assign(pending_.begin(), pending_.end());
    wake = !fresh_;
    fresh_ = true;
  }
  if (wake) wake_();  // Once until the session takes it: a flood asks for no more turns.
}

namespace {

// A blend's value by its name into `pending`, replacing the last one of that name.
void Set(std::vector<std::pair<std::string, float>>& pending, std::string_view name, float v,
         size_t cap) {
  if (name.empty() || name.size() > 64 || !std::isfinite(v)) return;
  for (auto& [n, value] : pending) {
    if (n == name) {
      value = v;
      return;
    }
  }
  if (pending.size() < cap) pending.emplace_back(std::string(name), v);
}

}  // namespace

// One datagram: VMC's blends wait for their Apply; an iFacialMocap line is a whole frame.
void MocapInlet::Read(std::string_view packet) {
  Status s = Status::Ok();
  if (protocol_ == MocapProtocol::kVmc) {
    bool apply = false;
    s = net::ReadOsc(packet, [&](const net::OscMessage& m) {
      if (m.address == kBlendVal && m.arguments.size() == 2 && m.arguments[0].tag == 's' &&
          m.arguments[1].tag == 'f')
        Set(pending_, m.arguments[0].s, std::clamp(m.arguments[1].f, 0.0f, 1.0f), kMaxNames);
      else if (m.address == kBlendApply)
        apply = true;
    });
    if (apply) ready_ = true;
  } else {
    line_.clear();
    s = net::ReadIFacialMocap(
        packet,
        [&](std::string_view name, float v) {
          Set(line_, name, std::clamp(v / 100.0f, 0.0f, 1.0f), kMaxNames);
        },
        [](std::string_view, std::span<const float>) {});  // The head's turn: not yet applied.
    if (s.ok()) {
      pending_.swap(line_);
      ready_ = true;
    }
  }
  if (!s.ok()) {
    bool wake = false;
    {
      std::lock_guard<std::mutex> lock(mu_);
      ++frame_.malformed;
      wake = frame_.error.empty() && !fresh_;
      if (frame_.error.empty()) frame_.error = s.message.substr(0, 200);
    }
    if (wake) wake_();
  }
}

// The thread: datagrams read at most kMaxPacketsPerSecond (the kernel drops what waits past its
// buffer), each from loopback or an allowed host, the CPU they cost counted; a whole frame given
// to the session at most kMaxFramesPerSecond (the newest, once the interval has passed).
void MocapInlet::Run(std::stop_token stop) {
  using Clock = std::chrono::steady_clock;
  const auto interval = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(1.0 / kMaxFramesPerSecond));
  std::vector<char> buffer(kMaxPacket);
  double credit = kMaxPacketsPerSecond;  // A second's burst.
  Clock::time_point at = Clock::now(), next_frame = at;
  while (!stop.stop_requested()) {
    const Clock::time_point now = Clock::now();
    credit =
        std::min(kMaxPacketsPerSecond,
                 credit + kMaxPacketsPerSecond * std::chrono::duration<double>(now - at).count());
    at = now;
    if (ready_ && now >= next_frame) {
      ready_ = false;
      next_frame = now + interval;
      Publish();
    }
    if (credit < 1.0) {
      std::this_thread::sleep_for(std::chrono::microseconds(250));
      continue;
    }
    pollfd p[2] = {{fd_, POLLIN, 0}, {stop_fd_, POLLIN, 0}};
    const int wait = ready_ ? 1 : 50;  // A stop wakes it (stop_fd_); 50 ms is a backstop.
    if (poll(p, stop_fd_ >= 0 ? 2 : 1, wait) <= 0 || !(p[0].revents & POLLIN)) continue;
    const double start = ThreadCpuSeconds();
    sockaddr_in from{};
    socklen_t len = sizeof(from);
    const ssize_t n = recvfrom(fd_, buffer.data(), buffer.size(), MSG_DONTWAIT | MSG_TRUNC,
                               reinterpret_cast<sockaddr*>(&from), &len);
    if (n < 0) continue;
    credit -= 1.0;
    const bool known =
        IsLoopback(from.sin_addr.s_addr) ||
        std::find(allowed_.begin(), allowed_.end(), from.sin_addr.s_addr) != allowed_.end();
    if (known && static_cast<size_t>(n) <= buffer.size())
      Read(std::string_view(buffer.data(), static_cast<size_t>(n)));
    std::lock_guard<std::mutex> lock(mu_);
    ++frame_.packets;
    if (!known || static_cast<size_t>(n) > buffer.size()) ++frame_.dropped;
    cpu_ += ThreadCpuSeconds() - start;
  }
}

// ---- the session's side ----

namespace {

using nlohmann::json;

std::string Alone(const std::string& member) {
  return ErrorEvent("invalid-message", member + " goes alone in its message", "/" + member);
}

}  // namespace

bool LiveMocap::Vmc(const json& m, const Rig& rig, std::span<const std::string> hosts,
                    std::vector<std::string>& texts) {
  const json& v = m["vmc"];
  if (m.size() != 1) return texts.push_back(Alone("vmc")), false;
  if (v == false) {
    vmc_.reset();
    texts.push_back(json{{"event", "vmc"}, {"state", "stopped"}}.dump());
    return false;
  }
  Status errors = Status::Ok();
  double port = 0;
  if (!v.is_object() || !v.contains("port"))
    errors.AddField("/vmc", "vmc is {\"port\": 39539, \"host\": \"127.0.0.1\"} or false");
  else if (evaluator::RefuseUnknown(v, "/vmc", evaluator::Body::kLiveVmc, errors);
           evaluator::ReadNumber(evaluator::Body::kLiveVmc, "port", v["port"], "/vmc/port", &port,
                                 errors) &&
           v.contains("host") && !v["host"].is_string())
    errors.AddField("/vmc/host", "host is a string, as 127.0.0.1");
  if (!errors.fields.empty()) return texts.push_back(StatusEvent(FieldErrors(errors))), false;
  const std::string host = v.value("host", std::string("127.0.0.1"));
  Status s = CheckMocapHost(host, hosts, "/vmc/host");
  if (s.ok()) {
    if (!vmc_) vmc_ = std::make_unique<VmcSender>(rig);
    s = vmc_->Add(host, static_cast<int>(port));
  }
  if (!s.ok()) return texts.push_back(StatusEvent(s)), false;
  texts.push_back(json{{"event", "vmc"},
                       {"state", "sending"},
                       {"host", host},
                       {"port", static_cast<int>(port)},
                       {"targets", vmc_->targets()}}
                      .dump());
  return true;
}

void LiveMocap::Listen(MocapProtocol protocol, const json& m, std::span<const std::string> hosts,
                       const std::function<void()>& wake, std::vector<std::string>& texts) {
  const std::string member(MocapMember(protocol)), where = "/" + member;
  const json& v = m[member];
  if (m.size() != 1) return texts.push_back(Alone(member));
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
    return texts.push_back(json{
        {"event", member},
        {"state", "end"},
        {"packets", n.packets},
        {"dropped", n.dropped},
        {"malformed",
         n.malformed}}.dump());
  }
  Status errors = Status::Ok();
  double port = 0;
  if (!v.is_object() || !v.contains("port"))
    errors.AddField(where, member + " is {\"port\": N} or false");
  else if (evaluator::RefuseUnknown(v, where, evaluator::Body::kLiveInlet, errors);
           evaluator::ReadNumber(evaluator::Body::kLiveInlet, "port", v["port"], where + "/port",
                                 &port, errors) &&
           port > 0 && port < 1024)
    errors.AddField(where + "/port", "a port from 1024 to 65535, or 0 for any free one");
  if (!errors.fields.empty()) return texts.push_back(StatusEvent(FieldErrors(errors)));
  if (inlets_.size() >= kMaxInlets)
    return texts.push_back(ErrorEvent(
        "too-many-ports", "a session listens on at most 4 ports; false closes them", where));
  auto opened = MocapInlet::Open(protocol, static_cast<int>(port), hosts, wake);
  if (!opened.ok()) return texts.push_back(StatusEvent(opened.status()));
  const int bound = opened.value()->port();
  {
    std::lock_guard<std::mutex> lock(mu_);
    inlets_.push_back(std::move(opened.value()));
  }
  texts.push_back(json{{"event", member}, {"state", "start"}, {"port", bound}}.dump());
}

void LiveMocap::Poll(std::vector<json>& faces, std::vector<std::string>& texts) {
  faces.clear();
  for (const auto& inlet : inlets_) {
    if (!inlet->Take(frame_)) continue;
    const std::string member(MocapMember(inlet->protocol()));
    if (!frame_.error.empty())
      texts.push_back(ErrorEvent("malformed-datagram",
                                 "port " + std::to_string(inlet->port()) + ": " + frame_.error,
                                 "/" + member));
    if (!frame_.fresh) continue;
    std::array<float, kArkitAxes> point{};
    json unknown = json::array();
    for (const auto& [name, value] : frame_.values) {
      auto terms = Place(Vocabulary::kArkit, name);
      if (terms.empty()) {
        const std::string_view preset = PresetOfVmcName(name);
        terms = Place(Vocabulary::kVrm, preset);
        if (preset.empty() && unknown.size() < 8) unknown.push_back(name);
      }
      for (const AxisTerm& t : terms) point[t.axis] = std::max(point[t.axis], value * t.amount);
    }
    if (unknown != last_unknown_) {
      texts.push_back(json{
          {"event", "mocap"}, {"source", member}, {"port", inlet->port()}, {"unknown", unknown}}
                          .dump());
      last_unknown_ = unknown;
    }
    json weights = json::object();
    for (int a = 0; a < kArkitAxes; ++a) {
      if (point[a] > 0.0f) weights[std::string(kArkitNames[a])] = point[a];
    }
    faces.push_back(std::move(weights));
  }
}

double LiveMocap::TakeCpu() {
  double cpu = 0;
  for (const auto& inlet : inlets_) cpu += inlet->TakeCpu();
  return cpu;
}

void LiveMocap::Cancel() {
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& inlet : inlets_) inlet->Cancel();
}

void LiveMocap::Close() { CloseInlets(std::nullopt); }

// The inlets of `protocol` (all without one) closed, their threads joined outside the lock.
void LiveMocap::CloseInlets(std::optional<MocapProtocol> protocol) {
  std::vector<std::unique_ptr<MocapInlet>> closing;
  std::lock_guard<std::mutex> lock(mu_);
  for (auto& inlet : inlets_) {
    if (!protocol || inlet->protocol() == *protocol) closing.push_back(std::move(inlet));
  }
  std::erase(inlets_, nullptr);
}

}  // namespace facespace::http
