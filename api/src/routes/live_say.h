// Speech on a live socket (issue 53): {"say": {"text", "voice", "rate"}} spoken by espeak-ng while it is
// made. Audio goes out as binary messages ("pcm1", chunk number, sample rate, first sample on the
// session's audio clock; then 16-bit little-endian mono samples) and visemes as text events
// {"viseme", "start", "end"} on the same clock, each with its audio; the visemes are the speech route's
// for the same text. Pieces queue (text as a language model streams it) and speak one after the other;
// audio is sent at most kLead ahead of real time, so a long text never floods the socket; {"stop": true}
// ends the speech and drops what is queued. One thread per speaking session, started at its first say.
#pragma once

#include <condition_variable>
#include <deque>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "facespace/core/speech.h"
#include "facespace/core/status.h"
#include "../http/live_hub.h"

namespace facespace::api::http {

// A little-endian uint32 appended: the live binary messages' headers.
inline void PutU32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
}

// The text events of a live session: an error (its type, what is wrong, the member's pointer if any),
// and a viseme on the session's audio clock ({"viseme", "start", "end"}, as the speech route writes them).
std::string ErrorEvent(const std::string& type, const std::string& detail, const std::string& pointer = "");
std::string VisemeEvent(const TimedViseme& v, double clock = 0);

class LiveSpeaker {
 public:
  static constexpr double kLead = 1.0;              // Seconds of audio sent ahead of real time.
  static constexpr size_t kMaxQueuedChars = 8000;   // Text waiting to be spoken (four long says).

  LiveSpeaker() = default;
  ~LiveSpeaker();
  LiveSpeaker(const LiveSpeaker&) = delete;
  LiveSpeaker& operator=(const LiveSpeaker&) = delete;

  void Attach(LivePost post) { post_ = std::move(post); }
  // Queues a piece (checked: text, voice, rate); errors name the field under /say.
  Status Say(std::string text, std::string voice, int rate);
  // Ends what is being said and drops what waits; false when nothing was.
  bool Stop();
  // For the session's end: stops, and joins the speaking thread; no more speech after.
  void Close();

 private:
  struct Piece {
    std::string text, voice;
    int rate = 175;
  };
  // What one piece has made and not yet sent.
  struct Utterance;
  void Run(std::stop_token stop);
  void Speak(const Piece& piece, std::stop_token stop);
  // Sends what is due of `u`; returns when the next part is due (or zero when all is out).
  double Send(Utterance& u, bool all_made);
  void Post(const std::string& text) { post_(ws::Opcode::kText, text); }

  LivePost post_;
  std::mutex mu_;
  std::condition_variable_any cv_;
  std::deque<Piece> queue_;
  size_t queued_chars_ = 0;
  bool speaking_ = false, closed_ = false;
  std::stop_source utterance_;  // The piece being spoken (Stop fires it).
  std::jthread thread_;
  // The session's audio clock (the speaker thread's): seconds of audio sent so far, and where real time
  // stood when the audio now playing began.
  double clock_ = 0;
  uint32_t chunk_ = 0;
};

}  // namespace facespace::api::http
