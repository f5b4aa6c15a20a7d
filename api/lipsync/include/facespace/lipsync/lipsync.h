// Lip sync: a speech request (text that espeak-ng speaks, or audio PocketSphinx hears) to the plan
// that says it on a rig (phonemes, visemes, the keys of a sequence), its JSON, and its video.
// Composed around the evaluator (api/evaluator), with the speech and video libraries the evaluator
// does not link.
#pragma once

#include <functional>
#include <memory>
#include <stop_token>
#include <string>
#include <vector>

#include "facespace/engine/speech.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/speech/speech.h"

namespace facespace::lipsync {

// What a speech request comes to: the audio (spoken by espeak-ng, or the one sent), its phonemes
// and visemes, and the sequence whose keys speak them over the face the request gives (its weights,
// expressions and controls), with its gaze track and blinks.
struct SpeechPlan {
  speech::Audio audio;
  std::vector<TimedPhoneme> phonemes;
  std::vector<TimedViseme> visemes;
  Sequence sequence;
  std::vector<Warning>
      warnings;  // The face's and the recognizer's; the sequence's own are in sequence.warnings.
  std::string voice;            // espeak-ng's voice, or "" for audio sent.
  std::string source;           // "espeak-ng", "pocketsphinx" or "pocketsphinx-aligned".
  float voiced_seconds = 0.0f;  // Audio sent: how much of it the voice detector took as speech.
};
// Errors: the rig cannot speak (FailedPrecondition, reason no-mouth); the text, voice, rate or
// audio (InvalidArgument or ResourceExhausted naming the field); the face (as ResolvePoint's).
Result<SpeechPlan> PlanSpeech(const Rig& rig, const evaluator::SpeechRequest& request,
                              const std::stop_token& stop = {});

// Everything the plan warns of: the face's and the recognizer's, then the sequence's (said once).
std::vector<Warning> SpeechWarnings(const SpeechPlan& plan);

// The speech route's JSON answer and `facespace speak -o X.json` (evaluator/answers.h: Speech):
// source, voice, duration, fps, frames, phonemes, visemes, keys (as sequence requests take them),
// transition, warnings, and with `with_audio` audio_wav, the WAV as base64.
std::string SpeechJson(const Rig& rig, const SpeechPlan& plan, float fps, bool with_audio = false);
// One viseme as the speech answer lists it and the live socket sends it: {viseme, start, end},
// its times moved by `clock` seconds.
std::string TimedVisemeJson(const TimedViseme& v, double clock);

// The plan's sequence rendered at `fps` (request.render's size, camera and view) with its audio, as
// a WebM file (VP9 + Opus, render/video.h): the frame at time i / fps shows the face the audio is
// saying at that time. Frames are drawn one after the other in `ws`; `on_frame` (may be empty)
// hears each one's number, for progress. Errors: the size (422 at /width or /height), the
// renderer's.
Result<std::string> SpeechVideo(const evaluator::Evaluator& evaluator,
                                const std::shared_ptr<const evaluator::StoredRig>& rig,
                                const SpeechPlan& plan, const evaluator::SpeechRequest& request,
                                evaluator::Workspace& ws,
                                const std::function<void(size_t)>& on_frame = {});

}  // namespace facespace::lipsync
