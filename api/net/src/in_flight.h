// A request while it runs on a worker (issue 48): how its answer is written (a stall time and a
// lowest rate; nothing waited for once it is stopped) and the watchdog that fires its stop token
// when its client hangs up, at its deadline, when its worker has spent its CPU, or when the server
// stops. The connection front's (front.cpp); private to api/.
#pragma once

#include <httplib.h>
#include <poll.h>
#include <pthread.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <ctime>
#include <mutex>
#include <stop_token>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_map>

#include "facespace/engine/cpu.h"
#include "facespace/net/framing.h"
#include "facespace/net/front.h"

namespace facespace::net {

using Clock = std::chrono::steady_clock;

// The socket a request came on, as cpp-httplib asks about it.
struct Peer {
  int fd = -1;
  std::string ip, local_ip;
  int port = 0, local_port = 0;
};

// How a response is written: its stop token, the longest wait without progress, and the lowest
// rate.
struct WriteBounds {
  std::stop_token stop;
  std::chrono::milliseconds
      stall;            // No byte taken for this long: the client is gone or not reading.
  double min_rate = 0;  // Bytes a second, over the time spent waiting, past `stall`'s grace.
};

// One buffered request for cpp-httplib: reads come from the bytes the front collected, writes go
// to the socket. A write waits for room in slices of 100 ms and gives up when the request is
// stopped (client gone, deadline, CPU, SIGTERM), when the client takes nothing for the stall time,
// or when the time spent waiting on it passes the grace plus what the bytes sent allow at the
// lowest rate: so a client that reads slowly, or never, holds a worker for seconds, not for ever.
class RequestStream final : public httplib::Stream {
 public:
  RequestStream(const Peer& peer, std::string_view request, bool sent_continue, WriteBounds bounds)
      : c_(peer), request_(request), b_(std::move(bounds)), drop_continue_(sent_continue) {}
  // A response head that replaces the one cpp-httplib writes (an upgrade's 101), when not empty by
  // then: it goes out instead, and the rest of cpp-httplib's response is dropped.
  void ReplaceResponse(const std::string* head) { replace_ = head; }
  bool replaced() const { return replaced_ && !failed_; }

  bool is_readable() const override { return pos_ < request_.size(); }
  bool is_writable() const override { return const_cast<RequestStream*>(this)->WaitWritable(); }
  ssize_t read(char* ptr, size_t size) override {
    const size_t n = std::min(size, request_.size() - pos_);
    std::copy_n(request_.data() + pos_, n, ptr);
    pos_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char* ptr, size_t size) override {
    const std::string_view bytes(ptr, size);
    if (drop_continue_) {
      drop_continue_ = false;
      if (bytes == "HTTP/1.1 100 Continue\r\n\r\n")
        return static_cast<ssize_t>(size);  // The front sent it already.
    }
    if (replaced_) return failed_ ? -1 : static_cast<ssize_t>(size);
    if (!head_seen_ && replace_ && !replace_->empty()) {
      head_seen_ = replaced_ = true;
      return SendAll(replace_->data(), replace_->size()) ? static_cast<ssize_t>(size) : -1;
    }
    if (!head_seen_) {  // The response's head: does it close the connection?
      head_seen_ = true;
      const size_t end = bytes.find("\r\n\r\n");
      const std::string_view head = bytes.substr(0, end);
      for (size_t at = head.find("\r\n"); at != std::string_view::npos;
           at = head.find("\r\n", at + 2)) {
        const std::string_view line = head.substr(at + 2, head.find("\r\n", at + 2) - (at + 2));
        if (EqualsIgnoreCase(line, "Connection: close")) closes_ = true;
      }
    }
    return SendAll(ptr, size) ? static_cast<ssize_t>(size) : -1;
  }
  // A stopped request's answer (a 503 problem, the end of a stream) goes out as far as the socket
  // takes it at once; it never waits.
  bool SendAll(const char* ptr, size_t size) {
    size_t done = 0;
    while (done < size) {
      const ssize_t n = ::send(c_.fd, ptr + done, size - done, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) {
        done += static_cast<size_t>(n);
        sent_ += static_cast<size_t>(n);
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK) && WaitWritable()) continue;
      break;
    }
    if (done == size) return true;
    failed_ = true;
    return false;
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = c_.ip;
    port = c_.port;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = c_.local_ip;
    port = c_.local_port;
  }
  socket_t socket() const override { return c_.fd; }

  bool closes() const { return closes_ || failed_; }
  bool too_slow() const { return too_slow_; }

 private:
  // Room to write, or false: stopped, stalled, or below the lowest rate.
  bool WaitWritable() {
    const Clock::time_point start = Clock::now();
    while (!b_.stop.stop_requested()) {
      pollfd p{c_.fd, POLLOUT, 0};
      const int r = ::poll(&p, 1, 100);
      const Clock::time_point now = Clock::now();
      if (r > 0) {
        waited_ += now - start;
        return !(p.revents & (POLLERR | POLLHUP)) && !BelowRate();
      }
      if (r < 0 && errno != EINTR) return false;
      if (now - start >= b_.stall ||
          (waited_ + (now - start) > b_.stall && BelowRate(now - start))) {
        too_slow_ = true;
        return false;
      }
    }
    return false;
  }
  // Whether the time spent waiting on the client (with `more`) is past the grace and the rate.
  bool BelowRate(Clock::duration more = {}) {
    const double waited = std::chrono::duration<double>(waited_ + more).count();
    const double allowed = std::chrono::duration<double>(b_.stall).count() +
                           (b_.min_rate > 0 ? static_cast<double>(sent_) / b_.min_rate : 1e300);
    if (waited <= allowed) return false;
    too_slow_ = true;
    return true;
  }

  const Peer& c_;
  std::string_view request_;
  size_t pos_ = 0;
  WriteBounds b_;
  bool drop_continue_;
  const std::string* replace_ = nullptr;
  bool head_seen_ = false, closes_ = false, failed_ = false, too_slow_ = false, replaced_ = false;
  size_t sent_ = 0;
  Clock::duration waited_{};
};

// Writes all of `bytes` to a non-blocking socket, waiting at most `wait` in all for room; false
// when the socket failed or the time ran out (a small answer the front writes itself: a probe's).
inline bool SendWithin(int fd, std::string_view bytes, std::chrono::milliseconds wait) {
  const Clock::time_point give_up = Clock::now() + wait;
  while (!bytes.empty()) {
    const ssize_t n = ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      bytes.remove_prefix(static_cast<size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(give_up - Clock::now()).count();
    pollfd p{fd, POLLOUT, 0};
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK) && left > 0 &&
        ::poll(&p, 1, static_cast<int>(left)) > 0)
      continue;
    return false;
  }
  return true;
}

// The requests in flight, each with its stop source: a thread fires one when its client hangs up
// (the socket's EPOLLRDHUP), at its deadline (looked at every 100 ms), and all of them when the
// server stops. Entries are known by a serial number, so an event of a finished request stops none.
class Watchdog {
 public:
  explicit Watchdog(FrontStats& stats) : stats_(stats) {
    epoll_ = epoll_create1(EPOLL_CLOEXEC);
    thread_ = std::jthread([this](std::stop_token stop) { Loop(stop); });
  }
  ~Watchdog() {
    thread_.request_stop();
    thread_.join();
    ::close(epoll_);
  }

  struct Entry {
    std::stop_source source;
    Clock::time_point deadline;
    int fd = -1;
    uint64_t serial = 0;
    // The worker's CPU clock and what it read at the start; a limit of 0: none.
    clockid_t cpu_clock{};
    double cpu_start = 0, cpu_limit = 0;
    HelperCpu helper_cpu;  // CPU other threads spent for it (Running::helper_cpu).
    double cpu() const { return Seconds(cpu_clock) - cpu_start + helper_cpu.Seconds(); }
  };
  // The calling thread's CPU clock into `e`, for a limit of `limit` CPU-seconds from now.
  static void MeterThisThread(Entry& e, double limit) {
    if (limit <= 0 || pthread_getcpuclockid(pthread_self(), &e.cpu_clock) != 0) return;
    e.cpu_start = Seconds(e.cpu_clock);
    e.cpu_limit = limit;
  }
  void Watch(Entry& e) {
    std::lock_guard<std::mutex> lock(mu_);
    e.serial = ++serial_;
    entries_[e.serial] = &e;
    if (stopping_) e.source.request_stop();
    epoll_event ev{};
    ev.events = EPOLLRDHUP;
    ev.data.u64 = e.serial;
    epoll_ctl(epoll_, EPOLL_CTL_ADD, e.fd, &ev);
  }
  void Unwatch(Entry& e) {
    std::lock_guard<std::mutex> lock(mu_);
    epoll_ctl(epoll_, EPOLL_CTL_DEL, e.fd, nullptr);
    entries_.erase(e.serial);
  }
  // Every request in flight is stopped, and every later one as it starts.
  void StopAll() {
    std::lock_guard<std::mutex> lock(mu_);
    stopping_ = true;
    for (auto& [serial, e] : entries_) e->source.request_stop();
  }

 private:
  void Loop(const std::stop_token& stop) {
    epoll_event events[64];
    while (!stop.stop_requested()) {
      const int n = epoll_wait(epoll_, events, 64, 100);
      std::lock_guard<std::mutex> lock(mu_);
      for (int i = 0; i < n; ++i) {
        const uint64_t serial =
            events[i].data.u64;  // A copy: epoll_event is packed, its u64 misaligned.
        auto it = entries_.find(serial);
        if (it == entries_.end() || it->second->source.stop_requested()) continue;
        it->second->source.request_stop();
        ++stats_.client_gone;
        // Disarmed: a hung-up socket would report again at every wait.
        epoll_event ev{};
        epoll_ctl(epoll_, EPOLL_CTL_MOD, it->second->fd, &ev);
      }
      const Clock::time_point now = Clock::now();
      for (auto& [serial, e] : entries_) {
        if (e->source.stop_requested()) continue;
        if (now >= e->deadline) {
          e->source.request_stop();
          ++stats_.past_deadline;
        } else if (e->cpu_limit > 0 && e->cpu() > e->cpu_limit) {
          e->source.request_stop();
          ++stats_.over_cpu;
        }
      }
    }
  }

  static double Seconds(clockid_t clock) {
    timespec t{};
    clock_gettime(clock, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
  }

  FrontStats& stats_;
  int epoll_ = -1;
  std::mutex mu_;
  uint64_t serial_ = 0;
  bool stopping_ = false;
  std::unordered_map<uint64_t, Entry*> entries_;
  std::jthread thread_;
};

}  // namespace facespace::net
