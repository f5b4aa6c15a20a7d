// A pool of worker threads stopped as the front's and the live hub's are: the flag set under the
// lock their wait takes, every waiter woken, every thread joined.
#pragma once

#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

namespace facespace::net {

inline void StopWorkers(std::mutex& mu, bool& stop, std::condition_variable& cv,
                        std::vector<std::thread>& workers) {
  {
    std::lock_guard<std::mutex> lock(mu);
    stop = true;
  }
  cv.notify_all();
  for (std::thread& t : workers) t.join();
  workers.clear();
}

}  // namespace facespace::net
