// Hearing on a live socket (issue 53; bounded by issue 61): after {"listen": {"rate": 16000}},
// binary messages are 16-bit PCM, decoded by PocketSphinx on a thread of the listener's own, never
// on the hub's turn workers (four listeners streaming at 3x real time held both workers, and every
// other session's frames waited 5 s). Listener threads are as few as the decoders
// (speech::kMaxLiveDecoders) and run at a lower CPU priority than the turns. Audio is taken at most
// kMaxRealTime times as fast as it plays (with a burst of kBurstSeconds), and at most
// kMaxBacklogSeconds of it waits to be decoded; the CPU the thread spends is the session's
// (TakeCpu).
#pragma once

#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <thread>
#include <vector>

#include "facespace/engine/speech.h"
#include "facespace/engine/status.h"
#include "facespace/speech/speech.h"

namespace facespace::http {

class LiveListener {
 public:
  static constexpr double kRate = 16000;
  static constexpr double kMaxRealTime = 1.5;        // Audio seconds a second, sustained.
  static constexpr double kBurstSeconds = 4.0;       // ... beyond which a burst is refused.
  static constexpr double kMaxBacklogSeconds = 6.0;  // Audio waiting for the decoder.
  static constexpr int kNice = 5;                    // The thread's priority below the turns'.

  // A listener with a decoder of its own, or ResourceExhausted (reason "busy") when every decoder
  // is in use. `wake` asks for a turn of the session, where Take and Ended read what the thread
  // made.
  static Result<std::unique_ptr<LiveListener>> Open(std::function<void()> wake);
  ~LiveListener();  // Stops the thread and joins it.
  LiveListener(const LiveListener&) = delete;
  LiveListener& operator=(const LiveListener&) = delete;

  // Queues a chunk for the decoder; ResourceExhausted ("audio-too-fast") past the rate or the
  // backlog.
  Status Feed(std::span<const int16_t> pcm);
  // No more audio: the thread decodes what waits, ends the utterance, then wakes the session.
  void Finish();
  // Stops decoding at the next chunk (the session is closing); from any thread, without waiting.
  void Cancel();
  // The phonemes sure so far (moved into `out`); an error of the decoder's, once; whether Finish is
  // done.
  Status Take(std::vector<TimedPhoneme>& out);
  bool Ended();
  double TakeCpu();  // CPU-seconds the thread spent since last asked.

 private:
  LiveListener(std::unique_ptr<speech::LiveRecognizer> rec, std::function<void()> wake);
  void Run(std::stop_token stop);

  using Clock = std::chrono::steady_clock;
  std::unique_ptr<speech::LiveRecognizer> rec_;
  std::function<void()> wake_;
  std::mutex mu_;  // Guards what follows.
  std::condition_variable_any cv_;
  std::deque<std::vector<int16_t>> queue_;
  size_t queued_samples_ = 0;
  std::vector<TimedPhoneme> sure_;
  Status error_ = Status::Ok();
  bool finishing_ = false, ended_ = false;
  double cpu_ = 0;
  double credit_ = kBurstSeconds * kRate;  // Samples that may come now (GCRA).
  Clock::time_point credit_at_ = Clock::now();
  std::jthread thread_;  // Last: it runs on the members above.
};

}  // namespace facespace::http
