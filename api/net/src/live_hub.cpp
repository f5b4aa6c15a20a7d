#include "facespace/net/live_hub.h"

#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>

#include "workers.h"

namespace facespace::net {

struct LiveHub::Session {
  uint64_t id = 0;
  int fd = -1;
  std::string ip;
  std::unique_ptr<LiveHandler> handler;
  Clock::time_point ends;
  double cpu_budget = 0;
  // The loop thread's: bytes read and not yet a whole frame, the message being assembled, the rate.
  std::string in;
  std::string message;
  ws::Opcode message_op = ws::Opcode::kText;
  bool in_message = false;
  Clock::time_point
      message_began;  // Its first fragment's arrival: the rest must follow within the stall time.
  std::atomic<bool> reading{true};  // False once closing: what comes is dropped.
  double tokens = 0;
  Clock::time_point tokens_at;
  // A turn's, one at a time.
  bool opened = false;
  double cpu = 0;
  std::atomic<bool> scheduled{false};
  // Guarded by mu.
  std::mutex mu;
  std::deque<std::pair<ws::Opcode, std::string>> inbox;
  size_t inbox_bytes = 0;
  struct Pending {
    std::string bytes;
    bool frame = false;
  };
  std::deque<Pending> out;
  size_t out_sent = 0;        // Of out.front().
  size_t queued = 0;          // Bytes in out not yet sent.
  bool frame_queued = false;  // A frame in `out`: the next waits for it to go (newest state wins).
  bool frame_wanted = false;
  // The frame rate as a virtual clock (GCRA): the 60 Hz grid's next slot. A frame may go up to half
  // a slot before it (after a late one), so a client sending at 60 Hz is answered at once, not a
  // slot later, and no more than 60 go in any second (plus one).
  Clock::time_point grid;
  bool want_write = false;
  Clock::time_point waiting_since;  // Bytes queued and none taken since.
  bool closing = false, shut = false;
  Clock::time_point linger_until;
  // Held by a turn (on a worker) and by End (on the loop): the handler is never in both at once.
  // Without it a client closing right after {"listen"} had End drop the listener a turn was
  // polling.
  std::mutex turn_mu;

  ~Session() {
    if (fd >= 0) ::close(fd);
  }
};

LiveHub::LiveHub(LiveLimits limits) : limits_(limits) {
  epoll_ = epoll_create1(EPOLL_CLOEXEC);
  wake_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.u64 = 0;  // Session ids start at 1.
  epoll_ctl(epoll_, EPOLL_CTL_ADD, wake_, &ev);
  loop_ = std::thread([this] { Loop(); });
  const int n = limits_.workers > 0
                    ? limits_.workers
                    : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  for (int i = 0; i < n; ++i) workers_.emplace_back([this] { Work(); });
}

LiveHub::~LiveHub() {
  Stop();
  ::close(epoll_);
  ::close(wake_);
}

void LiveHub::Stop() {
  if (stopping_.exchange(true)) return;
  Wake();
  loop_.join();
  StopWorkers(mu_, workers_stop_, cv_, workers_);
  std::lock_guard<std::mutex> lock(mu_);
  ready_.clear();
  timers_.clear();
  sessions_.clear();
}

bool LiveHub::Reserve(const std::string& ip) {
  std::lock_guard<std::mutex> lock(mu_);
  size_t& mine = per_client_[ip];
  if (stopping_ || reserved_ >= limits_.max_sessions || mine >= limits_.max_per_client) {
    if (mine == 0) per_client_.erase(ip);
    ++counts.refused;
    return false;
  }
  ++mine;
  ++reserved_;
  return true;
}

void LiveHub::Unreserve(const std::string& ip) {
  std::lock_guard<std::mutex> lock(mu_);
  GiveBack(ip);
}

void LiveHub::GiveBack(const std::string& ip) {
  --reserved_;
  auto it = per_client_.find(ip);
  if (it != per_client_.end() && --it->second == 0) per_client_.erase(it);
}

void LiveHub::Adopt(int fd, const std::string& ip, std::string buffered,
                    std::unique_ptr<LiveHandler> handler, SessionBounds bounds) {
  auto s = std::make_shared<Session>();
  s->fd = fd;
  s->ip = ip;
  s->handler = std::move(handler);
  s->ends = Clock::now() + bounds.lifetime;
  s->cpu_budget = bounds.cpu_seconds;
  s->in = std::move(buffered);
  s->tokens = 2 * limits_.max_rate;
  s->tokens_at = Clock::now();
  s->handler->Attach(
      [this, weak = std::weak_ptr<Session>(s)](ws::Opcode op, std::string_view payload) {
        const std::shared_ptr<Session> held = weak.lock();
        if (!held) return false;
        std::lock_guard<std::mutex> lock(held->mu);
        if (held->closing) return false;
        Queue(*held, ws::ServerFrame(op, payload));
        return true;
      },
      [this, weak = std::weak_ptr<Session>(s)] {
        if (const std::shared_ptr<Session> held = weak.lock()) Schedule(held);
      });
  {
    std::lock_guard<std::mutex> lock(mu_);
    s->id = next_id_++;
    adopted_.push_back(s);
  }
  ++counts.opened;
  Wake();
}

void LiveHub::Wake() {
  const uint64_t one = 1;
  [[maybe_unused]] ssize_t n = ::write(wake_, &one, sizeof one);
}

// ---- the loop thread -------------------------------------------------------------------------

void LiveHub::Loop() {
  epoll_event events[128];
  Clock::time_point next_sweep = Clock::now();
  while (true) {
    const int n = epoll_wait(epoll_, events, 128, 50);
    for (int i = 0; i < n; ++i) {
      const uint64_t id = events[i].data.u64;
      const uint32_t what = events[i].events;
      if (id == 0) {
        uint64_t count;
        [[maybe_unused]] ssize_t r = ::read(wake_, &count, sizeof count);
        continue;
      }
      std::shared_ptr<Session> s;
      {
        std::lock_guard<std::mutex> lock(mu_);
        auto it = sessions_.find(id);
        if (it != sessions_.end()) s = it->second;
      }
      if (!s) continue;
      if (what & EPOLLOUT) OnWritable(s);
      if (what & (EPOLLIN | EPOLLRDHUP | EPOLLHUP | EPOLLERR)) OnReadable(s);
    }
    std::vector<std::shared_ptr<Session>> adopted;
    {
      std::lock_guard<std::mutex> lock(mu_);
      adopted.swap(adopted_);
      for (auto& s : adopted) sessions_[s->id] = s;
    }
    for (auto& s : adopted) {
      ++open_;
      epoll_event ev{};
      ev.events = EPOLLIN | EPOLLRDHUP;
      ev.data.u64 = s->id;
      epoll_ctl(epoll_, EPOLL_CTL_ADD, s->fd, &ev);
      Schedule(s);  // Its first turn says what it is.
      if (!s->in.empty()) OnReadable(s);
    }
    const Clock::time_point now = Clock::now();
    const bool stopping = stopping_.load();
    if (now >= next_sweep || stopping) {
      next_sweep = now + std::chrono::milliseconds(100);
      Sweep(now, stopping);
    }
    if (stopping) {
      std::lock_guard<std::mutex> lock(mu_);
      if (sessions_.empty() && adopted_.empty()) return;
    }
  }
}

// Every 100 ms: sessions past their time or stalled are closed, closed ones past their linger
// forgotten.
void LiveHub::Sweep(Clock::time_point now, bool stopping) {
  std::vector<std::shared_ptr<Session>> all;
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (auto& [id, s] : sessions_) all.push_back(s);
  }
  for (auto& s : all) {
    bool closing, stalled;
    Clock::time_point linger;
    {
      std::lock_guard<std::mutex> lock(s->mu);
      closing = s->closing, linger = s->linger_until;
      stalled = s->queued > 0 && now - s->waiting_since >= limits_.stall;
    }
    if (closing) {
      if (now >= linger || stalled) Forget(s);
    } else if (stopping) {
      Close(s, ws::CloseCode::kGoingAway, "the server is stopping");
    } else if (s->in_message && now - s->message_began >= limits_.stall) {
      Close(s, ws::CloseCode::kPolicy,
            "a message begun and not finished within " +
                std::to_string(limits_.stall.count() / 1000) + " s");
    } else if (stalled) {
      ++counts.dropped_slow;
      Close(s, ws::CloseCode::kPolicy,
            "the client took nothing sent to it for " +
                std::to_string(limits_.stall.count() / 1000) + " s");
    } else if (now >= s->ends) {
      Close(s, ws::CloseCode::kGoingAway, "the session's time is up");
    }
  }
}

// A data frame: the session's rate first (every frame counts), then its message assembled and, when
// whole, queued for the session's turn. False when the session was closed for it.
// Every frame but a close spends one of the session's tokens (max_rate a second, a burst of twice
// that): pings and pongs too. False when the session was closed for a flood.
bool LiveHub::Spend(const std::shared_ptr<Session>& s) {
  const Clock::time_point now = Clock::now();
  s->tokens = std::min(
      2 * limits_.max_rate,
      s->tokens + limits_.max_rate * std::chrono::duration<double>(now - s->tokens_at).count());
  s->tokens_at = now;
  if (s->tokens < 1) {
    ++counts.closed_flood;
    Close(s, ws::CloseCode::kPolicy,
          "more than " + std::to_string(static_cast<int>(limits_.max_rate)) + " frames a second");
    return false;
  }
  s->tokens -= 1;
  return true;
}

bool LiveHub::Assemble(const std::shared_ptr<Session>& s, const ws::Frame& f) {
  if (f.opcode == ws::Opcode::kContinuation) {
    if (!s->in_message) {
      Close(s, ws::CloseCode::kProtocolError, "a continuation frame with no message begun");
      return false;
    }
  } else {
    if (s->in_message) {
      Close(s, ws::CloseCode::kProtocolError, "a new message before the last one ended");
      return false;
    }
    s->in_message = true;
    s->message_op = f.opcode;
    s->message.clear();
    s->message_began = Clock::now();
  }
  s->message.append(f.payload);
  if (!f.fin) return true;
  s->in_message = false;
  if (s->message_op == ws::Opcode::kText && !ws::ValidUtf8(s->message)) {
    Close(s, ws::CloseCode::kInvalidPayload, "a text message that is not UTF-8");
    return false;
  }
  ++counts.messages;
  bool over = false;
  {
    std::lock_guard<std::mutex> lock(s->mu);
    s->inbox_bytes += s->message.size();
    over = s->inbox_bytes > limits_.max_queued;
    s->inbox.emplace_back(s->message_op, std::move(s->message));
  }
  s->message = std::string();
  if (over) {
    Close(s, ws::CloseCode::kPolicy, "messages arrive faster than the session runs them");
    return false;
  }
  Schedule(s);
  return true;
}

// The whole frames in s->in: control frames answered, data frames assembled into messages for its
// turns. Returns the bytes they took.
size_t LiveHub::ReadFrames(const std::shared_ptr<Session>& s) {
  size_t at = 0;
  while (s->reading) {
    ws::Frame f;
    ws::FrameError error;
    const size_t room = limits_.max_message - (s->in_message ? s->message.size() : 0);
    const ws::Parsed p =
        ws::ParseClientFrame(std::span<char>(s->in.data() + at, s->in.size() - at), room, f, error);
    if (p == ws::Parsed::kNeedMore) break;
    if (p == ws::Parsed::kError) {
      if (error.code == ws::CloseCode::kTooBig) ++counts.closed_too_big;
      Close(s, error.code, error.reason);
      break;
    }
    at += f.size;
    if (f.opcode != ws::Opcode::kClose && !Spend(s)) break;
    if (f.opcode == ws::Opcode::kPing) {
      std::lock_guard<std::mutex> lock(s->mu);
      Queue(*s, ws::ServerFrame(ws::Opcode::kPong, f.payload));
      continue;
    }
    if (f.opcode == ws::Opcode::kPong) continue;
    if (f.opcode == ws::Opcode::kClose) {
      // The client's close: answered with its code (or none), then the socket ends.
      ws::CloseCode code = ws::CloseCode::kNormal;
      if (f.payload.size() >= 2)
        code = static_cast<ws::CloseCode>(static_cast<uint8_t>(f.payload[0]) << 8 |
                                          static_cast<uint8_t>(f.payload[1]));
      Close(s, code, "");
      break;
    }
    if (!Assemble(s, f)) break;
  }
  return at;
}

void LiveHub::OnReadable(const std::shared_ptr<Session>& s) {
  char chunk[65536];
  bool gone = false;
  while (true) {
    const ssize_t n = ::recv(s->fd, chunk, sizeof chunk, MSG_DONTWAIT);
    if (n > 0) {
      if (s->reading) s->in.append(chunk, static_cast<size_t>(n));
      if (s->in.size() >= limits_.max_message + 64)
        break;  // Enough for a frame: parse before reading more.
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
    gone = true;  // The client closed or reset.
    break;
  }
  const size_t at = ReadFrames(s);
  s->in.erase(0, std::min(at, s->in.size()));
  if (!s->reading) s->in.clear();
  if (gone) Forget(s);
}

void LiveHub::OnWritable(const std::shared_ptr<Session>& s) {
  bool again = false;
  {
    std::lock_guard<std::mutex> lock(s->mu);
    const bool had_frame = s->frame_queued;
    Flush(*s);
    again = had_frame && !s->frame_queued && s->frame_wanted;
  }
  if (again) Schedule(s);
}

// ---- queues and sends (s.mu held) -------------------------------------------------------------

void LiveHub::Queue(Session& s, std::string bytes, bool frame) {
  if (s.shut) return;
  if (s.queued == 0) s.waiting_since = Clock::now();
  s.queued += bytes.size();
  s.out.push_back({std::move(bytes), frame});
  s.frame_queued = s.frame_queued || frame;
  Flush(s);
}

void LiveHub::Flush(Session& s) {
  while (!s.out.empty()) {
    const std::string& b = s.out.front().bytes;
    const ssize_t n =
        ::send(s.fd, b.data() + s.out_sent, b.size() - s.out_sent, MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n > 0) {
      s.out_sent += static_cast<size_t>(n);
      s.queued -= static_cast<size_t>(n);
      s.waiting_since = Clock::now();
      if (s.out_sent == b.size()) {
        if (s.out.front().frame) s.frame_queued = false;
        s.out.pop_front();
        s.out_sent = 0;
      }
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      if (!s.want_write) {
        s.want_write = true;
        Arm(s);
      }
      return;
    }
    // The peer is gone: nothing more can be sent; the loop sees the hang-up.
    s.out.clear();
    s.queued = 0;
    s.out_sent = 0;
    s.frame_queued = false;
    s.shut = true;
    return;
  }
  if (s.want_write) {
    s.want_write = false;
    Arm(s);
  }
  if (s.closing && !s.shut) {
    ::shutdown(s.fd, SHUT_WR);  // The close frame is out: the client answers and closes.
    s.shut = true;
  }
}

void LiveHub::Arm(Session& s) {
  epoll_event ev{};
  ev.events = EPOLLIN | EPOLLRDHUP | (s.want_write ? EPOLLOUT : 0u);
  ev.data.u64 = s.id;
  epoll_ctl(epoll_, EPOLL_CTL_MOD, s.fd, &ev);
}

void LiveHub::Close(const std::shared_ptr<Session>& s, ws::CloseCode code,
                    std::string_view reason) {
  {
    std::lock_guard<std::mutex> lock(s->mu);
    if (s->closing) return;
    s->closing = true;
    s->linger_until = Clock::now() + std::chrono::seconds(2);
    s->inbox.clear();
    // What is not yet begun goes; a frame half sent is finished, so the close frame stays a frame.
    while (s->out.size() > (s->out_sent > 0 ? 1 : 0)) {
      s->queued -= s->out.back().bytes.size();
      s->out.pop_back();
    }
    s->frame_queued = false;
    s->frame_wanted = false;
    Queue(*s, ws::CloseFrame(code, reason));
  }
  s->reading = false;
  s->handler->Cancel();
}

void LiveHub::Forget(const std::shared_ptr<Session>& s) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (sessions_.erase(s->id) == 0) return;
    GiveBack(s->ip);
  }
  --open_;
  epoll_ctl(epoll_, EPOLL_CTL_DEL, s->fd, nullptr);
  {
    std::lock_guard<std::mutex> lock(s->mu);
    s->closing = true;
    s->shut = true;
    s->out.clear();
    s->queued = 0;
  }
  s->reading = false;
  ::shutdown(s->fd, SHUT_RDWR);
  s->handler->Cancel();
  std::lock_guard<std::mutex> turn(s->turn_mu);  // A turn running for it ends first.
  s->handler->End();
}

// ---- turns ------------------------------------------------------------------------------------

void LiveHub::Schedule(const std::shared_ptr<Session>& s) {
  if (s->scheduled.exchange(true)) return;
  {
    std::lock_guard<std::mutex> lock(mu_);
    ready_.push_back(s);
  }
  cv_.notify_one();
}

void LiveHub::ScheduleAt(const std::shared_ptr<Session>& s, Clock::time_point at) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    timers_.emplace(at, s);
  }
  cv_.notify_one();
}

void LiveHub::Work() {
  std::unique_lock<std::mutex> lock(mu_);
  while (true) {
    const Clock::time_point now = Clock::now();
    while (!timers_.empty() && timers_.begin()->first <= now) {
      if (auto s = timers_.begin()->second.lock(); s && !s->scheduled.exchange(true))
        ready_.push_back(std::move(s));
      timers_.erase(timers_.begin());
    }
    if (!ready_.empty()) {
      std::shared_ptr<Session> s = std::move(ready_.front());
      ready_.pop_front();
      lock.unlock();
      Turn(s);
      s.reset();
      lock.lock();
      continue;
    }
    if (workers_stop_) return;
    if (timers_.empty()) {
      cv_.wait(lock);
    } else {
      // A copy: wait_until reads its time point after the wait, when another worker may have erased
      // the timer.
      const Clock::time_point next = timers_.begin()->first;
      cv_.wait_until(lock, next);
    }
  }
}

void LiveHub::Apply(const std::shared_ptr<Session>& s, LiveHandler::Out& out) {
  {
    std::lock_guard<std::mutex> lock(s->mu);
    for (std::string& text : out.texts) Queue(*s, ws::ServerFrame(ws::Opcode::kText, text));
    if (out.frame_wanted) s->frame_wanted = true;
  }
  out.texts.clear();
  out.frame_wanted = false;
  if (out.close) Close(s, out.code, out.reason);
}

// A session's turn: its messages, then its frame if one is due and the last is out.
void LiveHub::Turn(const std::shared_ptr<Session>& s) {
  std::lock_guard<std::mutex> turn(s->turn_mu);
  std::deque<std::pair<ws::Opcode, std::string>> inbox;
  bool closing;
  {
    std::lock_guard<std::mutex> lock(s->mu);
    inbox.swap(s->inbox);
    s->inbox_bytes = 0;
    closing = s->closing;
    if (closing) inbox.clear();
  }
  const double cpu_start = ThreadCpuSeconds();
  LiveHandler::Out out;
  if (!s->opened && !closing) {
    s->opened = true;
    s->handler->Open(out);
    Apply(s, out);
  }
  for (auto& [op, message] : inbox) {
    if (op == ws::Opcode::kText)
      s->handler->OnText(message, out);
    else
      s->handler->OnBinary(message, out);
    Apply(s, out);
    if (!s->reading) break;
  }
  if (!closing && s->reading) {
    s->handler->Poll(out);
    Apply(s, out);
  }
  bool frame = false;
  Clock::time_point at{};
  {
    std::lock_guard<std::mutex> lock(s->mu);
    const Clock::time_point now = Clock::now();
    if (s->frame_wanted && !s->frame_queued && !s->closing) {
      const Clock::time_point earliest = s->grid - limits_.frame_interval / 2;
      if (now >= earliest) {
        frame = true;
        s->frame_wanted = false;
        s->grid = std::max(s->grid, now) + limits_.frame_interval;
      } else {
        at = earliest;
      }
    }
  }
  if (frame) {
    std::string message;
    if (s->handler->MakeFrame(message, out)) {
      std::lock_guard<std::mutex> lock(s->mu);
      if (!s->closing) Queue(*s, ws::ServerFrame(ws::Opcode::kBinary, message), true);
      ++counts.frames;
    }
    Apply(s, out);
  }
  s->cpu += ThreadCpuSeconds() - cpu_start + s->handler->TakeHelperCpu();
  if (s->cpu > s->cpu_budget) {
    Close(s, ws::CloseCode::kPolicy,
          "the session spent the CPU it may (" + std::to_string(s->cpu_budget) + " s)");
  }
  if (at != Clock::time_point{}) ScheduleAt(s, at);
  s->scheduled = false;
  bool again;
  {
    std::lock_guard<std::mutex> lock(s->mu);
    again = !s->inbox.empty() && !s->closing;
  }
  if (again) Schedule(s);
}

}  // namespace facespace::net
