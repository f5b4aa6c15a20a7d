// What a request will cost, said before the work (issue 48): every route that does work estimates
// its CPU-seconds from the request as parsed (frames x pixels x samples, keys, audio seconds,
// words, cells) and one admission step compares the estimate with what the caller may spend:
// --anonymous-cpu without the API key, --keyed-cpu with it. Over it: 422 over-budget naming the
// member that drives the cost and both figures, before any work. Every answer carries the estimate:
// `Facespace-Cost: 0.42` (seconds).
//
// The figures are this machine's kind of core (2 cores, llvmpipe), measured with the routes'
// Server-Timing and /proc CPU (tests/bench/README.md, "Bounded by design"): an estimate, not a
// meter; the deadline (--request-deadline) and cancellation bound what an estimate gets wrong.
#pragma once

#include <httplib.h>

#include <string>

#include "context.h"

namespace facespace::http {

struct Cost {
  double seconds = 0;  // Estimated CPU-seconds.
  std::string
      field;  // The member that drives it, as a JSON Pointer ("/fps") or "?width" for a query.
  std::string formula;  // How it was reckoned, for people: "7,080 frames x 18.7 M samples".
};

// What a route whose work does not grow with its request says it costs (a lookup, a listing, a
// cached body).
inline constexpr char kConstantCost[] = "0.0001";

// Per unit of work, in CPU-seconds.
inline constexpr double kPerRequest = 5e-5;  // Parsing, routing, a small answer.
inline constexpr double kPerSample = 36e-9;  // One rendered sample (pixels x supersample squared).
inline constexpr double kPerImage = 1e-3;    // One image's set-up and encode.
inline constexpr double kPerVideoPixel =
    15e-9;  // VP9's real-time encode, per output pixel a frame.
inline constexpr double kPerPhysicsBody = 6e-6;  // One rigid body's step (60 a second of sequence).
inline constexpr double kSynthPerSecond =
    0.002;  // espeak-ng, per second of speech (13 ms for 9 s).
inline constexpr double kDecodePerSecond =
    0.08;  // PocketSphinx, per second of audio at 16 kHz (0.66 s for 9 s).
inline constexpr double kPerInputSample = 1e-7;  // Resampling and voice detection, per sample sent.
inline constexpr double kPerUploadByte = 1e-7;   // Reading a rig file.
inline constexpr double kDerivePerVertex = 4e-5;       // Registering, per vertex of either mesh.
inline constexpr double kDerivePerShapeVertex = 1e-6;  // Transferring one shape, per target vertex.
inline constexpr double kCapturePerFrame =
    5e-4;  // A frame's solve, per 52 shapes (FaceCap: 0.34 ms).
// The landmarks' registration onto a rig: FaceCap's (4,368 vertices) 0.25 s, MakeHuman's (46,779)
// 0.2 s, Uka's (49,955, refused as a poor fit) 0.36 s.
inline constexpr double kCaptureRegister = 0.3;
inline constexpr double kCapturePerVertex = 1e-5;
inline constexpr double kPerMovedVertex =
    3e-9;  // One weighted shape's moved vertex added into the blend.

// One frame of `rig`: its blend (and skinning, when skinned) and the frame's encoding.
double FrameSeconds(const Rig& rig);
// One image of `o` of a rig with `triangles`.
double ImageSeconds(const picture::RenderOptions& o, const Rig& rig);

// The blend's additions for `weighted` shapes: each moves at most the rig's largest shape's
// vertices, all of them together at most every shape's (a dense 1,000-shape rig was priced 200
// times low by its vertices alone).
double BlendSeconds(const Rig& rig, size_t weighted);
// One blend of `weighted` shapes (SIZE_MAX: any, as a live session may) in `format`; a VRM writes
// the whole rig and draws its thumbnail.
Cost MeshCost(const Rig& rig, std::optional<formats::MeshFormat> format, size_t weighted);
// The shapes a mesh request weights, for MeshCost: its non-zero weights, every shape when controls
// drive them.
size_t WeightedShapes(const evaluator::MeshRequest& r);
// An image's encode, per output pixel, in `format` (measured at 2048², issue 61: EXR and TIFF 90-95
// ns, WebP 20, JPEG 7, PNG 4).
double EncodeSeconds(picture::ImageFormat format, double pixels);
Cost RenderCost(const Rig& rig, const picture::RenderOptions& o, bool query,
                picture::ImageFormat format);
Cost SheetCost(const Rig& rig, const picture::RenderOptions& o, size_t cells,
               picture::ImageFormat format);
// `frames` frames of a sequence lasting `seconds` (physics steps at 60 a second when the rig has
// bodies).
Cost FramesCost(const Rig& rig, size_t frames, double seconds, bool meshes, const char* field);
Cost ReduceCost(const Rig& rig, size_t keys);
Cost FitCost(const Rig& rig, const evaluator::FitRequest& r);
// Speech: synthesis of `seconds` of speech, or recognition of `seconds` of audio sent at `rate`;
// then the frames (a stream), or the video's frames at the request's size.
Cost SpeechCost(const Rig& rig, const evaluator::SpeechRequest& r, double seconds, int rate);
Cost UploadCost(size_t bytes);
// A derive of `shapes` shapes from `source` onto `target` (the job's, charged when it is asked
// for): the registration grows with both meshes, the transfer with the target's vertices a shape.
Cost DeriveCost(const Rig& target, const Rig& source, size_t shapes);
// A capture of `frames` on `rig`: its landmarks' registration unless `registered`, then the frames.
Cost CaptureCost(const Rig& rig, size_t frames, bool registered);

// The admission step: sets Facespace-Cost; true when the cost is within what the caller may spend,
// else false with 422 over-budget sent (the field, the estimate, the budget, and what to do).
bool WithinBudget(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                  const Cost& cost);

}  // namespace facespace::http
