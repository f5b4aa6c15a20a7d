// The connection front's bounds on a running request (issue 48), with handlers of the test's own
// that spin until their stop token fires: the CPU meter, the deadline, a client that hangs up, and
// one address's turns.
#include "facespace/net/front.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "loopback.h"

namespace facespace::net {
namespace front_test {  // Named: the target is a unity build, its files share one unit.

using Clock = std::chrono::steady_clock;

class Front {
 public:
  explicit Front(net::FrontOptions o) : server_(std::move(o), stats_) {
    // Spins (burning CPU) until its stop token fires, then says how long it ran.
    server_.Post("/spin", [this](const httplib::Request& req, httplib::Response& res) {
      ++running_;
      const auto start = Clock::now();
      volatile double x = 0;
      while (!net::StopOf(req).stop_requested()) {
        for (int i = 0; i < 10000; ++i) x = x + 1.0;
      }
      --running_;
      res.set_content(std::to_string(std::chrono::duration<double>(Clock::now() - start).count()),
                      "text/plain");
    });
    // Waits without CPU until its token fires.
    server_.Post("/wait", [this](const httplib::Request& req, httplib::Response& res) {
      ++running_;
      peak_ = std::max(peak_.load(), running_.load());
      while (!net::StopOf(req).stop_requested())
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      --running_;
      res.set_content("stopped", "text/plain");
    });
    port_ = server_.bind_to_any_port("127.0.0.1");
    thread_ = std::thread([this] { server_.listen_after_bind(); });
    while (!server_.is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ~Front() {
    server_.stop();
    thread_.join();
  }
  // A socket with `path`'s POST sent, from 127.0.0.`from`.
  int Send(const char* path, int from = 1) const {
    const int fd = test::ConnectLoopback(port_, 10, 0x7f000000u + static_cast<uint32_t>(from));
    if (fd < 0) return -1;
    const std::string request =
        std::string("POST ") + path + " HTTP/1.1\r\nHost: x\r\nContent-Length: 0\r\n\r\n";
    send(fd, request.data(), request.size(), MSG_NOSIGNAL);
    return fd;
  }
  static std::string Answer(int fd) {
    std::string out;
    char buf[4096];
    for (ssize_t n; (n = recv(fd, buf, sizeof buf, 0)) > 0;) {
      out.append(buf, static_cast<size_t>(n));
      if (out.find("\r\n\r\n") != std::string::npos && out.size() > out.find("\r\n\r\n") + 4) break;
    }
    close(fd);
    return out.substr(out.find("\r\n\r\n") == std::string::npos ? 0 : out.find("\r\n\r\n") + 4);
  }
  // The whole answer to a GET of `path` on a socket of its own.
  std::string Get(const char* path) const {
    const int fd = test::ConnectLoopback(port_, 10);
    const std::string request =
        std::string("GET ") + path + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
    send(fd, request.data(), request.size(), MSG_NOSIGNAL);
    std::string out;
    char buf[4096];
    for (ssize_t n; (n = recv(fd, buf, sizeof buf, 0)) > 0;)
      out.append(buf, static_cast<size_t>(n));
    close(fd);
    return out;
  }
  const net::FrontStats& stats() const { return server_.Stats(); }
  std::atomic<int> running_{0}, peak_{0};

 private:
  net::FrontStats stats_;  // Before the server, which counts into it.
  net::FrontServer server_;
  int port_ = 0;
  std::thread thread_;
};

net::FrontOptions Options() {
  net::FrontOptions o;
  o.workers = 8;
  o.log_requests = false;
  return o;
}

TEST(Front, ARequestSpendingMoreCpuThanItMayIsStopped) {
  net::FrontOptions o = Options();
  o.cpu_limit = 0.3;
  Front front(o);
  const double ran = std::stod(Front::Answer(front.Send("/spin")));
  EXPECT_GE(
      ran,
      0.3);  // Seconds run: not stopped before its 0.3 CPU-s (without the meter it would spin on).
  EXPECT_EQ(front.stats().over_cpu.load(), 1u);
}

TEST(Front, ARequestIsStoppedAtItsDeadline) {
  net::FrontOptions o = Options();
  o.request_deadline = 1;
  Front front(o);
  const auto start = Clock::now();
  EXPECT_EQ(Front::Answer(front.Send("/wait")), "stopped");
  const double took = std::chrono::duration<double>(Clock::now() - start).count();
  EXPECT_GE(
      took,
      0.9);  // Not before it (without the deadline, /wait would not return: the test's timeout).
  EXPECT_EQ(front.stats().past_deadline.load(), 1u);
}

TEST(Front, AClientThatHangsUpStopsItsRequest) {
  Front front(Options());
  const int fd = front.Send("/spin");
  while (front.running_ == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  close(fd);
  const auto start = Clock::now();
  // Without the hang-up's stop it would spin on: waited for up to 30 s (a hang's bound, not a speed
  // bar).
  while (front.running_ > 0 && Clock::now() - start < std::chrono::seconds(30))
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(front.running_.load(), 0) << "the spinning handler was not stopped";
  EXPECT_EQ(front.stats().client_gone.load(), 1u);
}

TEST(Front, OneAddressRunsAtMostItsTurnsAndTheRestWait) {
  net::FrontOptions o = Options();
  o.max_client_requests = 2;
  o.request_deadline = 1;  // Each waits its second, then the next of the line runs.
  Front front(o);
  int fds[5];
  for (int& fd : fds) fd = front.Send("/wait");
  for (int fd : fds) EXPECT_EQ(Front::Answer(fd), "stopped");
  EXPECT_EQ(front.peak_.load(), 2);
  EXPECT_EQ(front.stats().waited_turn.load(), 3u);
}

// Fair shares (issue 61): an address may take the workers but a quarter kept for addresses that run
// nothing.
TEST(Front, AnAddressThatRunsNothingFindsAWorkerWhileAnotherTakesTheRest) {
  net::FrontOptions o = Options();
  o.workers = 4;
  o.max_client_requests = 16;
  o.request_deadline = 2;
  Front front(o);
  int busy[8];
  for (size_t i = 0; i < 8; ++i) {  // One at a time: cpp-httplib's listen backlog is 5, and a SYN
                                    // past it waits a second.
    busy[i] = front.Send("/wait", 1);
    while (front.stats().open.load() < i + 1)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  while (front.running_ < 3) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(front.running_.load(), 3) << "one address takes every worker but the reserve";
  const int other = front.Send("/wait", 2);
  while (front.running_ < 4 && front.stats().past_deadline.load() == 0)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  EXPECT_EQ(front.running_.load(), 4) << "the other address's request waited behind the first's";
  EXPECT_EQ(front.stats().past_deadline.load(), 0u);
  EXPECT_EQ(Front::Answer(other), "stopped");
  for (int fd : busy) EXPECT_EQ(Front::Answer(fd), "stopped");
  EXPECT_EQ(front.peak_.load(), 4);
  EXPECT_EQ(front.stats().waited_turn.load(), 5u);
}

// A probe is answered by the front itself, however many workers are busy.
TEST(Front, AProbeIsAnsweredWithoutAWorker) {
  net::FrontOptions o = Options();
  o.workers = 2;
  o.request_deadline = 2;
  o.probe = [](const net::RequestHeadView& head) -> std::optional<std::string> {
    if (head.target != "/healthz") return std::nullopt;
    return std::string("HTTP/1.1 200 OK\r\nContent-Length: 2\r\nConnection: keep-alive\r\n\r\nok");
  };
  Front front(o);
  const int a = front.Send("/wait", 1), b = front.Send("/wait", 2);
  while (front.running_ < 2) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const std::string answer = front.Get("/healthz");
  EXPECT_EQ(front.running_.load(), 2) << "both workers were still busy";
  EXPECT_EQ(answer.substr(0, 15), "HTTP/1.1 200 OK");
  EXPECT_EQ(answer.substr(answer.size() - 2), "ok");
  EXPECT_EQ(front.stats().past_deadline.load(), 0u);
  Front::Answer(a);
  Front::Answer(b);
}

}  // namespace front_test
}  // namespace facespace::net
