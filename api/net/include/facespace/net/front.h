// The connection front: what stands between clients and the request handlers.
//
// cpp-httplib 0.11.4 gives each connection a thread of its pool for as long as the connection
// lives, reading the request with a timeout per read: 256 sockets sending a byte a second held
// every thread (slowloris), and idle keep-alive sockets held threads too. Here one thread holds
// every connection (epoll) while its request comes in: the whole head and body must arrive within
// a deadline, the connections are capped in all and per client address, bodies in memory share
// a budget, and the framing is checked strictly (RFC 9112: no chunk without its CRLF, no
// Transfer-Encoding beside Content-Length, pipelined requests answered in order). Only a whole
// request goes to a worker, which runs cpp-httplib's own request processing on it (routing,
// handlers, response writing); the connection then comes back to the front for its next request.
#pragma once

#include <httplib.h>

#include <any>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stop_token>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/engine/cpu.h"

namespace facespace::net {

// A request's line and headers as the front read them, for a check before its body is read.
struct RequestHeadView {
  std::string method;
  std::string target;
  std::vector<std::pair<std::string, std::string>> headers;
};

// Why the front answers a request itself, with the HTTP status it answers.
enum class Refusal {
  kTooManyConnections,  // 503: the caps on connections, in all or from one address.
  kFraming,       // 400, 411, 413, 414, 431, 501 or 505: the request's framing (status says which).
  kBodyTooLarge,  // 413: a body over max_body.
  kBusy,          // 503: the budget for bodies held in memory is spent.
  kRequestTimeout,  // 408: the request did not arrive whole in time.
};
struct RefusalInfo {
  Refusal why;
  int status;
  std::string_view detail;
  std::string_view path;  // The request's path, when its head was read.
  bool retry_after;       // Worth retrying in a moment.
};

struct FrontOptions {
  int workers = 64;               // Threads running whole requests.
  int request_timeout = 10;       // Seconds for a whole head and body (plus 1 s per MiB of body).
  int keep_alive_timeout = 5;     // Seconds an idle connection is kept.
  size_t keep_alive_max = 10000;  // Requests on one connection.
  int write_timeout = 10;         // Seconds a response write may wait for the client.
  size_t max_body = size_t{64} << 20;
  size_t max_connections = 4096;  // Open at once, in all; more are answered 503 and closed.
  size_t max_per_client = 256;    // Open at once from one address.
  size_t body_budget =
      size_t{1} << 30;  // Bytes of requests held in memory at once, in all; past it 503.
  bool log_requests =
      true;  // An access-log line (stderr) for each request the front answers itself.
  // Bounds on a request once it runs (its stop token fires at any of them; see Running):
  size_t max_client_requests =
      16;  // Requests of one address running at once; its others wait their turn.
  int request_deadline = 120;  // Seconds from the start of its work to the end of its answer.
  int keyed_deadline = 1800;   // ... for a request that `keyed` says carries the API key.
  size_t min_send_rate =
      size_t{32}
      << 10;  // Bytes a second a client must read an answer at, past write_timeout's grace.
  double cpu_limit = 0;  // CPU-seconds a request's worker thread may spend (0: no limit): the meter
  double keyed_cpu_limit =
      0;  // behind the estimates (the API's budgets, with a margin); keyed requests.
  std::function<bool(std::string_view authorization)>
      keyed;  // Whether a request's Authorization carries the key.
  // Called for a request that declares a body, before the body is read: a whole HTTP response to
  // send (then the connection is closed), or nothing to go on. (The API's pre-routing: 401, 404,
  // 405, 411, 413 from the headers, so a refused body is never uploaded.)
  std::function<std::optional<std::string>(const RequestHeadView&)> head_check;
  // Called for a whole request without a body before it would go to a worker: a whole HTTP response
  // the front sends itself, at once (the probes, /healthz, /readyz and /metrics, answered however
  // many workers are busy), or nothing to go on.
  std::function<std::optional<std::string>(const RequestHeadView&)> probe;
  // The scarce resource a request needs, from its method, target and Content-Type (an index into
  // scarce_slots), or -1 for none: at most scarce_slots[i] of the requests that need resource i
  // hold a worker (or a place in their address's line) at once; the rest wait in the front, in
  // order, holding no worker.
  std::function<int(std::string_view method, std::string_view target,
                    std::string_view content_type)>
      scarce;
  std::vector<size_t> scarce_slots;
  // The whole HTTP response for a request the front refuses (the connection closes after it),
  // worded by the caller: the API's problem+json. Absent: plain text.
  std::function<std::string(const RefusalInfo&)> refusal;
};

// Counters of the front, for /metrics and the log.
struct FrontStats {
  std::atomic<size_t> open{0};            // Connections open now.
  std::atomic<size_t> refused_total{0};   // Connections refused for the caps.
  std::atomic<size_t> refused_client{0};  // ... of which for the per-client cap.
  std::atomic<size_t> timed_out{0};       // Requests cut off at their deadline (408).
  std::atomic<size_t> bad_framing{
      0};  // Requests refused for their framing (400, 414, 431, 501, 505).
  std::atomic<size_t> over_budget{0};  // Bodies refused for the memory budget (503).
  std::atomic<size_t> body_bytes{0};   // Request bytes held now.
  std::atomic<size_t> waited_turn{
      0};  // Requests that waited for their address's turn (max_client_requests).
  std::atomic<size_t> client_gone{0};    // Requests stopped because their client hung up.
  std::atomic<size_t> past_deadline{0};  // Requests stopped at their deadline.
  std::atomic<size_t> slow_readers{
      0};  // Answers ended because their client read too slowly, or not at all.
  std::atomic<size_t> over_cpu{0};   // Requests stopped for the CPU their worker spent (cpu_limit).
  std::atomic<size_t> in_flight{0};  // Requests running now.
};

// A request running on a front's worker, as the front knows it: carried on the request itself
// (RunningOf), not on the thread. `stop` fires when the request's client hangs up, at its deadline
// or CPU limit, and when the server stops (SIGTERM); long work checks it between its steps (frames,
// cells, keys, audio chunks). `state` is the caller's own state of the request (the API's clock and
// route label). `helper_cpu` is charged what other threads spend for it (a render's rasteriser, an
// encoder's helpers: facespace/engine/cpu.h), counted by its CPU limit as its own.
struct Running {
  std::stop_token stop;
  void* connection = nullptr;  // The front's, for UpgradeConnection.
  std::any state;
  HelperCpu* helper_cpu = nullptr;
};

// The running request `req` is, or null for a request no front's worker serves.
Running* RunningOf(const httplib::Request& req);
// Its stop token; one that never fires for a request no front serves.
std::stop_token StopOf(const httplib::Request& req);
// Its helper threads' meter; null (charged nowhere) for a request no front serves.
HelperCpu* HelperCpuOf(const httplib::Request& req);

// Who takes a connection upgraded to another protocol (the live route's WebSocket sessions): the
// socket (theirs from then on) and the bytes the client sent after its request.
using UpgradeTaker = std::function<void(int fd, std::string buffered)>;

// From a route handler: answer `req` with `head` (a whole response head, "HTTP/1.1 101 Switching
// Protocols\r\n...\r\n\r\n") instead of what cpp-httplib writes, then hand the connection to `take`
// once the head is out. False for a request no front's worker serves (nothing is taken).
bool UpgradeConnection(const httplib::Request& req, std::string head, UpgradeTaker take);

// A cpp-httplib server whose connections go through the front. Use it as httplib::Server
// (routes, hooks, bind_to_port, listen_after_bind, stop); new_task_queue is its own.
class FrontServer : public httplib::Server {
 public:
  // `stats` outlives the server: the API that reports them is made first, then the server that
  // calls it.
  FrontServer(FrontOptions options, FrontStats& stats);
  ~FrontServer() override;
  const FrontStats& Stats() const;

  class Front;  // The epoll loop and the workers (api/net/src/front.cpp).

 private:
  bool process_and_close_socket(socket_t sock) override;
  bool Process(httplib::Stream& stream, bool close_connection, bool& connection_closed,
               Running& running);
  std::unique_ptr<Front> front_;
};

}  // namespace facespace::net
