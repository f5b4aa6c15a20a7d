// The connection front (facespace/net/front.h): one epoll thread holds the connections while
// their requests arrive, a fixed pool of workers runs whole requests through cpp-httplib.
#include "facespace/net/front.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <malloc.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <mutex>
#include <thread>
#include <unordered_map>

#include "conn.h"
#include "facespace/engine/cpu.h"
#include "facespace/net/framing.h"
#include "in_flight.h"
#include "running.h"
#include "turns.h"
#include "workers.h"

namespace facespace::net {

namespace {

// A whole response for a request the front refuses itself, worded by the caller
// (FrontOptions::refusal: the API's problem+json), else plain text; then the connection closes.
std::string Refused(const FrontOptions& o, const RefusalInfo& info) {
  if (o.refusal) return o.refusal(info);
  return "HTTP/1.1 " + std::to_string(info.status) +
         " Refused\r\nContent-Type: text/plain\r\nConnection: close\r\n" +
         (info.retry_after ? "Retry-After: 1\r\n" : "") +
         "Content-Length: " + std::to_string(info.detail.size() + 1) + "\r\n\r\n" +
         std::string(info.detail) + "\n";
}

// cpp-httplib's accept loop hands every accepted socket to its task queue: this one gives it to
// the front at once, on the accept thread.
class AdoptQueue final : public httplib::TaskQueue {
 public:
  explicit AdoptQueue(std::function<void()> on_shutdown) : on_shutdown_(std::move(on_shutdown)) {}
  void enqueue(std::function<void()> fn) override { fn(); }
  void shutdown() override { on_shutdown_(); }

 private:
  std::function<void()> on_shutdown_;
};

}  // namespace

bool UpgradeConnection(const httplib::Request& req, std::string head, UpgradeTaker take) {
  Running* running = RunningOf(req);
  Conn* conn = running ? static_cast<Conn*>(running->connection) : nullptr;
  if (!conn || head.empty() || !take) return false;
  conn->upgrade_head = std::move(head);
  conn->upgrade_take = std::move(take);
  return true;
}

class FrontServer::Front {
 public:
  Front(FrontServer& server, FrontOptions options, FrontStats& counters)
      : stats(counters),
        server_(server),
        o_(std::move(options)),
        turns_(static_cast<size_t>(std::max(1, o_.workers)), o_.max_client_requests,
               o_.scarce_slots) {}
  ~Front() { Stop(); }

  FrontStats&
      stats;  // The caller's, so what reads them (the API's /metrics) can exist before the front.

  void Start() {
    std::lock_guard<std::mutex> lock(mu_);
    if (running_) return;
    running_ = true;
    stopping_ = false;
    epoll_ = epoll_create1(EPOLL_CLOEXEC);
    wake_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = wake_;
    epoll_ctl(epoll_, EPOLL_CTL_ADD, wake_, &ev);
    loop_ = std::thread([this] { Loop(); });
    for (int i = 0; i < std::max(1, o_.workers); ++i) workers_.emplace_back([this] { Work(); });
  }

  // From the accept thread.
  void Adopt(int fd) {
    Start();
    {
      std::lock_guard<std::mutex> lock(mu_);
      adopted_.push_back(fd);
    }
    Wake();
  }

  // Stops taking connections, closes the idle ones, lets requests in flight finish, then returns.
  void Stop() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (!running_) return;
      stopping_ = true;
    }
    watchdog_.StopAll();  // Work in flight stops at its next step; what waits its turn is stopped
                          // as it starts.
    Wake();
    loop_.join();
    StopWorkers(mu_, workers_stop_, work_cv_, workers_);
    ::close(epoll_);
    ::close(wake_);
    std::lock_guard<std::mutex> lock(mu_);
    running_ = false;
    workers_stop_ = false;
  }

 private:
  void Wake() {
    const uint64_t one = 1;
    [[maybe_unused]] ssize_t n = ::write(wake_, &one, sizeof one);
  }

  // ---- the front thread ----------------------------------------------------------------------

  void Loop() {
    std::vector<epoll_event> events(256);
    Clock::time_point next_sweep = Clock::now(), next_log = Clock::now() + std::chrono::seconds(10);
    size_t logged_refused = 0, logged_timed_out = 0, logged_framing = 0, logged_budget = 0;
    std::vector<int> recheck;
    while (true) {
      const int n = epoll_wait(epoll_, events.data(), static_cast<int>(events.size()),
                               recheck_.empty() ? 100 : 1);
      recheck.swap(recheck_);
      for (int i = 0; i < n; ++i) recheck.push_back(events[static_cast<size_t>(i)].data.fd);
      for (int fd : recheck) {
        if (fd == wake_) {
          uint64_t count;
          [[maybe_unused]] ssize_t r = ::read(wake_, &count, sizeof count);
          continue;
        }
        auto it = conns_.find(fd);
        if (it == conns_.end()) continue;
        // A worker armed the connection and has not yet said it is done with it: next time round.
        if (it->second->state == Conn::State::kBusy) {
          recheck_.push_back(fd);
          continue;
        }
        OnReadable(*it->second);
        Arm(fd);
      }
      recheck.clear();
      TakeAdoptedAndReturned();
      const Clock::time_point now = Clock::now();
      if (now >= next_sweep) {
        Sweep(now);
        next_sweep = now + std::chrono::milliseconds(100);
      }
      if (now >= next_log) {  // What the caps turned away, once in ten seconds at most.
        const size_t r = stats.refused_total, t = stats.timed_out, f = stats.bad_framing,
                     b = stats.over_budget;
        if (r != logged_refused || t != logged_timed_out || f != logged_framing ||
            b != logged_budget) {
          std::fprintf(
              stderr,
              "facespace: front: in the last 10 s %zu connections refused (caps), %zu requests "
              "timed out, %zu refused for their framing, %zu over the body budget; %zu open\n",
              r - logged_refused, t - logged_timed_out, f - logged_framing, b - logged_budget,
              stats.open.load());
          logged_refused = r, logged_timed_out = t, logged_framing = f, logged_budget = b;
        }
        next_log = now + std::chrono::seconds(10);
      }
      bool stop;
      {
        std::lock_guard<std::mutex> lock(mu_);
        stop = stopping_;
      }
      if (stop) {
        // Idle and half-read connections go now; busy ones when their worker gives them back.
        std::vector<Conn*> open;
        for (auto& [fd, c] : conns_) {
          if (c->state != Conn::State::kBusy) open.push_back(c.get());
        }
        for (Conn* c : open) Close(*c);
        if (conns_.empty()) break;
      }
    }
  }

  void TakeAdoptedAndReturned() {
    std::vector<int> adopted;
    std::vector<Conn*> returned;
    bool stopping;
    {
      std::lock_guard<std::mutex> lock(mu_);
      adopted.swap(adopted_);
      returned.swap(returned_);
      stopping = stopping_;
    }
    for (int fd : adopted) {
      if (stopping) {
        ::close(fd);
        continue;
      }
      Accept(fd);
    }
    for (Conn* c : returned) Returned(*c);
  }

  void Accept(int fd) {
    const int flags = fcntl(fd, F_GETFL, 0);
    fcntl(fd, F_SETFL, flags | O_NONBLOCK);
    const int yes = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
    auto c = std::make_unique<Conn>();
    c->fd = fd;
    Address(fd, true, c->ip, c->port);
    Address(fd, false, c->local_ip, c->local_port);
    size_t& from_client = per_client_[c->ip];
    const char* refused = nullptr;
    if (conns_.size() >= o_.max_connections)
      refused = "the server has as many connections open as it takes (--max-connections)";
    else if (from_client >= o_.max_per_client)
      refused =
          "this address has as many connections open as one client may (--max-client-connections)";
    if (refused) {
      ++stats.refused_total;
      if (from_client >= o_.max_per_client) ++stats.refused_client;
      if (from_client == 0) per_client_.erase(c->ip);
      SendNow(fd, Refused(o_, {Refusal::kTooManyConnections, 503, refused, "", true}));
      ::shutdown(fd, SHUT_RDWR);
      ::close(fd);
      return;
    }
    ++from_client;
    c->deadline = Clock::now() + std::chrono::seconds(o_.request_timeout);
    epoll_event ev{};
    ev.events = EPOLLIN | EPOLLRDHUP | EPOLLONESHOT;
    ev.data.fd = fd;
    if (epoll_ctl(epoll_, EPOLL_CTL_ADD, fd, &ev) != 0) {
      if (--from_client == 0) per_client_.erase(c->ip);
      ::close(fd);
      return;
    }
    conns_[fd] = std::move(c);
    stats.open = conns_.size();
  }

  // Every connection is registered one-shot: an event disarms it, so the thread that handles the
  // event owns the connection until it arms it again (the front here, or a worker when done).
  void Arm(int fd) {
    auto it = conns_.find(fd);
    if (it == conns_.end() || it->second->state == Conn::State::kBusy) return;
    epoll_event ev{};
    ev.events = EPOLLIN | EPOLLRDHUP | EPOLLONESHOT;
    ev.data.fd = fd;
    if (epoll_ctl(epoll_, EPOLL_CTL_MOD, fd, &ev) != 0) Close(*it->second);
  }

  void Close(Conn& c) {
    ::shutdown(c.fd, SHUT_RDWR);
    ::close(c.fd);
    Forget(c);
  }

  // The connection no longer the front's (closed, or handed off): out of epoll, its budget and its
  // address's count given back, and gone.
  void Forget(Conn& c) {
    epoll_ctl(epoll_, EPOLL_CTL_DEL, c.fd, nullptr);
    Release(c);
    auto pc = per_client_.find(c.ip);
    if (pc != per_client_.end() && --pc->second == 0) per_client_.erase(pc);
    conns_.erase(c.fd);  // Destroys c.
    stats.open = conns_.size();
  }

  // Answers a request the front refuses, then reads and drops what the client still sends for a
  // moment (closing with unread bytes would reset the connection and could lose the answer).
  void Refuse(Conn& c, Refusal why, int status, const std::string& detail,
              bool retry_after = false) {
    const std::string path = c.head.target.substr(0, c.head.target.find('?')).substr(0, 200);
    const std::string response = Refused(o_, {why, status, detail, path, retry_after});
    SendNow(c.fd, response);
    if (o_.log_requests) {
      // As the access log writes a request, with no duration: the request never reached a handler.
      const bool parsed = !c.head.method.empty();
      const std::string logged = parsed          ? path
                                 : status == 414 ? "(request line over 8,192 bytes)"
                                                 : "-";
      std::fprintf(stderr, "%s %s %d %zu -\n", parsed ? c.head.method.substr(0, 20).c_str() : "-",
                   logged.c_str(), status, response.size() - response.find("\r\n\r\n") - 4);
    }
    Linger(c);
  }
  void RefuseRaw(Conn& c, const std::string& response) {
    SendNow(c.fd, response);
    Linger(c);
  }
  void Linger(Conn& c) {
    ::shutdown(c.fd, SHUT_WR);
    Release(c);
    c.buf.clear();
    c.buf.shrink_to_fit();
    c.state = Conn::State::kLinger;
    c.deadline = Clock::now() + std::chrono::seconds(2);
  }

  bool Reserve(Conn& c, size_t bytes) {
    if (bytes <= c.reserved) return true;
    const size_t more = bytes - c.reserved;
    if (stats.body_bytes + more > o_.body_budget) return false;
    stats.body_bytes += more;
    c.reserved = bytes;
    return true;
  }
  void Release(Conn& c) {
    stats.body_bytes -= c.reserved;
    c.reserved = 0;
  }

  void OnReadable(Conn& c) {
    char chunk[65536];
    while (true) {
      const ssize_t n = ::recv(c.fd, chunk, sizeof chunk, 0);
      if (n > 0) {
        if (c.state == Conn::State::kLinger) continue;  // Dropped.
        c.buf.append(chunk, static_cast<size_t>(n));
        // Enough to find a head, or for the whole body: the rest stays in the socket until asked
        // for.
        if (c.state != Conn::State::kBody && c.buf.size() > (1u << 20)) break;
        if (c.state == Conn::State::kBody &&
            c.buf.size() >=
                c.head.end + (c.head.chunked ? o_.max_body + 4096 : c.head.content_length))
          break;
        continue;
      }
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
      if (n < 0 && errno == EINTR) continue;
      Close(c);  // The client closed (or reset) its side.
      return;
    }
    if (c.state == Conn::State::kLinger) return;
    Advance(c);
  }

  // Takes the connection's request as far as its bytes go; hands a whole one to a worker.
  void Advance(Conn& c) {
    if (c.buf.empty()) return;
    const Clock::time_point now = Clock::now();
    if (c.state == Conn::State::kIdle) {
      // A new connection's first request is due within the timeout from the accept; a kept-alive
      // one's from its first byte.
      c.state = Conn::State::kHead;
      c.head_scan = 0;
      c.head = RequestHead{};
      if (c.served > 0) c.deadline = now + std::chrono::seconds(o_.request_timeout);
    }
    FramingError error;
    if (c.state == Conn::State::kHead) {
      const Framing f = ParseHead(c.buf, c.head_scan, limits_, c.head, error);
      if (f == Framing::kNeedMore) return;
      if (f == Framing::kError) {
        ++stats.bad_framing;
        return Refuse(c, Refusal::kFraming, error.status, error.detail);
      }
      // Read from the head as it came (a chunked body is rewritten before its request is handed
      // on).
      c.keyed = o_.keyed && o_.keyed(HeaderValue(c, "Authorization"));
      if (c.head.has_body()) {
        if (o_.head_check) {
          if (auto refusal = o_.head_check(View(c)); refusal) return RefuseRaw(c, *refusal);
        }
        if (c.head.content_length > o_.max_body) {
          return Refuse(
              c, Refusal::kBodyTooLarge, 413,
              "the request body (Content-Length: " + std::to_string(c.head.content_length) +
                  ") is over the server's limit of " + std::to_string(o_.max_body) +
                  " bytes (--max-body)");
        }
        if (!Reserve(c, c.head.end + c.head.content_length)) {
          ++stats.over_budget;
          return Refuse(
              c, Refusal::kBusy, 503,
              "the server holds as many request bodies in memory as it may; retry shortly", true);
        }
        // A body of N MiB may take N more seconds. Its room is made once (no copies as it grows).
        c.deadline += std::chrono::seconds(c.head.content_length >> 20);
        c.buf.reserve(c.head.end + c.head.content_length);
        if (c.head.expect_continue && c.buf.size() == c.head.end) {
          SendNow(c.fd, "HTTP/1.1 100 Continue\r\n\r\n");
          c.sent_continue = true;
        }
      }
      c.state = Conn::State::kBody;
      c.chunked = ChunkedState{};
      c.chunked.pos = c.head.end;
    }
    if (c.head.chunked) {
      const Framing f = ParseChunked(c.buf, c.chunked, o_.max_body, error);
      if (f == Framing::kError) {
        ++stats.bad_framing;
        return Refuse(c, Refusal::kFraming, error.status, error.detail);
      }
      if (!Reserve(c, c.buf.size())) {
        ++stats.over_budget;
        return Refuse(c, Refusal::kBusy, 503,
                      "the server holds as many request bodies in memory as it may; retry shortly",
                      true);
      }
      if (f == Framing::kNeedMore) return;
      // Handed on with its body whole (Content-Length), followed by what came after it.
      std::string whole = Dechunked(std::string_view(c.buf).substr(0, c.chunked.pos), c.head);
      c.request_end = whole.size();
      c.buf = std::move(whole.append(c.buf, c.chunked.pos, std::string::npos));
    } else {
      if (c.buf.size() < c.head.end + c.head.content_length) return;
      c.request_end = c.head.end + c.head.content_length;
    }
    if (!c.head.has_body() && o_.probe) {
      if (std::optional<std::string> answer = o_.probe(View(c))) return AnswerHere(c, *answer);
    }
    Dispatch(c);
  }

  // A request the front answers itself (a probe): the answer written now (a few KB: what the socket
  // does not take at once gets 100 ms), then the connection waits for its next request, or closes.
  void AnswerHere(Conn& c, std::string_view response) {
    const bool close = EqualsIgnoreCase(HeaderValue(c, "Connection"), "close") ||
                       c.served + 1 >= o_.keep_alive_max;
    if (!SendWithin(c.fd, response, std::chrono::milliseconds(100))) return Close(c);
    if (close) return Linger(c);
    ReadyForNext(c);
    c.state = Conn::State::kIdle;
    if (!c.buf.empty()) recheck_.push_back(c.fd);  // A pipelined request: next time round.
  }

  RequestHeadView View(const Conn& c) const {
    RequestHeadView v;
    v.method = c.head.method;
    v.target = c.head.target;
    ForEachField(c, [&v](std::string_view field, std::string_view value) {
      v.headers.emplace_back(std::string(field), std::string(value));
      return false;
    });
    return v;
  }

  // A whole request to a worker, or to its address's line when the address may not start one more
  // now (turns.h: fair shares), so that one address, or a few, cannot hold every worker while
  // others wait.
  void Dispatch(Conn& c) {
    c.state = Conn::State::kBusy;  // Not armed: the worker arms it when the answer is out.
    {
      std::lock_guard<std::mutex> lock(mu_);
      c.gate =
          o_.scarce ? o_.scarce(c.head.method, c.head.target, HeaderValue(c, "Content-Type")) : -1;
      if (!turns_.Arrive(c.ip, &c, c.gate)) {
        ++stats.waited_turn;
        return;
      }
      work_.push_back(&c);
    }
    work_cv_.notify_one();
  }

  // Under mu_: the finished request's turn given back, and the waiting ones that may start now
  // started.
  void EndTurn(const std::string& ip, int gate) {
    std::vector<Conn*> start;
    turns_.End(ip, gate, start);
    for (Conn* c : start) work_.push_back(c);
    for (size_t i = 0; i < start.size(); ++i) work_cv_.notify_one();
  }

  // A served request's bytes and budget let go, the connection waiting for its next request (not
  // yet armed, and still busy for the front until its state is stored).
  void ReadyForNext(Conn& c) {
    c.buf.erase(0, c.request_end);
    Release(c);
    ++c.served;
    c.request_end = 0;
    c.sent_continue = false;
    c.deadline = Clock::now() + std::chrono::seconds(o_.keep_alive_timeout);
    if (c.buf.capacity() > (1u << 20)) c.buf.shrink_to_fit();  // A large body's room goes back.
  }

  void Returned(Conn& c) {
    if (c.upgrade_take && !c.close_after) return HandOff(c);
    if (c.close_after) return Close(c);
    ReadyForNext(c);
    c.state = Conn::State::kIdle;
    const int fd = c.fd;
    Advance(c);  // A pipelined request may be whole already.
    Arm(fd);
  }

  // An upgraded connection leaves the front: its socket and what the client sent after its request
  // go to their taker (the live hub), which owns and closes the socket from then on.
  void HandOff(Conn& c) {
    const int fd = c.fd;
    UpgradeTaker take = std::move(c.upgrade_take);
    std::string rest = c.buf.substr(std::min(c.request_end, c.buf.size()));
    Forget(c);
    take(fd, std::move(rest));
  }

  void Sweep(Clock::time_point now) {
    std::vector<Conn*> late;
    for (auto& [fd, c] : conns_) {
      if (c->state != Conn::State::kBusy && now >= c->deadline) late.push_back(c.get());
    }
    for (Conn* c : late) {
      if (c->state == Conn::State::kHead || c->state == Conn::State::kBody) {
        ++stats.timed_out;
        Refuse(*c, Refusal::kRequestTimeout, 408,
               "the request did not arrive whole within " + std::to_string(o_.request_timeout) +
                   " s (--read-timeout)");
        c->deadline =
            now + std::chrono::milliseconds(200);  // A short linger: the client was slow anyway.
      } else {
        Close(*c);  // Idle past the keep-alive time, or done lingering.
      }
    }
  }

  // ---- the workers ---------------------------------------------------------------------------

  void Work() {
    while (true) {
      Conn* c = nullptr;
      bool stopping;
      {
        std::unique_lock<std::mutex> lock(mu_);
        work_cv_.wait(lock, [this] { return !work_.empty() || workers_stop_; });
        if (work_.empty()) return;
        c = work_.front();
        work_.pop_front();
        stopping = stopping_;
      }
      Watchdog::Entry watch;
      watch.fd = c->fd;
      watch.deadline =
          Clock::now() + std::chrono::seconds(c->keyed ? o_.keyed_deadline : o_.request_deadline);
      Watchdog::MeterThisThread(watch, c->keyed ? o_.keyed_cpu_limit : o_.cpu_limit);
      watchdog_.Watch(watch);
      // What helper threads spend for the request is its own (facespace/engine/cpu.h).
      Running running{watch.source.get_token(), c, {}, &watch.helper_cpu};
      ++stats.in_flight;
      RequestStream stream(*c, std::string_view(c->buf.data(), c->request_end), c->sent_continue,
                           {running.stop, std::chrono::seconds(o_.write_timeout),
                            static_cast<double>(o_.min_send_rate)});
      const bool close = stopping || c->served + 1 >= o_.keep_alive_max;
      bool closed_by_client = false;
      bool ok = false;
      stream.ReplaceResponse(&c->upgrade_head);
      try {
        ok = server_.Process(stream, close, closed_by_client, running);
      } catch (...) {
        ok = false;
      }
      --stats.in_flight;
      watchdog_.Unwatch(watch);
      if (stream.too_slow()) ++stats.slow_readers;
      {
        std::lock_guard<std::mutex> lock(mu_);
        EndTurn(c->ip, c->gate);
      }
      c->close_after =
          !ok || close || closed_by_client || stream.closes() || watch.source.stop_requested();
      if (c->upgrade_take) {
        // Upgraded when its 101 went out whole; else the taker is dropped (its place given back)
        // and the connection closes.
        c->close_after = !stream.replaced() || stopping;
        if (c->close_after) c->upgrade_take = nullptr;
      }
      // A large body's parse leaves freed heap behind (a DOM of a million values): give it back.
      if (c->request_end > (size_t{1} << 20)) malloc_trim(0);
      if (!c->close_after && !c->upgrade_take && c->buf.size() == c->request_end) {
        // Kept alive with nothing more sent yet (the usual case): made ready for its next request
        // here and armed, without a round trip through the front. Armed first: the front waits
        // for the state below before it touches the connection.
        ReadyForNext(*c);
        epoll_event ev{};
        ev.events = EPOLLIN | EPOLLRDHUP | EPOLLONESHOT;
        ev.data.fd = c->fd;
        if (epoll_ctl(epoll_, EPOLL_CTL_MOD, c->fd, &ev) == 0) {
          c->state = Conn::State::kIdle;
          continue;
        }
        c->close_after = true;  // Cannot be armed: the front closes it.
      }
      {
        std::lock_guard<std::mutex> lock(mu_);
        returned_.push_back(c);
      }
      Wake();
    }
  }

  FrontServer& server_;
  FrontOptions o_;
  HeadLimits limits_;
  int epoll_ = -1, wake_ = -1;
  std::thread loop_;
  std::vector<std::thread> workers_;
  std::unordered_map<int, std::unique_ptr<Conn>> conns_;  // The front thread's.
  std::unordered_map<std::string, size_t> per_client_;    // The front thread's.
  std::vector<int> recheck_;  // The front thread's: events to look at again.

  std::mutex mu_;
  std::condition_variable work_cv_;
  bool running_ = false, stopping_ = false, workers_stop_ = false;
  std::vector<int> adopted_;
  std::vector<Conn*> returned_;
  std::deque<Conn*> work_;
  FairTurns<Conn*> turns_;  // Under mu_.
  Watchdog watchdog_{stats};
};

FrontServer::FrontServer(FrontOptions options, FrontStats& stats)
    : front_(std::make_unique<Front>(*this, std::move(options), stats)) {
  new_task_queue = [this] { return new AdoptQueue([this] { front_->Stop(); }); };
}

FrontServer::~FrontServer() { front_->Stop(); }

const FrontStats& FrontServer::Stats() const { return front_->stats; }

bool FrontServer::process_and_close_socket(socket_t sock) {
  front_->Adopt(sock);
  return true;
}

bool FrontServer::Process(httplib::Stream& stream, bool close_connection, bool& connection_closed,
                          Running& running) {
  // cpp-httplib calls this once the request's head is read, before its hooks and handler.
  const auto carry = [&running](httplib::Request& req) { req.progress = Carrier{&running}; };
  return process_request(stream, close_connection, connection_closed, carry);
}

}  // namespace facespace::net
