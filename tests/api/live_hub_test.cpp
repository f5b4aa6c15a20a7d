// The live hub's threads together (issue 61; run under ThreadSanitizer by tests/tsan.sh): sessions
// on socket pairs, each message answered on a turn, helper threads waking sessions and posting to
// them while the loop reads, pings, closes and sessions' ends run beside them.
#include "facespace/net/live_hub.h"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

namespace facespace::net {
namespace live_hub_test {  // Named: the target is a unity build, its files share one unit.

// A client's frame: masked (with a zero key, so the payload reads as it is), whole, short.
std::string ClientFrame(net::ws::Opcode op, const std::string& payload) {
  std::string f;
  f.push_back(static_cast<char>(0x80 | static_cast<uint8_t>(op)));
  f.push_back(static_cast<char>(0x80 | payload.size()));
  f.append(4, '\0');
  return f + payload;
}

// The next server frame's opcode and payload (short frames only), or opcode 0xff when the socket
// ended.
std::pair<uint8_t, std::string> ReadFrame(int fd) {
  auto read_n = [fd](size_t n) {
    std::string out;
    while (out.size() < n) {
      char buf[256];
      const ssize_t got = recv(fd, buf, std::min(sizeof buf, n - out.size()), 0);
      if (got <= 0) return std::string();
      out.append(buf, static_cast<size_t>(got));
    }
    return out;
  };
  const std::string head = read_n(2);
  if (head.size() < 2) return {0xff, ""};
  size_t n = static_cast<uint8_t>(head[1]) & 0x7f;
  if (n == 126) {
    const std::string ext = read_n(2);
    n = static_cast<size_t>(static_cast<uint8_t>(ext[0])) << 8 | static_cast<uint8_t>(ext[1]);
  }
  return {static_cast<uint8_t>(head[0]) & 0x0f, read_n(n)};
}

// Echoes each text message on its turn; a helper thread of its own posts "helper" and wakes the
// session.
class Echo final : public net::LiveHandler {
 public:
  ~Echo() override { End(); }
  void Attach(net::LivePost post, net::LiveWake wake) override {
    helper_ = std::thread([post, wake, this] {
      post(net::ws::Opcode::kText, "helper");
      woken_ = true;
      wake();
    });
  }
  void Open(Out& out) override { out.texts.push_back("ready"); }
  void OnText(std::string_view text, Out& out) override {
    out.texts.push_back("echo " + std::string(text));
  }
  void OnBinary(std::string_view, Out&) override {}
  void Poll(Out& out) override {
    if (woken_.exchange(false)) out.texts.push_back("polled");
  }
  double TakeHelperCpu() override { return 0.001; }
  bool MakeFrame(std::string&, Out&) override { return false; }
  void End() override {
    if (helper_.joinable()) helper_.join();
  }

 private:
  std::thread helper_;
  std::atomic<bool> woken_{false};
};

TEST(LiveHub, SessionsWithHelperThreadsAnswerEveryMessageAndClose) {
  net::LiveLimits limits;
  limits.workers = 2;
  net::LiveHub hub(limits);
  constexpr int kSessions = 8, kMessages = 20;
  std::vector<int> clients;
  for (int i = 0; i < kSessions; ++i) {
    int pair[2];
    ASSERT_EQ(socketpair(AF_UNIX, SOCK_STREAM, 0, pair), 0);
    timeval timeout{10, 0};
    setsockopt(pair[0], SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
    ASSERT_TRUE(hub.Reserve("127.0.0.1"));
    hub.Adopt(pair[1], "127.0.0.1", "", std::make_unique<Echo>(), SessionBounds{});
    clients.push_back(pair[0]);
  }
  std::vector<std::thread> talkers;
  std::atomic<int> echoes{0}, helpers{0}, pongs{0}, closes{0};
  for (int fd : clients) {
    talkers.emplace_back([&, fd] {
      for (int m = 0; m < kMessages; ++m) {
        const std::string frames = ClientFrame(net::ws::Opcode::kText, "m" + std::to_string(m)) +
                                   ClientFrame(net::ws::Opcode::kPing, "p");
        send(fd, frames.data(), frames.size(), MSG_NOSIGNAL);
      }
      // Everything answered first (a close drops what is not yet begun), then the close, answered
      // with one.
      int mine = 0, my_pongs = 0;
      bool helped = false, closed = false;
      for (auto [op, payload] = ReadFrame(fd); op != 0xff; std::tie(op, payload) = ReadFrame(fd)) {
        if (op == 8) {
          closed = true;
          break;
        }
        my_pongs += op == 10;
        mine += payload.rfind("echo m", 0) == 0;
        helped = helped || payload == "helper";
        if (mine == kMessages && my_pongs == kMessages && helped) {
          const std::string bye = ClientFrame(net::ws::Opcode::kClose, std::string("\x03\xe8", 2));
          send(fd, bye.data(), bye.size(), MSG_NOSIGNAL);
        }
      }
      echoes += mine;
      pongs += my_pongs;
      helpers += helped;
      closes += closed;
      ::close(fd);
    });
  }
  for (std::thread& t : talkers) t.join();
  EXPECT_EQ(echoes.load(), kSessions * kMessages);
  EXPECT_EQ(pongs.load(), kSessions * kMessages);
  EXPECT_EQ(helpers.load(), kSessions);
  EXPECT_EQ(closes.load(), kSessions);
  hub.Stop();
  EXPECT_EQ(hub.open(), 0u);
}

// A turn that takes a while; End counts the times it found a turn of its session running (as a live
// listener's Poll was while End dropped it: the server's crash after 48 rounds of four listeners).
class SlowTurn final : public LiveHandler {
 public:
  SlowTurn(std::atomic<int>& ends, std::atomic<int>& overlaps) : ends_(ends), overlaps_(overlaps) {}
  void Open(Echo::Out&) override {}
  void OnText(std::string_view, Echo::Out& out) override {
    in_turn_ = true;
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    out.texts.push_back("done");
    in_turn_ = false;
  }
  void OnBinary(std::string_view, Echo::Out&) override {}
  bool MakeFrame(std::string&, Echo::Out&) override { return false; }
  void End() override {
    overlaps_ += in_turn_.load();
    ++ends_;
  }

 private:
  std::atomic<bool> in_turn_{false};
  std::atomic<int>& ends_;
  std::atomic<int>& overlaps_;
};

TEST(LiveHub, AClientGoneDuringATurnEndsItsSessionAfterTheTurn) {
  net::LiveLimits limits;
  limits.workers = 2;
  net::LiveHub hub(limits);
  constexpr int kSessions = 12;
  std::atomic<int> ends{0}, overlaps{0};
  for (int i = 0; i < kSessions; ++i) {
    int pair[2];
    ASSERT_EQ(socketpair(AF_UNIX, SOCK_STREAM, 0, pair), 0);
    ASSERT_TRUE(hub.Reserve("127.0.0.1"));
    hub.Adopt(pair[1], "127.0.0.1", "", std::make_unique<SlowTurn>(ends, overlaps),
              SessionBounds{});
    const std::string text = ClientFrame(net::ws::Opcode::kText, "slow");
    send(pair[0], text.data(), text.size(), MSG_NOSIGNAL);
    std::this_thread::sleep_for(
        std::chrono::milliseconds(10));  // Its turn has begun: then the client is gone.
    ::close(pair[0]);
  }
  for (int i = 0; i < 500 && ends.load() < kSessions; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(ends.load(), kSessions);
  EXPECT_EQ(overlaps.load(), 0) << "End ran while a turn of its session was running";
  hub.Stop();
}

}  // namespace live_hub_test
}  // namespace facespace::net
