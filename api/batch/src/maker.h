// Sample makers in processes of their own, for the CLI's batches that render (run.cpp). llvmpipe
// rasterises for every GL context of a process through one rasteriser behind one lock (one screen a
// process), so two worker threads take turns at it and a core waits; a process a core renders its
// samples alone, in its own thread (tests/bench/README.md, "Datasets": 15% more samples a second).
//
// The parent forks each maker before it starts any thread (a fork copies only the calling thread),
// asks it for variant k over a pipe and gets back what the variant's worker thread would have made:
// its manifest line's pieces, its warnings and its files. The parent alone writes to the folder, so
// group commit, tar order and resume are the threads' own. A maker dies with its parent (a kill -9
// leaves none behind), ignores SIGINT and SIGTERM (the parent stops asking and closes the pipe),
// and one that dies fails the run like any worker's error: the rerun resumes. Internal to
// facespace_batch.
#pragma once

#include <sys/types.h>

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "facespace/engine/status.h"

namespace facespace::batch {

// A folder variant's files by name, each in up to two pieces (a mesh's header and body), viewing
// the buffers of whoever made them.
using NamedFiles = std::vector<std::pair<std::string, std::array<std::string_view, 2>>>;

// A variant as made, ready to be stored: the manifest line's head and tail (its position in a tar
// goes between), the warning codes it carries (each once) and its sum of weights, and its bytes: a
// tar's members, or a folder's files.
struct MadeVariant {
  std::string head, tail;
  std::vector<std::string> codes;
  double sum = 0;
  std::string tar;
  NamedFiles files;  // A maker's: views into the message its MakerProcess received.
};

// Whether this process may fork makers now: it runs one thread (a thread started before, such as an
// image decoder's pool, would be missing from the copy and could hold a lock it needs).
bool CanForkMakers();

class MakerProcess {
 public:
  using Make = std::function<Status(size_t k, MadeVariant& out)>;
  // A maker forked to answer variant numbers with `make` (called in the child only), or an error.
  static Result<std::unique_ptr<MakerProcess>> Start(const Make& make);
  MakerProcess(const MakerProcess&) = delete;
  MakerProcess& operator=(const MakerProcess&) = delete;
  ~MakerProcess();  // The pipe closed, the child waited for (it exits on the pipe's end).

  // Variant k from the maker into `out`, whose views stay valid until the next call.
  Status Ask(size_t k, MadeVariant& out);

 private:
  MakerProcess(pid_t pid, int to_child, int from_child)
      : pid_(pid), to_child_(to_child), from_child_(from_child) {}
  Status Died();

  pid_t pid_;
  int to_child_, from_child_;
  std::string received_;
};

// The message a maker sends for one variant, and its reading (exposed for the fuzzer and tests):
// a status, then the variant's pieces, each a length and its bytes.
std::string EncodeMade(const Status& status, const MadeVariant& made);
Status DecodeMade(std::string_view message, MadeVariant& out);

}  // namespace facespace::batch
