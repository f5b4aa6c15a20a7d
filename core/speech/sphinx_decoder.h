// What the batch recognizer (sphinx.cpp) and the live one (live_sphinx.cpp) share: the decoder's
// set-up and a segment's phoneme. Private to core/speech.
#pragma once

#include <pocketsphinx.h>
#include <sphinxbase/cmn.h>
#include <sphinxbase/feat.h>

#include <string>
#include <vector>

#include "facespace/engine/speech.h"

#ifndef FACESPACE_SPHINX_MODEL
#define FACESPACE_SPHINX_MODEL "/usr/share/pocketsphinx/model/en-us"
#endif

namespace facespace::speech {

// PocketSphinx's all-phone search over US English (context-independent, backtrace on), or null when
// its model is missing. PocketSphinx and sphinxbase are not thread-safe where a decoder is made or
// freed: ps_init reads the model's files through process-wide state (sphinxbase's log file, which a
// decoder's -logfn reopened and closed under another decoder's feet: two live listeners opening at
// once crashed the process in fclose, or deadlocked in fopen). Both go through one process-wide
// lock, and sphinxbase's logging is turned off once, before the first decoder, instead of per
// decoder. A decoder made is then its owner's alone (one thread at a time).
ps_decoder_t* NewAllPhoneDecoder();
void FreeDecoder(ps_decoder_t* ps);

// PocketSphinx's cepstral mean normalisation carries each utterance's means into the next: the same
// WAV's phonemes came 120 ms earlier on every request after a process's first. The means as the
// decoder made them, read once, and set back before each recognition, so that every one starts
// where the first did.
std::vector<float> CepstralMeans(ps_decoder_t* ps);
void SetCepstralMeans(ps_decoder_t* ps, const std::vector<float>& means);

// Whether the voice detector heard a voice over most of frames sf..ef, `active` starting at frame
// `first`.
bool Heard(const std::vector<bool>& active, int first, int sf, int ef);

// A decoder's segment as a phoneme: "(2)" variants and fillers cut, SIL where the voice detector
// heard no voice over most of it (`heard` false), silences next to each other merged.
void AppendSegment(std::vector<TimedPhoneme>& out, std::string name, float start, float end,
                   bool heard);

}  // namespace facespace::speech
