// The live socket and the apps VTubers stream with (issue 64), over UDP.
// - Out: {"vmc": {"port": 39539, "host": "127.0.0.1"}} sends each frame's face to a VMC receiver
//   (VSeeFace, Warudo, VNyan...): the 52 ARKit values (perfect sync) and VRM 0.x's presets (A I U E
//   O Blink Joy ...) as /VMC/Ext/Blend/Val, then one /VMC/Ext/Blend/Apply, in bundles that fit a
//   datagram. At most kMaxTargets receivers a session, one packet set a frame (the frame rate).
// - In: {"listen_vmc": {"port": P}} and {"listen_ifacialmocap": {"port": P}} open a UDP port whose
//   datagrams drive the face: VMC's blends at each Apply, an iFacialMocap line each datagram
//   (ARKit names, 0-100). Read on a thread of the inlet's own (its CPU the session's), at most
//   kMaxPacketsPerSecond datagrams (the rest dropped unread), the newest frame kept.
// Hosts other than this machine only as the operator allows (serve --vmc-hosts): sending to them,
// and, when any is allowed, listening on every interface but reading only them and loopback.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "facespace/engine/retarget.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace::http {

// Whether an IPv4 address (dotted, numeric) may be talked to: loopback, or one `allowed` names.
// InvalidField at `pointer` when it is not an address or not allowed.
Status CheckMocapHost(const std::string& host, std::span<const std::string> allowed,
                      const std::string& pointer);

class VmcSender {
 public:
  static constexpr size_t kMaxTargets = 4;
  static constexpr size_t kMaxDatagram = 1400;  // Bytes: a home network's MTU, unfragmented.

  explicit VmcSender(const Rig& rig);
  ~VmcSender();
  VmcSender(const VmcSender&) = delete;
  VmcSender& operator=(const VmcSender&) = delete;

  // A receiver at host:port (host checked by CheckMocapHost first); errors at /vmc/...
  Status Add(const std::string& host, int port);
  size_t targets() const { return fds_.size(); }
  // The face of `weights` (one a shape) to every receiver; datagrams that the network refuses are
  // counted, never waited for.
  void Send(std::span<const float> weights);
  size_t sent() const { return sent_; }
  size_t failed() const { return failed_; }

 private:
  void Flush(bool last);
  std::vector<std::span<const AxisTerm>> places_;
  std::vector<int> fds_;
  std::string bundle_, message_;  // Kept: no allocation a frame once they have grown.
  size_t sent_ = 0, failed_ = 0;
};

enum class MocapProtocol : uint8_t { kVmc, kIFacialMocap };
std::string_view MocapMember(MocapProtocol p);  // "listen_vmc", "listen_ifacialmocap"

// A name of VMC's blends as VRM 1.0's preset (Joy, joy or happy: "happy"), or empty.
std::string_view PresetOfVmcName(std::string_view name);

// The face an inlet last received: names as sent, values 0-1.
struct MocapFrame {
  bool fresh = false;  // `values` is a frame not given before.
  std::vector<std::pair<std::string, float>> values;
  size_t packets = 0, dropped = 0, malformed = 0;  // Since the inlet opened.
  std::string error;                               // A malformed datagram's, at most once a second.
};

class MocapInlet {
 public:
  static constexpr size_t kMaxPacket = 65536;
  static constexpr double kMaxPacketsPerSecond = 4000;  // One VMC blend a datagram, at 60 Hz.
  static constexpr double kMaxFramesPerSecond = 120;    // Faces given to the session.
  static constexpr size_t kMaxNames = 256;              // Blend names held before an Apply.
  static constexpr size_t kMaxInAll = 64;               // Inlets open on the server.

  // A UDP port bound (loopback, or every interface when `allowed` is not empty, reading only
  // loopback and the allowed hosts); `wake` asks for the session's turn. Errors at
  // /listen_.../port: in use, too many inlets.
  static Result<std::unique_ptr<MocapInlet>> Open(MocapProtocol protocol, int port,
                                                  std::span<const std::string> allowed,
                                                  std::function<void()> wake);
  ~MocapInlet();  // Stops the thread, closes the port.
  MocapInlet(const MocapInlet&) = delete;
  MocapInlet& operator=(const MocapInlet&) = delete;

  MocapProtocol protocol() const { return protocol_; }
  int port() const { return port_; }
  // The newest frame since the last call, or an error to say, into `out` (true), else false.
  bool Take(MocapFrame& out);
  // Datagrams read, dropped (from hosts not allowed, too large) and malformed since it opened.
  struct Counts {
    size_t packets = 0, dropped = 0, malformed = 0;
  };
  Counts counts();
  double TakeCpu();
  void Cancel();  // From any thread, without waiting.

 private:
  MocapInlet(MocapProtocol protocol, int fd, int port, std::vector<uint32_t> allowed,
             std::function<void()> wake);
  void Run(std::stop_token stop);
  void Read(std::string_view packet);
  void Publish();

  MocapProtocol protocol_;
  int fd_, port_;
  std::vector<uint32_t> allowed_;  // Network byte order.
  std::function<void()> wake_;
  int stop_fd_;                                         // An eventfd Cancel writes: the poll wakes.
  std::vector<std::pair<std::string, float>> pending_;  // The thread's: blends before an Apply.
  std::vector<std::pair<std::string, float>> line_;     // The thread's: a line being read.
  bool ready_ = false;  // The thread's: pending_ is a whole frame not yet given.
  std::mutex mu_;       // Guards what follows.
  MocapFrame frame_;
  bool fresh_ = false;
  std::chrono::steady_clock::time_point next_error_{};
  double cpu_ = 0;
  std::jthread thread_;  // Last: it runs on the members above.
};

// A live session's VMC receivers and UDP ports, from its messages (each alone in its message):
// events and errors into `texts`. Turns call it one at a time; Cancel may come from another thread.
class LiveMocap {
 public:
  static constexpr size_t kMaxInlets = 4;

  ~LiveMocap() { Close(); }
  // {"vmc": {"port", "host"}} adds a receiver, {"vmc": false} stops sending; true when a frame is
  // due (the face, to the new receiver).
  bool Vmc(const nlohmann::json& message, const Rig& rig, std::span<const std::string> hosts,
           std::vector<std::string>& texts);
  // {"listen_vmc" | "listen_ifacialmocap": {"port"}} opens a port, false closes that protocol's.
  void Listen(MocapProtocol protocol, const nlohmann::json& message,
              std::span<const std::string> hosts, const std::function<void()>& wake,
              std::vector<std::string>& texts);
  // Each port's newest face as weights in ARKit's names (into `faces`, one a port that has one):
  // its ARKit values and its VRM presets' places (vocabulary.cpp), the larger on each axis, so a
  // sender of both (perfect sync beside the presets made from it) does not count a blink twice.
  // Names of neither come once in a mocap event.
  void Poll(std::vector<nlohmann::json>& faces, std::vector<std::string>& texts);
  void Send(std::span<const float> weights) {
    if (vmc_) vmc_->Send(weights);
  }
  double TakeCpu();
  void Cancel();  // From any thread.
  void Close();   // The ports closed, their threads joined.

 private:
  void CloseInlets(std::optional<MocapProtocol> protocol);
  std::unique_ptr<VmcSender> vmc_;
  std::mutex mu_;  // Guards inlets_' membership (Cancel reads it from the hub's loop).
  std::vector<std::unique_ptr<MocapInlet>> inlets_;
  MocapFrame frame_;
  nlohmann::json last_unknown_ = nlohmann::json::array();
};

}  // namespace facespace::http
