// CPU clocks of threads, and the meter of helper threads' work (issue 61). A request's cost is metered on
// the thread that serves it; work it hands to other threads (llvmpipe's rasteriser threads, an encoder's
// helpers, a session's speaker or listener) escaped that meter: an EXR sheet estimated at 1.6 CPU-s took
// 8.3. Whoever waits for such work measures what the helpers spent and charges it here, on the thread it
// was done for; the server's meter (the connection front) counts the charge as the request's own CPU and
// stops the request at its limit just the same.
#pragma once

#include <sys/types.h>

#include <span>

namespace facespace {

// The calling thread's CPU clock, in seconds.
double ThreadCpuSeconds();
// Another thread's of this process (by its kernel id), 0 when it is gone.
double ThreadCpuSeconds(pid_t tid);

// CPU-seconds other threads spent for the work of the calling thread: given to the sink the server set
// for this thread (nothing happens where none is set: the CLI, tests, batch jobs' own threads).
void ChargeHelperCpu(double seconds);
// The sink of the calling thread (the front sets one per request on its worker), or null for none.
using HelperCpuSink = void (*)(void* context, double seconds);
void SetHelperCpuSink(HelperCpuSink sink, void* context);

}  // namespace facespace
