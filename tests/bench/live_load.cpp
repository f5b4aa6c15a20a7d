// Live sessions under load (issue 53): N WebSocket clients on GET /v1/rigs/{rig}/live, each sending
// a slider change ({"weights": {SHAPE: v}, "id": k}) at a rate for a time, reading every frame; M
// more that send the same but never read. Prints one JSON line: messages, frames, bytes, the delay
// from a message to the first frame that reflects it (p50, p99, max; frames carry the newest id
// applied), errors, and how the never-readers ended (closed by the server, and when).
//
//   live_load PORT RIG [--sessions 100] [--seconds 30] [--hz 60] [--shape jawOpen] [--never-read 0]
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <random>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

struct Session {
  int fd = -1;
  bool reader = true, open = false, closed = false;
  int close_code = 0;
  double closed_at = 0;
  std::string in;
  uint32_t next_id = 1, seen_id = 0;
  std::map<uint32_t, Clock::time_point> sent;  // Ids sent and not yet seen in a frame.
  size_t frames = 0, bytes = 0, errors = 0;
};

std::string Frame(int opcode, const std::string& payload) {
  std::string f;
  f.push_back(static_cast<char>(0x80 | opcode));
  const size_t n = payload.size();
  if (n < 126) {
    f.push_back(static_cast<char>(0x80 | n));
  } else {
    f.push_back(static_cast<char>(0x80 | 126));
    f.push_back(static_cast<char>(n >> 8));
    f.push_back(static_cast<char>(n));
  }
  const char mask[4] = {0x12, 0x34, 0x56, 0x78};
  f.append(mask, 4);
  for (size_t i = 0; i < n; ++i) f.push_back(static_cast<char>(payload[i] ^ mask[i & 3]));
  return f;
}

int Connect(int port, const std::string& rig) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) return -1;
  const int yes = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
  const std::string head =
      "GET /v1/rigs/" + rig +
      "/live HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
      "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
  if (send(fd, head.data(), head.size(), 0) != static_cast<ssize_t>(head.size())) return -1;
  std::string got;
  char c;
  while (got.size() < 4 || got.compare(got.size() - 4, 4, "\r\n\r\n") != 0) {
    if (recv(fd, &c, 1, 0) != 1) return -1;
    got.push_back(c);
  }
  if (got.compare(0, 12, "HTTP/1.1 101") != 0) {
    std::fprintf(stderr, "live_load: no upgrade: %s\n", got.substr(0, got.find("\r\n")).c_str());
    close(fd);
    return -1;
  }
  return fd;
}

// The server's whole messages in s.in: frames' ids matched to what was sent.
void Parse(Session& s, Clock::time_point now, double t, std::vector<double>& delays) {
  size_t at = 0;
  while (s.in.size() - at >= 2) {
    const auto* b = reinterpret_cast<const uint8_t*>(s.in.data() + at);
    uint64_t n = b[1] & 0x7F;
    size_t h = 2;
    if (n == 126) {
      if (s.in.size() - at < 4) break;
      n = static_cast<uint64_t>(b[2]) << 8 | b[3], h = 4;
    } else if (n == 127) {
      if (s.in.size() - at < 10) break;
      n = 0;
      for (int i = 0; i < 8; ++i) n = n << 8 | b[2 + i];
      h = 10;
    }
    if (s.in.size() - at < h + n) break;
    const int op = b[0] & 0x0F;
    const char* p = s.in.data() + at + h;
    if (op == 2 && n >= 16 && std::memcmp(p, "mesh", 4) == 0) {
      uint32_t id;
      std::memcpy(&id, p + 8, 4);
      ++s.frames;
      s.bytes += n;
      for (auto it = s.sent.begin(); it != s.sent.end() && it->first <= id;) {
        delays.push_back(std::chrono::duration<double>(now - it->second).count());
        it = s.sent.erase(it);
      }
      s.seen_id = std::max(s.seen_id, id);
    } else if (op == 1) {
      if (std::string_view(p, n).find("\"event\":\"error\"") != std::string_view::npos) ++s.errors;
      if (std::string_view(p, n).find("\"event\":\"ready\"") != std::string_view::npos)
        s.open = true;
    } else if (op == 8) {
      s.closed = true;
      s.close_code = n >= 2 ? (static_cast<uint8_t>(p[0]) << 8 | static_cast<uint8_t>(p[1])) : 1005;
      s.closed_at = t;
    }
    at += h + n;
  }
  s.in.erase(0, at);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: live_load PORT RIG [--sessions N] [--seconds S] [--hz H] [--shape NAME] "
                 "[--never-read M]\n");
    return 2;
  }
  const int port = std::atoi(argv[1]);
  const std::string rig = argv[2];
  int sessions = 100, never = 0;
  double seconds = 30, hz = 60;
  std::string shape = "jawOpen";
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--sessions")
      sessions = std::atoi(v.c_str());
    else if (k == "--seconds")
      seconds = std::atof(v.c_str());
    else if (k == "--hz")
      hz = std::atof(v.c_str());
    else if (k == "--shape")
      shape = v;
    else if (k == "--never-read")
      never = std::atoi(v.c_str());
  }
  std::vector<Session> all(static_cast<size_t>(sessions + never));
  const int ep = epoll_create1(0);
  for (size_t i = 0; i < all.size(); ++i) {
    all[i].fd = Connect(port, rig);
    all[i].reader = static_cast<int>(i) < sessions;
    if (all[i].fd < 0) {
      std::printf("{\"error\": \"session %zu could not connect\"}\n", i);
      return 1;
    }
    if (!all[i].reader) {  // A small receive buffer: the server's queue, not the kernel's, fills.
      const int small = 4096;
      setsockopt(all[i].fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    }
    epoll_event ev{};
    ev.events = all[i].reader ? EPOLLIN : 0u;
    ev.data.u64 = i;
    epoll_ctl(ep, EPOLL_CTL_ADD, all[i].fd, &ev);
  }
  std::vector<double> delays;
  delays.reserve(static_cast<size_t>(sessions * seconds * hz) + 1000);
  std::mt19937 rng(7);
  std::vector<double> phase(all.size());
  for (double& p : phase) p = std::uniform_real_distribution<double>(0, 6.28)(rng);
  const Clock::time_point start = Clock::now(),
                          end = start + std::chrono::duration_cast<Clock::duration>(
                                            std::chrono::duration<double>(seconds));
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / hz));
  Clock::time_point next_send = start + std::chrono::milliseconds(200);
  size_t messages = 0;
  std::vector<char> chunk(1 << 20);
  epoll_event events[256];
  while (true) {
    const Clock::time_point now = Clock::now();
    if (now >= end + std::chrono::milliseconds(300)) break;
    if (now >= next_send && now < end) {
      const double t = std::chrono::duration<double>(now - start).count();
      for (size_t i = 0; i < all.size(); ++i) {
        Session& s = all[i];
        if (s.closed) continue;
        char text[160];
        const double v = 0.5 + 0.45 * std::sin(2 * M_PI * 0.5 * t + phase[i]);
        std::snprintf(text, sizeof text, "{\"weights\":{\"%s\":%.4f},\"id\":%u}", shape.c_str(), v,
                      s.next_id);
        const std::string f = Frame(1, text);
        if (send(s.fd, f.data(), f.size(), MSG_NOSIGNAL | MSG_DONTWAIT) ==
            static_cast<ssize_t>(f.size())) {
          if (s.reader) s.sent[s.next_id] = Clock::now();
          ++s.next_id;
          ++messages;
        }
      }
      next_send += period;
    }
    const int wait = static_cast<int>(std::max<int64_t>(
        0,
        std::chrono::duration_cast<std::chrono::milliseconds>(next_send - Clock::now()).count()));
    const int n = epoll_wait(ep, events, 256, std::min(wait, 5));
    const Clock::time_point got = Clock::now();
    const double t = std::chrono::duration<double>(got - start).count();
    for (int k = 0; k < n; ++k) {
      Session& s = all[events[k].data.u64];
      while (true) {
        const ssize_t r = recv(s.fd, chunk.data(), chunk.size(), MSG_DONTWAIT);
        if (r > 0) {
          s.in.append(chunk.data(), static_cast<size_t>(r));
          continue;
        }
        if (r == 0) {
          if (!s.closed) s.closed = true, s.closed_at = t, s.close_code = 1006;
          epoll_ctl(ep, EPOLL_CTL_DEL, s.fd, nullptr);
        }
        break;
      }
      Parse(s, got, t, delays);
    }
  }
  // The never-readers: read what is there now (the server's close frame, if it dropped them).
  for (Session& s : all) {
    if (s.reader) continue;
    const double t = std::chrono::duration<double>(Clock::now() - start).count();
    ssize_t r;
    while ((r = recv(s.fd, chunk.data(), chunk.size(), MSG_DONTWAIT)) > 0)
      s.in.append(chunk.data(), static_cast<size_t>(r));
    std::vector<double> ignored;
    Parse(s, Clock::now(), t, ignored);
    if (!s.closed && r == 0) s.closed = true, s.close_code = 1006;
  }
  std::sort(delays.begin(), delays.end());
  auto pct = [&](double q) {
    return delays.empty()
               ? 0.0
               : 1e3 *
                     delays[std::min(delays.size() - 1,
                                     static_cast<size_t>(q * static_cast<double>(delays.size())))];
  };
  size_t frames = 0, bytes = 0, errors = 0, unseen = 0, readers_closed = 0, dropped = 0;
  for (const Session& s : all) {
    frames += s.frames, bytes += s.bytes, errors += s.errors;
    if (s.reader)
      unseen += s.sent.size(), readers_closed += s.closed;
    else
      dropped += s.closed;
  }
  std::printf(
      "{\"sessions\": %d, \"seconds\": %g, \"hz\": %g, \"messages\": %zu, \"frames\": %zu, "
      "\"bytes_per_frame\": %.0f, "
      "\"delay_ms\": {\"p50\": %.2f, \"p99\": %.2f, \"max\": %.2f, \"count\": %zu}, "
      "\"unanswered\": %zu, \"errors\": %zu, "
      "\"readers_closed\": %zu, \"never_readers\": %d, \"never_readers_dropped\": %zu}\n",
      sessions, seconds, hz, messages, frames,
      frames ? static_cast<double>(bytes) / static_cast<double>(frames) : 0.0, pct(0.5), pct(0.99),
      delays.empty() ? 0.0 : 1e3 * delays.back(), delays.size(), unseen, errors, readers_closed,
      never, dropped);
  for (Session& s : all) close(s.fd);
  return 0;
}
