// Speech on a live socket (issue 53): {"say": {"text", "voice", "rate"}} spoken by espeak-ng while
// it is made. Audio goes out as binary messages ("pcm1", chunk number, sample rate, first sample on
// the session's audio clock; then 16-bit little-endian mono samples) and visemes as text events
// {"viseme", "start", "end"} on the same clock, each with its audio; the visemes are the speech
// route's for the same text. Pieces queue (text as a language model streams it) and speak one after
// the other; audio is sent at most kLead ahead of real time, so a long text never floods the
// socket; {"stop": true} ends the speech and drops what is queued. One thread per speaking session,
// started at its first say. Memory is bounded (issue 61: an 8-minute line held 57-84 MB a session
// for its playback): a piece is spoken in segments (SpeechSegments: whole sentences of at most
// about kSegmentSeconds of speech), each made when the one before is nearly played, its samples let
// go as they are sent; the speech held by every session together has a cap (kMaxHeldBytes: past it,
// the next segments wait); the CPU of synthesis is the session's (TakeCpu).
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "facespace/engine/speech.h"
#include "facespace/engine/status.h"
#include "facespace/net/live_hub.h"

namespace facespace::http {

// The text of a piece cut where it may be spoken in parts, each taking at most about
// LiveSpeaker::kSegmentSeconds to say at `rate` (words a minute): after the last whole sentence (.
// ! ? ; :) that fits, else between words. A text that fits is one part, spoken as the speech route
// speaks it.
std::vector<std::string> SpeechSegments(std::string_view text, int rate);
// Bytes of speech made and not yet sent, by every live session together.
std::atomic<size_t>& HeldBytes();

// A little-endian uint32 appended: the live binary messages' headers.
inline void PutU32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
}

// A text event of a live session: an error (its type, what is wrong, the member's pointer if any).
// A viseme on the session's audio clock is lipsync::TimedVisemeJson, as the speech route writes it.
std::string ErrorEvent(const std::string& type, const std::string& detail,
                       const std::string& pointer = "");
// A status as an error event: its reason (else invalid-message) at its first field's pointer, else
// at `where`.
std::string StatusEvent(const Status& s, const std::string& where = "");
// The fields a member table's reader listed (RefuseUnknown, ReadNumber) as one status, worded by
// the first.
Status FieldErrors(Status s);

class LiveSpeaker {
 public:
  static constexpr double kLead = 1.0;             // Seconds of audio sent ahead of real time.
  static constexpr size_t kMaxQueuedChars = 8000;  // Text waiting to be spoken (four long says).
  static constexpr double kSegmentSeconds =
      8.0;  // About the longest part of a piece made at once ...
  static constexpr double kMaxSegmentSeconds =
      60.0;  // ... and the most it may make (a word that long is cut).
  static constexpr double kBusyPatience = 30.0;  // Seconds a segment waits for the synthesizer.
  static constexpr double kRefill =
      2.0;  // Seconds made ahead of playing before the next part is made.
  static constexpr size_t kMaxHeldBytes = size_t{64}
                                          << 20;  // Speech made and unsent, every session together.

  LiveSpeaker() = default;
  ~LiveSpeaker();
  LiveSpeaker(const LiveSpeaker&) = delete;
  LiveSpeaker& operator=(const LiveSpeaker&) = delete;

  void Attach(net::LivePost post) { post_ = std::move(post); }
  // Queues a piece (checked: text, voice, rate); errors name the field under /say.
  Status Say(std::string text, std::string voice, int rate);
  // Ends what is being said and drops what waits; false when nothing was.
  bool Stop();
  // For the session's end: stops, and joins the speaking thread; no more speech after.
  void Close();
  // CPU-seconds the speaking thread spent since last asked (synthesis and sending).
  double TakeCpu() { return static_cast<double>(cpu_ns_.exchange(0)) * 1e-9; }

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
  void SendWhile(Utterance& u, bool all_made, const std::stop_token& halt,
                 const std::function<bool()>& more);
  bool SpeakSegment(Utterance& u, const Piece& piece, std::string_view text,
                    const std::stop_token& halt);
  void Charge();  // The speaking thread's CPU since the last call, into cpu_ns_.
  void Post(const std::string& text) { post_(net::ws::Opcode::kText, text); }

  net::LivePost post_;
  std::mutex mu_;
  std::condition_variable_any cv_;
  std::deque<Piece> queue_;
  size_t queued_chars_ = 0;
  bool speaking_ = false, closed_ = false;
  std::stop_source utterance_;  // The piece being spoken (Stop fires it).
  std::jthread thread_;
  // The session's audio clock (the speaker thread's): seconds of audio sent so far, and where real
  // time stood when the audio now playing began.
  double clock_ = 0;
  uint32_t chunk_ = 0;
  double cpu_mark_ = 0;  // The speaking thread's CPU clock at the last Charge.
  std::atomic<int64_t> cpu_ns_{0};
};

}  // namespace facespace::http
