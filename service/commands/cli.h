// The facespace command line: info, blend (and serve, in server.cpp).
#pragma once

#include <string>
#include <vector>

#include "facespace/engine/blend.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace::cli {

// Reads a whole file; false when it cannot.
bool ReadFile(const std::string& path, std::string& out);
// Writes `data` to `path` atomically (a temporary file beside it, then rename), or to stdout for
// "-".
bool WriteOutput(const std::string& path, const std::string& data);
// The exit code of writing an export's result to `path`: 1 with the error on stderr when the
// export failed or the file cannot be written, else 0.
int WriteResult(const std::string& path, const Result<std::string>& bytes);

// "a,b,,c" -> {"a", "b", "c"}: the items of a comma-separated flag value, empty ones skipped.
std::vector<std::string> SplitList(const std::string& value);

class Flags;
// --mode and --normals (flags.h), for every command that blends.
void AddBlendOptionFlags(Flags& flags, BlendOptions& options);

// A Status on stderr ("error: ..."), one line per offending field.
void PrintStatus(const Status& s);
// Warnings on stderr ("warning: code: ...").
void PrintWarnings(const std::vector<Warning>& warnings);
// The rig named by positional arguments (a glTF file, or an OBJ sequence), with its error
// or its load warnings on stderr.
Result<Rig> LoadAndReport(const std::vector<std::string>& paths);

// Each returns the process exit code: 0 success, 1 failure (message on stderr), 2 bad usage.
int Info(const std::vector<std::string>& args);
int Blend(const std::vector<std::string>& args);
int Serve(const std::vector<std::string>& args);
// render, or sheet (a contact sheet of several weight vectors) when `sheet` is set.
int Render(const std::vector<std::string>& args, bool sheet);
// Keyframe sequences: sample, bake, reduce.
int Sequence(const std::vector<std::string>& args);
// Lip sync from text or audio: keys, audio, video (sequence.cpp).
int Speak(const std::vector<std::string>& args);
// Projection of a target mesh onto the face space.
int FitCommand(const std::vector<std::string>& args);
// Batch variant generation.
int Batch(const std::vector<std::string>& args);
// Mirror a shape into its left/right counterpart.
int Mirror(const std::vector<std::string>& args);
// Shape-basis compression and quantisation report.
int Compress(const std::vector<std::string>& args);
// Any rig (glTF, OBJ sequence, MakeHuman folder) to a .glb with sparse targets and its manifest.
int Convert(const std::vector<std::string>& args);
// A source rig's shapes transferred onto a head without them (derive.cpp).
int Derive(const std::vector<std::string>& args);
int Capture(const std::vector<std::string>& args);

}  // namespace facespace::cli
