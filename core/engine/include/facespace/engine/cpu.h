// CPU clocks of threads, and the meter of helper threads' work (issue 61). A request's cost is
// metered on the thread that serves it; work it hands to other threads (llvmpipe's rasteriser
// threads, an encoder's helpers, a session's speaker or listener) escaped that meter: an EXR sheet
// estimated at 1.6 CPU-s took 8.3. Whoever waits for such work measures what the helpers spent and
// charges it to the work's HelperCpu, handed down with the work itself (RenderOptions, Encode,
// VideoOptions, the evaluator's Workspace), never found through the thread; the server's meter (the
// connection front's watchdog) counts it as the request's own CPU and stops the request at its
// limit just the same.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <cmath>
#include <cstdint>

namespace facespace {
inline namespace engine {

// The calling thread's CPU clock, in seconds.
double ThreadCpuSeconds();
// Another thread's of this process (by its kernel id), 0 when it is gone.
double ThreadCpuSeconds(pid_t tid);

// CPU-seconds other threads spent for one piece of work (a request, a live session's turn).
// Thread-safe: helpers' waiters charge it while the work's meter reads it.
class HelperCpu {
 public:
  void Charge(double seconds) {
    if (seconds > 0) ns_.fetch_add(std::llround(seconds * 1e9), std::memory_order_relaxed);
  }
  double Seconds() const { return 1e-9 * static_cast<double>(ns_.load(std::memory_order_relaxed)); }
  // What was charged since the last Take.
  double Take() { return 1e-9 * static_cast<double>(ns_.exchange(0, std::memory_order_relaxed)); }

 private:
  std::atomic<int64_t> ns_{0};
};

// Charges `meter`, or nothing where the work has none (the CLI, tests, batch jobs' own threads).
inline void ChargeHelperCpu(HelperCpu* meter, double seconds) {
  if (meter) meter->Charge(seconds);
}

}  // namespace engine
}  // namespace facespace
