// The live hub (issue 53): the WebSocket sessions the front handed over after their handshake. One
// thread holds every session's socket (epoll): it reads frames (ws::ParseClientFrame), answers
// pings and closes, and queues whole messages; a few worker threads run each session's turns one at
// a time: its messages, then at most one frame per 1/60 s when its state changed and its last frame
// is out (newest state wins: a client that reads slowly gets fewer frames, never a backlog). Every
// session is bounded: its message size and rate, the bytes queued for it (a client that takes
// nothing for the stall time is dropped), its CPU (measured) and its lifetime; sessions are capped
// in all and per address.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_map>
#include <vector>

#include "facespace/engine/cpu.h"
#include "facespace/net/front.h"
#include "facespace/net/websocket.h"

namespace facespace::net {

struct LiveLimits {
  size_t max_sessions = 1024;             // Open at once, in all (--max-live-sessions).
  size_t max_per_client = 128;            // ... from one address (--max-client-live-sessions).
  size_t max_message = size_t{64} << 10;  // Bytes of one message (text or audio); more: 1009.
  double max_rate = 240;  // Messages a second, sustained (a burst of twice that); more: 1008.
  size_t max_queued = size_t{1} << 20;  // Bytes waiting for one client; more: 1008.
  std::chrono::milliseconds stall{
      10000};  // A client that takes nothing queued for this long: 1008.
  std::chrono::microseconds frame_interval{16667};  // At most 60 frames a second.
  int workers = 0;                                  // Threads running turns; 0: one per core.
};

// Sends one whole message of a session from any thread (speech made as it is spoken); false once
// the session is closing or gone.
using LivePost = std::function<bool(ws::Opcode opcode, std::string_view payload)>;
// Asks for a turn of the session from any thread (a helper thread has made something for it); a
// no-op once the session is gone.
using LiveWake = std::function<void()>;

// What a session does with its messages, called from one thread at a time.
class LiveHandler {
 public:
  virtual ~LiveHandler() = default;
  // The session's post and wake, before its first turn.
  virtual void Attach(LivePost, LiveWake) {}
  struct Out {
    std::vector<std::string> texts;  // Text messages to send (events), in order.
    bool frame_wanted = false;       // The state changed: a frame is due.
    bool close = false;              // Close the session with `code` and `reason`.
    ws::CloseCode code = ws::CloseCode::kNormal;
    std::string reason;
  };
  // The session's first messages (what it is, its limits), once open.
  virtual void Open(Out& out) = 0;
  virtual void OnText(std::string_view text, Out& out) = 0;
  virtual void OnBinary(std::string_view bytes, Out& out) = 0;
  // Each turn, after its messages: what the session's helper threads made since (a listener's
  // visemes).
  virtual void Poll(Out&) {}
  // CPU-seconds the session's helper threads spent since last asked (synthesis, decoding): the
  // session's budget counts them as its turns' own.
  virtual double TakeHelperCpu() { return 0; }
  // The payload of a binary message: a frame of the current state, into `message`; false to skip
  // it.
  virtual bool MakeFrame(std::string& message, Out& out) = 0;
  // Stop whatever runs for the session (the socket is closing): from any thread, without waiting.
  virtual void Cancel() {}
  // The session is gone: wait for what ran for it to end (once, on the hub's loop thread).
  virtual void End() {}
};

// A session's limits from its admission: how long it may stay and the CPU it may spend.
struct SessionBounds {
  std::chrono::seconds lifetime{3600};
  double cpu_seconds = 2.0;
};

class LiveHub {
 public:
  explicit LiveHub(LiveLimits limits);
  ~LiveHub();
  LiveHub(const LiveHub&) = delete;
  LiveHub& operator=(const LiveHub&) = delete;

  // A place for a session from `ip`, or false when the caps are reached. Released by the session's
  // end, or by Unreserve when the handshake does not happen.
  bool Reserve(const std::string& ip);
  void Unreserve(const std::string& ip);
  // A reserved session's socket (after its 101) and the bytes the client sent after its request.
  void Adopt(int fd, const std::string& ip, std::string buffered,
             std::unique_ptr<LiveHandler> handler, SessionBounds bounds);
  // Every session closed (1001 going away) and the threads joined.
  void Stop();

  const LiveLimits& limits() const { return limits_; }
  size_t open() const { return open_.load(); }
  struct Counts {
    std::atomic<size_t> opened{0}, frames{0}, messages{0}, dropped_slow{0}, closed_flood{0},
        closed_too_big{0}, refused{0};
  };
  Counts counts;

 private:
  struct Session;
  using Clock = std::chrono::steady_clock;

  void Loop();
  void Work();
  void Sweep(Clock::time_point now, bool stopping);
  void OnReadable(const std::shared_ptr<Session>& s);
  size_t ReadFrames(const std::shared_ptr<Session>& s);
  bool Spend(const std::shared_ptr<Session>& s);
  bool Assemble(const std::shared_ptr<Session>& s, const ws::Frame& f);
  void OnWritable(const std::shared_ptr<Session>& s);
  void Turn(const std::shared_ptr<Session>& s);
  void Schedule(const std::shared_ptr<Session>& s);
  void ScheduleAt(const std::shared_ptr<Session>& s, Clock::time_point at);
  // With s->mu held: queue bytes for the client; send what the socket takes now.
  void Queue(Session& s, std::string bytes, bool frame = false);
  void Flush(Session& s);
  // Sends the close frame and ends the session's reading (its socket goes after a short linger).
  void Close(const std::shared_ptr<Session>& s, ws::CloseCode code, std::string_view reason);
  void Apply(const std::shared_ptr<Session>& s, LiveHandler::Out& out);
  void Forget(const std::shared_ptr<Session>& s);
  void GiveBack(const std::string& ip);  // A place of Reserve's (mu_ held).
  void Arm(Session& s);
  void Wake();

  const LiveLimits limits_;
  int epoll_ = -1, wake_ = -1;
  std::atomic<bool> stopping_{false};
  std::atomic<size_t> open_{0};
  std::mutex mu_;  // Guards what follows.
  std::condition_variable cv_;
  std::unordered_map<uint64_t, std::shared_ptr<Session>> sessions_;
  std::map<std::string, size_t> per_client_;
  size_t reserved_ = 0;
  uint64_t next_id_ = 1;
  std::deque<std::shared_ptr<Session>> ready_;
  std::multimap<Clock::time_point, std::weak_ptr<Session>> timers_;
  std::vector<std::shared_ptr<Session>> adopted_;
  bool workers_stop_ = false;
  std::thread loop_;
  std::vector<std::thread> workers_;
};

}  // namespace facespace::net
