#include "facespace/engine/cpu.h"

#include <ctime>

namespace facespace {
inline namespace engine {

namespace {

double Seconds(clockid_t clock) {
  timespec t{};
  if (clock_gettime(clock, &t) != 0) return 0.0;
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace

double ThreadCpuSeconds() { return Seconds(CLOCK_THREAD_CPUTIME_ID); }

// The kernel's per-thread CPU clock of `tid` (what pthread_getcpuclockid makes: the id inverted,
// shifted by 3, with the per-thread bit and CPUCLOCK_SCHED).
double ThreadCpuSeconds(pid_t tid) {
  return Seconds(static_cast<clockid_t>((~static_cast<unsigned>(tid) << 3) | 6u));
}

}  // namespace engine
}  // namespace facespace
