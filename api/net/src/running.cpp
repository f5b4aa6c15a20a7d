// A request's Running, found on the request (running.h).
#include "running.h"

namespace facespace::net {

Running* RunningOf(const httplib::Request& req) {
  const Carrier* carrier = req.progress.target<Carrier>();
  return carrier ? carrier->running : nullptr;
}

std::stop_token StopOf(const httplib::Request& req) {
  const Running* running = RunningOf(req);
  return running ? running->stop : std::stop_token();
}

HelperCpu* HelperCpuOf(const httplib::Request& req) {
  const Running* running = RunningOf(req);
  return running ? running->helper_cpu : nullptr;
}

}  // namespace facespace::net
