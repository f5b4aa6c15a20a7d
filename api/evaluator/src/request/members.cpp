// The request bodies' members (members.h), in groups several bodies share.
#include "facespace/evaluator/members.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <vector>

#include "facespace/engine/rig.h"
#include "facespace/engine/speech.h"
#include "facespace/engine/weights.h"
#include "facespace/formats/lod.h"

namespace facespace::evaluator {

namespace {

constexpr char kMeshFormats[] = "glb|obj|json|f32|vrm|vrm0";
constexpr char kImageFormats[] = "png|jpeg|exr|tiff|webp";
constexpr char kClipRef[] = "#ClipRef";
constexpr char kByName[] = R"({"type": "object", "additionalProperties": {"type": "number"}})";
constexpr char kNumbers3[] =
    R"({"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3})";
constexpr char kNames[] = R"({"type": "array", "items": {"type": "string"}})";
constexpr char kIntervals[] =
    R"({"type": "object", "additionalProperties": false, "properties": {)"
    R"("yaw": {"$ref": "#/components/schemas/Interval"}, "pitch": {"$ref": "#/components/schemas/Interval"},)"
    R"("zoom": {"$ref": "#/components/schemas/Interval"}, "exposure": {"$ref": "#/components/schemas/Interval"}}})";

// ---- a point of face space ----
constexpr Member kPoint[] = {
    Schema("weights",
           "Shape weights: dense in shape order, or by shape name, alias or index; shapes not "
           "given are 0",
           "#Weights")
        .Example(R"({"jawOpen": 0.5, "eyeBlinkLeft": 1})"),
    Schema("controls",
           "Control values by name (the rig route lists controls): a two-sided control v < 0 "
           "drives its negative "
           "shape with -v, v > 0 its positive shape",
           kByName),
    Schema("expressions",
           "Expressions by name: VRM 1.0's presets (happy, angry, sad, relaxed, surprised, aa, ih, "
           "ou, ee, oh, "
           "blink, blinkLeft, blinkRight, lookUp, lookDown, lookLeft, lookRight, neutral) or the "
           "rig's own, each a value in "
           "[0, 1] added to the weights of the shapes it maps, with VRM's override rules; a preset "
           "the rig does not map warns "
           "expression_unmapped",
           kByName)
        .Example(R"({"happy": 0.8})"),
    Schema("gaze", "Where the eyes look", "#Gaze").Example(R"({"yaw": 10, "pitch": -5})"),
    String("vocabulary",
           "What the weights' names are: arkit (ARKit's 52, either spelling), vrm (VRM 1.0's "
           "presets), mmd (MMD's standard morphs: あ, まばたき, ...) or another rig's id (its "
           "shapes). This rig's own weights that best reproduce them are solved (bounded least "
           "squares in ARKit's 52 shapes, the space the vocabularies share); what this rig cannot "
           "show warns vocabulary_unexpressed. Default: this rig's own names",
           "^[a-z0-9][a-z0-9_-]{0,63}$")
        .Example(R"("mmd")"),
    Choice("mode", "relative: base + sum w d; absolute: sum w S, the weights summing to 1",
           "relative|absolute")
        .Default(R"("relative")"),
    Choice("normals", "Blend the shapes' normals, or recompute them from the blended positions",
           "blend|recompute")
        .Default(R"("blend")"),
    Boolean("strict", "Refuse (422) a point with warnings instead of answering with them")
        .Default("false"),
};
constexpr Member kSkeleton[] = {
    Schema("pose", "Joint name -> local transform parts that replace the rest values", "#Pose")
        .Example(R"({"Head": {"euler": [0, 20, 0]}})"),
    Schema("animation", "A clip by name or index, posed at time", kClipRef),
    Schema("motion", "A clip by MMD's word (a .vmd motion): as animation", kClipRef),
    Number("time", "Seconds into the animation").Default("0"),
    Number("frame", "The time in MMD frames, 30 a second (instead of time)"),
    Boolean("loop", "Wrap time into the clip's length").Default("false"),
    Schema("blend", "Several clips at their times and weights (instead of animation)", "#Blend"),
    Schema("layers",
           "Motions stacked: the first the base, each later one an overlay replacing, by its "
           "weight, only the "
           "joints and shapes its clip moves",
           "#Layers"),
    Choice("skinning", "Linear blend skinning or dual quaternions", "linear|dual_quaternion")
        .Default(R"("linear")"),
    Integer("lod",
            "Level of detail: 0 full, L about 1/2^L of the triangles (a subset of the vertices)", 0,
            formats::kMaxLod)
        .Default("0"),
};
constexpr Member kMeshOnly[] = {
    Choice("format", "The mesh's encoding; absent: from Accept, else json", kMeshFormats)
        .Example(R"("glb")"),
    Choice("space",
           "json, obj, f32: world space (each primitive placed by its node, dequantized) or each "
           "mesh's own",
           "world|mesh")
        .Default(R"("world")"),
    Boolean("keep_targets", "glb: keep the morph targets, with the blend as the mesh's weights")
        .Default("false"),
};

// ---- an image ----
constexpr Member kImage[] = {
    Integer("width", "Pixels", 1, 1 << 20).Default("512").Example("256"),
    Integer("height", "Pixels", 1, 1 << 20).Default("512").Example("256"),
    Choice("view", "How the mesh is drawn", "shaded|wireframe|heatmap|normals|clay")
        .Default(R"("shaded")"),
    Schema("background", "#rrggbb, #rrggbbaa, transparent, or [r, g, b(, a)] in 0..1", "#Colour"),
    Integer("supersample", "Samples a pixel along each axis; absent: as the size allows", 1, 4),
    Integer("quality", "jpeg and webp", 1, 100).Default("90"),
    Schema("camera", "Where the camera stands: an orbit, or a look-at camera", "#Camera")
        .Example(R"({"yaw": 20, "zoom": 1.2})"),
    Number("exposure", "Stops of light before tone mapping (+1: twice the light)", -10, 10)
        .Default("0"),
    Schema("light", "The studio's lights turned about the camera", "#Light"),
};
constexpr Member kImageFormat[] = {
    Choice("format", "The image's encoding; absent: from Accept, else png", kImageFormats)
        .Example(R"("png")"),
};
constexpr Member kSheetOnly[] = {
    Schema(
        "cells",
        "The cells, each a point and a label; or \"shapes\" (\"shapes:GROUP\"): one cell per shape "
        "at 1",
        R"({"oneOf": [{"type": "array", "minItems": 1, "items": {"$ref": "#/components/schemas/Cell"}},)"
        R"({"type": "string", "pattern": "^shapes(:.+)?$"}]})")
        .Example(
            R"([{"weights": {"jawOpen": 1}, "label": "open"}, {"weights": {}, "label": "rest"}])")
        .Required(),
    Integer("columns", "Cells a row; absent: about square", 1, 64),
};

// ---- sequences ----
constexpr Member kSequence[] = {
    Schema("keys", "Keys at times: weights (or a shape at 1) and the transition into the next",
           R"({"type": "array", "items": {"$ref": "#/components/schemas/Key"}})")
        .Example(R"([{"time": 0, "weights": {}}, {"time": 1, "weights": {"jawOpen": 1}}])"),
    Schema("times", "The times to sample (sample)",
           R"({"type": "array", "items": {"type": "number"}})")
        .Example("[0, 0.5, 1]"),
    Number("fps", "Frames a second (stream; sample without times)"),
    Schema("animation", "A clip played instead of keys", kClipRef),
    Schema("motion", "A clip by MMD's word: as animation", kClipRef),
    Schema("layers", "Motions stacked, as on the mesh route", "#Layers"),
    String("transition",
           "step, linear, smoothstep, smootherstep, ease-in, ease-out, ease-in-out, "
           "cubic-bezier(x1, y1, x2, y2)")
        .Default(R"("linear")"),
    Boolean("smooth", "Catmull-Rom through the keys").Default("false"),
    Schema(
        "gaze", "One gaze held, or a track of gaze keys",
        R"({"oneOf": [{"$ref": "#/components/schemas/Gaze"}, {"$ref": "#/components/schemas/GazeTrack"}]})"),
    Schema("blink", "Natural blinks through the rig's blink expression", "#Blink"),
    Boolean("physics",
            "Simulate the rig's rigid bodies (MMD hair, ears, skirts) over a sequence that plays a "
            "motion or "
            "layers; false: they follow their bones")
        .Default("true"),
    Choice("format",
           "sample: json (each frame's mesh) or weights (each frame's weights, sum and pose); "
           "stream: ndjson "
           "(= weights) or f32",
           "json|weights|ndjson|f32"),
    Number("tolerance", "reduce: the largest vertex error allowed, scene units", 0),
    Choice("mode", "As on the mesh route", "relative|absolute").Default(R"("relative")"),
    Choice("normals", "As on the mesh route", "blend|recompute").Default(R"("blend")"),
};

// ---- batches ----
constexpr Member kBatchOnly[] = {
    Schema("variants", "The points, listed (exactly one of variants or sample)",
           R"({"type": "array", "minItems": 1, "items": {"$ref": "#/components/schemas/Variant"}})")
        .Example(
            R"([{"id": "open", "weights": {"jawOpen": 1}}, {"id": "smile", "weights": {"mouthSmileLeft": 1}}])"),
    Schema("sample", "The points, sampled (exactly one of variants or sample)", "#Sample"),
    Choice("format", "Each variant's file: a mesh, or an image drawn with the image settings",
           "glb|obj|json|f32|vrm|vrm0|png|jpeg|exr|tiff|webp")
        .Default(R"("glb")"),
    Choice("space", "As on the mesh route", "world|mesh").Default(R"("world")"),
    Schema(
        "labels",
        "Images: each variant a training sample with KEY.depth.exr, KEY.normals.exr, KEY.seg.png "
        "and KEY.json "
        "(camera K and world_to_camera, landmarks, the point)",
        R"({"type": "array", "items": {"enum": ["depth", "normals", "segmentation", "landmarks"]}})"),
    Choice("archive", "Files in a folder, or WebDataset tar shards", "folder|tar")
        .Default(R"("folder")"),
    Integer("shard_samples", "archive tar: samples a shard", 1, 1000000).Default("1000"),
    Schema("randomize", "What varies per sample", "#Randomize"),
};
// The batch takes the point's members but weights and strict (its points are the variants), and
// the mesh's but keep_targets.
constexpr std::string_view kNotInBatch[] = {"weights", "strict", "keep_targets",
                                            "format",  "space",  "vocabulary"};

// ---- capture: a tracker's landmarks ----
constexpr Member kCapture[] = {
    Choice("scheme",
           "The landmarks' tracker: MediaPipe's face mesh, 468 points, or 478 with the irises "
           "(whose last 10 are not used yet)",
           "mediapipe-478|mediapipe-468")
        .Default(R"("mediapipe-478")"),
    Schema("image", "The image's [width, height] in pixels (the points' frame)",
           R"({"type": "array", "items": {"type": "integer", "minimum": 1, "maximum": 16384}, )"
           R"("minItems": 2, "maxItems": 2})")
        .Required()
        .Example("[640, 480]"),
    Number("fps", "Frames a second (the keys' times, and the smoothing's)", 1, 240).Default("30"),
    Schema("frames",
           "Per frame the tracker's points, [x, y, z] each: x, y in the image's pixels (y down), "
           "z in x's scale (smaller nearer), as MediaPipe's normalized values times the image size",
           R"({"type": "array", "minItems": 1, "items": {"type": "array", "minItems": 468, )"
           R"("maxItems": 478, "items": {"type": "array", "items": {"type": "number"}, )"
           R"("minItems": 3, "maxItems": 3}}})")
        .Required(),
    Integer("neutral",
            "The frame in which the performer's face rests: their face is not the rig's, and "
            "what differs there is not an expression",
            0, 100000)
        .Default("0"),
};

// ---- fitting and speech ----
constexpr Member kDerive[] = {
    String("from", "The source rig (its id in the store), whose shapes are transferred",
           "^[a-z0-9][a-z0-9_-]{0,63}$")
        .Default(R"("facecap")"),
    String("as",
           "The rig to write (its id): a new rig, or this one's id to add the shapes to it; "
           "default this rig",
           "^[a-z0-9][a-z0-9_-]{0,63}$")
        .Example(R"("myhead-arkit")"),
    Schema("shapes",
           "Which of the source's shapes: arkit (its ARKit-named ones), visemes (the 15 baked as "
           "viseme_*); default all of the source's shapes and the visemes",
           R"({"type": "array", "items": {"enum": ["arkit", "visemes"]}, "maxItems": 2})")
        .Example(R"(["arkit", "visemes"])"),
    Schema("landmarks",
           "Points on this rig's face named as the source's landmarks (its manifest's): vertex in "
           "the file's own numbering or a position; any subset; default the heads' own shape",
           "#Landmarks"),
};
constexpr Member kFit[] = {
    Schema("target", "The mesh to reproduce, as the mesh route's JSON", "#MeshJson"),
    Schema("primitives", "Instead of target: the mesh route's JSON as it is",
           R"({"type": "array", "items": {"type": "object", "additionalProperties": true}})"),
    Choice("space", "With primitives: as the mesh route's JSON", "world|mesh"),
    Schema("warnings", "With primitives: the mesh route's warnings, ignored",
           R"({"type": "array", "items": {"$ref": "#/components/schemas/Warning"}})"),
    Boolean("bounded", "Keep each weight in its shape's range").Default("true"),
    Boolean("sum_at_most_one", "Keep the sum of weights at most 1").Default("false"),
    Boolean("rigid_align", "Align the target rigidly first (a scan in another pose)")
        .Default("false"),
};
constexpr Member kSpeechOnly[] = {
    String("text", "Words to say (espeak-ng); or audio").Example(R"("Hello there")"),
    String("audio", "A WAV file (at most 60 s) to lip-sync, as base64"),
    String("transcript", "With audio: the words said, to align to"),
    String("voice", "An espeak-ng voice (GET /v1/voices)").Default(R"("en-us")"),  // kDefaultVoice
    Integer("rate", "Words a minute", 80, 450).Default("175"),
    Number("fps", "Frames a second of the keys and streams", 1, 120).Default("30"),
    Number("strength", "Scales the visemes (1: as mapped)", 0, 2).Default("1"),
    Choice("format",
           "json: phonemes, visemes and keys; ndjson, weights, f32: frames streamed; wav; webm",
           "json|ndjson|f32|weights|wav|webm")
        .Default(R"("json")"),
    Boolean("with_audio", "json: the audio too, as audio_wav (base64 WAV)").Default("false"),
    Schema("blink", "Natural blinks through the rig's blink expression", "#Blink"),
};
static_assert(std::string_view(kDefaultVoice) == "en-us",
              "the speech table's voice default is kDefaultVoice");
// The speech body's face and picture: these of the point's and the image's members.
constexpr std::string_view kSpeechFace[] = {
    "weights", "expressions", "controls", "mode",       "normals",     "vocabulary", "width",
    "height",  "camera",      "view",     "background", "supersample", "exposure"};

// ---- nested objects ----
constexpr Member kCamera[] = {
    Number("yaw", "Degrees around the vertical axis; 0 looks at the front", -3600, 3600)
        .Default("0"),
    Number("pitch", "Degrees up (positive) or down", -3600, 3600).Default("0"),
    Number("distance", "From the framed centre, scene units; 0 fits the framed part", 0, 1e9)
        .Default("0"),
    Number("zoom", "Divides the distance", 0.01, 100).Default("1"),
    Number("fov", "Vertical field of view, degrees", 1, 170).Default("30"),
    String("frame",
           "Orbit around every vertex (of the rest shape unless posed: still while weights "
           "change), around those "
           "the shapes move, around those a joint carries (joint:NAME), or (auto) around the "
           "shapes' when they are a small "
           "part of the rig, else every vertex",
           "^(all|shapes|auto|joint:.+)$")
        .Default(R"("auto")"),
    Schema("eye", "Look-at camera: where it stands (with target)", kNumbers3),
    Schema("target", "Look-at camera: what it looks at", kNumbers3),
    Schema("up", "Look-at camera: the up direction", kNumbers3).Default("[0, 1, 0]"),
};
constexpr Member kLight[] = {
    Number("yaw", "Degrees, to the right", -3600, 3600).Default("0"),
    Number("pitch", "Degrees, up", -3600, 3600).Default("0"),
};
constexpr Member kGaze[] = {
    Schema("target", "A point of the rig's world the eyes look at", kNumbers3),
    Number("yaw", "Degrees, > 0 to the character's left", -180, 180),
    Number("pitch", "Degrees, > 0 up", -180, 180),
};
constexpr Member kGazeTrack[] = {
    Schema("keys", "Gaze keys: linear between them, held past the ends",
           R"({"type": "array", "items": {"$ref": "#/components/schemas/GazeKey"}})")
        .Required(),
};
constexpr Member kGazeKey[] = {
    Number("time", "Seconds").Required(),
    Schema("target", "As in a gaze", kNumbers3),
    Number("yaw", "As in a gaze", -180, 180),
    Number("pitch", "As in a gaze", -180, 180),
};
constexpr Member kBlink[] = {
    Number("per_minute", "Blinks a minute: one at a random moment of each 60 / per_minute seconds",
           0, 60)
        .Default("15"),
    Integer("seed", "The same seed gives the same blinks", 0, 1.8446744073709552e19).Default("1"),
};
constexpr Member kJoint[] = {
    Schema("rotation", "A quaternion [x, y, z, w]",
           R"({"type": "array", "items": {"type": "number"}, "minItems": 4, "maxItems": 4})"),
    Schema("euler", "Degrees about x, y, z (instead of rotation)", kNumbers3),
    Schema("translation", "Scene units", kNumbers3),
    Schema("scale", "Factors", kNumbers3),
};
constexpr Member kBlendClip[] = {
    Schema("animation", "The clip", kClipRef).Required(),
    Number("time", "Seconds into it").Default("0"),
    Number("weight", "Its share of the blend").Default("1"),
    Boolean("loop", "Wrap time into its length").Default("false"),
    Schema("mask", "Only these joints", kNames),
};
constexpr Member kLayer[] = {
    Schema("motion", "The clip (or animation)", kClipRef),
    Schema("animation", "The clip (or motion)", kClipRef),
    Number("time", "Seconds into it").Default("0"),
    Number("frame", "MMD frames into it (instead of time)"),
    Number("weight", "How much of it replaces what is below", 0).Default("1"),
    Boolean("loop", "Wrap time into its length").Default("false"),
    Number("fade_in", "Seconds its weight takes to rise", 0).Default("0"),
    Number("fade_out", "Seconds its weight takes to fall at its end", 0).Default("0"),
    Schema("mask", "Only these joints", kNames),
};
constexpr Member kKey[] = {
    Number("time", "Seconds").Required(),
    Schema("weights", "The point at this key", "#Weights"),
    String("shape", "Instead of weights: this shape at 1"),
    Schema("expressions", "Expressions at this key", kByName),
    String("transition", "Into the next key (as the sequence's transition)"),
};
constexpr Member kCell[] = {
    Schema("weights", "The cell's point", "#Weights"),
    String("label", "Drawn under the cell (80 characters at most)"),
};
constexpr Member kVariant[] = {
    String("id", "Names the variant's files", "^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$"),
    Schema("weights", "The variant's point", "#Weights").Required(),
};
constexpr Member kSample[] = {
    Choice("method", "uniform, gaussian, grid (every combination), convex (of points)",
           "uniform|gaussian|grid|convex")
        .Required(),
    Integer("count", "Samples", 1, 1e9),
    Integer("seed", "The same seed, the same samples", 0, 1.8446744073709552e19),
    Schema("shapes", "The shapes that vary; absent: all", kNames),
    Schema("fixed", "Weights every sample keeps", kByName),
    Schema("center", "gaussian: the mean", kByName),
    Number("spread", "gaussian: the standard deviation", 0),
    Schema("points", "convex: the corners",
           R"({"type": "array", "items": )"
           R"({"type": "object", "additionalProperties": {"type": "number"}})"
           R"(, "minItems": 2, "maxItems": 3})"),
    Integer("active", "Shapes non-zero in a sample; 0: all", 0, 1e9),
    Boolean("symmetric", "Left and right partners get the same weight"),
    Boolean("sum_at_most_one", "Scale a sample whose weights sum over 1"),
};
constexpr Member kRandomize[] = {
    Integer("seed", "The stream of draws", 0, 1.8446744073709552e19),
    Schema("camera", "yaw, pitch, zoom intervals", kIntervals),
    Schema("light", "yaw, pitch, exposure intervals", kIntervals),
    Schema("gaze", "yaw, pitch intervals", kIntervals),
    Schema(
        "background",
        "A random colour, or one of these colours; `facespace batch` also takes {\"images\": "
        "FOLDER}",
        R"({"oneOf": [{"const": "random"}, {"type": "array", "items": {"type": "string"}, "minItems": 1}]})"),
    Schema(
        "expressions", "Name -> [lo, hi] strengths",
        R"({"type": "object", "additionalProperties": {"$ref": "#/components/schemas/Interval"}})"),
};

// ---- the live socket's text messages ----
constexpr Member kLive[] = {
    Schema("weights", "Shape weights merged into the face (a name's null: back to 0)", kByName)
        .Example(R"({"jawOpen": 0.5})"),
    Schema("expressions", "Expressions merged into the face, as weights", kByName),
    Schema("controls", "Control values merged into the face, as weights", kByName),
    Schema("gaze", "Where the eyes look", "#Gaze"),
    Schema("pose", "The pose, replacing the last one", "#Pose"),
    String("vocabulary",
           "What the weights' names are, as the mesh body's vocabulary (arkit, vrm, mmd or a rig's "
           "id), kept for later messages; a change of vocabulary starts the weights over",
           "^[a-z0-9][a-z0-9_-]{0,63}$")
        .Example(R"("arkit")"),
    Schema("landmarks",
           "A face tracker's frame (alone in its message, with an id at most): {\"scheme\": "
           "\"mediapipe-478\", \"image\": [w, h], \"points\": [[x, y, z], ...] (468 or 478, "
           "in the image's pixels), \"neutral\": true (this frame is the performer at rest; "
           "the first one is)}; the solved weights replace the face's, answered by a frame and "
           "a weights event",
           R"({"type": "object", "required": ["points"], "properties": {"scheme": {"enum": )"
           R"(["mediapipe-478", "mediapipe-468"]}, "image": {"type": "array", "items": )"
           R"({"type": "integer"}, "minItems": 2, "maxItems": 2}, "points": {"type": "array", )"
           R"("minItems": 468, "maxItems": 478, "items": {"type": "array", "items": {"type": )"
           R"("number"}, "minItems": 3, "maxItems": 3}}, "neutral": {"type": "boolean"}}})"),
    Integer("id", "Echoed in the frames and warnings that show this message", 0, 4294967295.0),
    Schema("say", "Speak a text on the face (alone in its message)", "#LiveSay"),
    Boolean("stop", "true: end the speech (alone in its message)"),
    Schema("listen",
           "Hear 16 kHz 16-bit mono PCM sent as binary messages, lip-synced (alone in its "
           "message); false ends it",
           R"({"oneOf": [{"$ref": "#/components/schemas/LiveListen"}, {"const": false}]})"),
    Schema("frames",
           "What the binary frames carry from the next one (alone in its message): f32 (the "
           "default), weights or delta",
           "#LiveFrames")
        .Example(R"({"kind": "delta"})"),
    Schema("vmc",
           "Send each frame's face to a VMC receiver (VSeeFace, Warudo...): ARKit's 52 and VRM "
           "0.x's presets as /VMC/Ext/Blend/Val, then Apply (alone in its message; at most 4 "
           "receivers); false stops sending",
           R"({"oneOf": [{"$ref": "#/components/schemas/LiveVmc"}, {"const": false}]})")
        .Example(R"({"port": 39539})"),
    Schema("listen_vmc",
           "Let a VMC sender drive the face: its blends (ARKit names, else VRM presets) at each "
           "Apply, through the vocabulary they name (alone in its message); false closes the port",
           R"({"oneOf": [{"$ref": "#/components/schemas/LiveInlet"}, {"const": false}]})"),
    Schema("listen_ifacialmocap",
           "Let iFacialMocap (an iPhone's ARKit tracking, UDP text) drive the face (alone in its "
           "message); false closes the port",
           R"({"oneOf": [{"$ref": "#/components/schemas/LiveInlet"}, {"const": false}]})")
        .Example(R"({"port": 49983})"),
};
constexpr Member kLiveSay[] = {
    String("text", "What to say").Required(),
    String("voice", "An espeak-ng voice (GET /v1/voices)").Default(R"("en-us")"),
    Integer("rate", "Words a minute", 80, 450).Default("175"),
};
constexpr Member kLiveListen[] = {
    Integer("rate", "Samples a second of the audio sent: 16000 only", 16000, 16000)
        .Default("16000"),
    Boolean("frames", "Send the face's frames as the audio is heard").Default("false"),
};

constexpr Member kLiveFrames[] = {
    Choice("kind",
           "f32: the mesh route's f32 bytes; weights: the shapes' weights and a pose's node "
           "transforms, for a client that blends the rig's glb itself; delta: 16-bit positions, "
           "only what moved, packed by meshoptimizer's vertex codec (a keyframe first, and again "
           "when asked)",
           "f32|weights|delta")
        .Required()
        .Example(R"("delta")"),
};
constexpr Member kLiveVmc[] = {
    Integer("port", "The receiver's UDP port (VMC's own: 39539)", 1, 65535).Required(),
    String("host",
           "The receiver's IPv4 address: this machine, or one the operator allows (serve "
           "--vmc-hosts)")
        .Default(R"("127.0.0.1")"),
};
constexpr Member kLiveInlet[] = {
    Integer("port",
            "The UDP port to listen on: 1024-65535, or 0 for any free one (the start event says "
            "which)",
            0, 65535)
        .Required()
        .Example("49983"),
};

struct Table {
  Body body;
  std::string_view name, doc;
  std::vector<Member> members;
};

// Appends `from` to `to`, but the names in `except`.
void Append(std::vector<Member>& to, std::span<const Member> from,
            std::span<const std::string_view> except = {}) {
  for (const Member& m : from) {
    bool skip = false;
    for (std::string_view e : except) skip = skip || e == m.name;
    if (!skip) to.push_back(m);
  }
}
// Only the names in `only`.
void AppendOnly(std::vector<Member>& to, std::span<const Member> from,
                std::span<const std::string_view> only) {
  for (const Member& m : from) {
    for (std::string_view o : only) {
      if (o == m.name) to.push_back(m);
    }
  }
}
void Override(std::vector<Member>& in, std::string_view name, std::string_view fallback) {
  for (Member& m : in) {
    if (m.name == name) m.fallback = fallback;
  }
}

std::vector<Table> MakeTables() {
  std::vector<Table> t;
  auto add = [&](Body b, std::string_view name, std::string_view doc, auto&&... groups) {
    Table table{b, name, doc, {}};
    (Append(table.members, groups), ...);
    t.push_back(std::move(table));
    return &t.back().members;
  };
  add(Body::kMesh, "MeshRequest", "A point of face space, posed, as a mesh", kPoint, kSkeleton,
      kMeshOnly);
  add(Body::kRender, "RenderRequest", "A point of face space, posed, drawn", kPoint, kSkeleton,
      kImage, kImageFormat);
  {
    std::vector<Member>& sheet = *add(Body::kSheet, "SheetRequest",
                                      "Several points drawn into one labelled grid", kSheetOnly);
    constexpr std::string_view kNoWeights[] = {"weights"};
    Append(sheet, kPoint, kNoWeights);
    Append(sheet, kSkeleton);
    Append(sheet, kImage);
    Override(sheet, "width", "256");
    Override(sheet, "height", "256");
  }
  add(Body::kSequence, "SequenceRequest", "Keys (or a clip) over time", kSequence);
  {
    std::vector<Member>& batch =
        *add(Body::kBatch, "BatchRequest",
             "Many points as files: exactly one of variants or sample", kBatchOnly);
    Append(batch, kPoint, kNotInBatch);
    Append(batch, kSkeleton);
    Append(batch, kImage);
  }
  add(Body::kFit, "FitRequest", "A target mesh to reproduce with the rig's shapes", kFit);
  add(Body::kCapture, "CaptureRequest",
      "A tracker's landmarks over frames, as this rig's weights (the keys of a sequence)",
      kCapture);
  add(Body::kDerive, "DeriveRequest",
      "Another rig's shapes transferred onto this one's neutral, as a job", kDerive);
  {
    std::vector<Member>& speech =
        *add(Body::kSpeech, "SpeechRequest", "Text or recorded speech to lip-sync", kSpeechOnly);
    AppendOnly(speech, kPoint, kSpeechFace);
    AppendOnly(speech, kImage, kSpeechFace);
    constexpr std::string_view kTrack[] = {"gaze"};  // As a sequence's: one gaze held, or a track.
    AppendOnly(speech, kSequence, kTrack);
  }
  add(Body::kCamera, "Camera",
      "Where the camera stands: an orbit (yaw, pitch, distance, zoom) or a look-at camera (eye, "
      "target, up)",
      kCamera);
  add(Body::kLight, "Light", "The studio's lights turned about the camera: yaw, then pitch",
      kLight);
  add(Body::kGaze, "Gaze",
      "Where the eyes look (GET /v1/rigs/{id} says how): a target point of the rig's world, or "
      "angles "
      "from straight ahead. A rig with no eyes warns gaze_unsupported",
      kGaze);
  add(Body::kGazeTrack, "GazeTrack", "A gaze track: linear between its keys, held past its ends",
      kGazeTrack);
  add(Body::kGazeKey, "GazeKey", "One key of a gaze track", kGazeKey);
  add(Body::kBlink, "Blink",
      "Natural blinks: closing fast, opening slower; the same seed gives the same blinks", kBlink);
  add(Body::kJoint, "JointPose", "One joint's local transform parts, replacing its rest values",
      kJoint);
  add(Body::kBlendClip, "BlendClip", "One clip of a blend", kBlendClip);
  add(Body::kLayer, "Layer", "One layer: a clip at its time and weight, fading in and out", kLayer);
  add(Body::kKey, "Key", "One key of a sequence", kKey);
  add(Body::kCell, "Cell", "One cell of a sheet", kCell);
  add(Body::kVariant, "Variant", "One variant of a batch", kVariant);
  add(Body::kSample, "Sample", "How a batch's points are sampled, with a seed", kSample);
  add(Body::kRandomize, "Randomize",
      "What varies per sample, drawn from the sample's own seeded stream: the same seed and "
      "index, the same draw",
      kRandomize);
  add(Body::kLive, "LiveMessage",
      "A text message of the live socket: a change of the face (merged into it), or say, stop or "
      "listen",
      kLive);
  add(Body::kLiveSay, "LiveSay", "Text the live face speaks", kLiveSay);
  add(Body::kLiveListen, "LiveListen", "Audio the live face hears and lip-syncs", kLiveListen);
  add(Body::kLiveFrames, "LiveFrames", "What the live face's binary frames carry", kLiveFrames);
  add(Body::kLiveVmc, "LiveVmc", "A VMC receiver the live face's frames go to", kLiveVmc);
  add(Body::kLiveInlet, "LiveInlet", "A UDP port a face tracking app streams to", kLiveInlet);
  return t;
}

const Table& TableOf(Body body) {
  static const std::vector<Table> tables = MakeTables();
  for (const Table& t : tables) {
    if (t.body == body) return t;
  }
  return tables.front();  // Every Body has a table (members_test checks).
}

}  // namespace

std::span<const Member> Members(Body body) { return TableOf(body).members; }
std::string_view SchemaName(Body body) { return TableOf(body).name; }
std::string_view Describe(Body body) { return TableOf(body).doc; }

const Member* FindMember(Body body, std::string_view name) {
  for (const Member& m : Members(body)) {
    if (m.name == name) return &m;
  }
  return nullptr;
}

void UnknownMember(std::string_view pointer, const std::string& key, Body body, Status& errors) {
  std::vector<std::string_view> names;
  for (const Member& m : Members(body)) names.push_back(m.name);
  std::string message = "unknown member" + DidYouMean(key, names);
  if (message.size() == 14) {
    message += "; the members are";
    for (size_t i = 0; i < names.size(); ++i)
      message += std::string(i ? ", " : " ") + std::string(names[i]);
  }
  errors.fields.push_back({std::string(pointer) + "/" + JsonPointerEscape(key), message});
}

void RefuseUnknown(const nlohmann::json& v, std::string_view pointer, Body body, Status& errors) {
  if (!v.is_object()) return;
  for (auto it = v.begin(); it != v.end(); ++it) {
    if (!FindMember(body, it.key())) UnknownMember(pointer, it.key(), body, errors);
  }
}

std::vector<std::string_view> Choices(const Member& m) {
  std::vector<std::string_view> out;
  for (std::string_view rest = m.choices; !rest.empty();) {
    const size_t bar = rest.find('|');
    out.push_back(rest.substr(0, bar));
    rest = bar == std::string_view::npos ? std::string_view() : rest.substr(bar + 1);
  }
  return out;
}

std::string Expected(const Member& m) {
  switch (m.kind) {
    case Kind::kNumber:
    case Kind::kInteger: {
      const std::string what = m.kind == Kind::kInteger ? "an integer" : "a number";
      const bool lo = std::isfinite(m.lo), hi = std::isfinite(m.hi);
      if (lo && hi) return what + " in [" + FormatNumber(m.lo) + ", " + FormatNumber(m.hi) + "]";
      if (lo) return what + " >= " + FormatNumber(m.lo);
      return what;
    }
    case Kind::kBoolean: return "true or false";
    case Kind::kString: return "a string";
    case Kind::kChoice: {
      std::string out = "one of ";
      for (std::string_view c : Choices(m))
        out += (out.size() > 7 ? ", \"" : "\"") + std::string(c) + "\"";
      return out;
    }
    case Kind::kSchema: return "as the document's schema says";
  }
  return {};
}

bool ReadNumber(Body body, std::string_view name, const nlohmann::json& v,
                const std::string& pointer, double* out, Status& errors) {
  const Member* m = FindMember(body, name);
  const bool kind_ok = m && (m->kind == Kind::kInteger ? v.is_number_integer() : v.is_number());
  const double d = kind_ok ? v.get<double>() : 0.0;
  if (kind_ok && std::isfinite(d) && d >= m->lo && d <= m->hi) {
    *out = d;
    return true;
  }
  errors.fields.push_back({pointer, m ? "must be " + Expected(*m) : "is not a member"});
  return false;
}

}  // namespace facespace::evaluator
