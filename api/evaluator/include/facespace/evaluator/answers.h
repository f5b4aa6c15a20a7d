// The members of the JSON answers written member by member, declared once as the request bodies
// are (members.h): name, type and documentation. Each answer's writer names its members through
// AnswerWriter<A>, which finds them in A's table as the program compiles (a name the table does not
// declare does not compile), and the OpenAPI document writes these answers' schemas from the same
// tables, closed: a member no table names fails the document's own schema.
#pragma once

#include <span>
#include <string>
#include <string_view>

#include "facespace/engine/weights.h"
#include "facespace/evaluator/members.h"

namespace facespace::evaluator {

namespace answers {

inline constexpr char kByName[] =
    R"({"type": "object", "additionalProperties": {"type": "number"}})";
inline constexpr char kWarnings[] =
    R"({"type": "array", "items": {"$ref": "#/components/schemas/Warning"}})";
inline constexpr char kNames[] = R"({"type": "array", "items": {"type": "string"}})";
inline constexpr Member kWeightsByName =
    Schema("weights", "Shape name -> weight; a shape not named is 0", kByName).Required();
inline constexpr Member kWarningList =
    Schema("warnings", "Where the point leaves the authored space, and why", kWarnings).Required();

inline constexpr Member kCheck[] = {
    Number("sum", "The weights' sum").Required(),
    kWeightsByName,
    Number("mahalanobis",
           "With manifest statistics: distance from the mean in standard deviations"),
    Number("vertex_sum", "Beside a sum above 1: the most weight one vertex takes"),
    Schema("stacked", "Beside vertex_sum: the shapes stacking there", kNames),
    kWarningList,
};
inline constexpr Member kFit[] = {
    kWeightsByName,
    Schema("residual", "How far the fitted mesh is from the target", "#Residual").Required(),
    Schema("alignment",
           "With rigid_align: the column-major 4x4 matrix that took the target onto the rig",
           R"({"type": "array", "items": {"type": "number"}, "minItems": 16, "maxItems": 16})"),
    kWarningList,
};
inline constexpr Member kResidual[] = {
    Number("rms", "Root mean square of the vertices' distances, in the rig's units").Required(),
    Number("max", "The largest vertex distance").Required(),
};
inline constexpr Member kSequenceFrames[] = {
    Choice("space", "Frames of positions and normals: placed by each primitive's node", "world"),
    Choice("format", "Present when the frames are weights alone", "weights"),
    Schema("frames", "At each time asked",
           R"({"type": "array", "items": {"$ref": "#/components/schemas/Frame"}})")
        .Required(),
    kWarningList,
};
inline constexpr Member kFrame[] = {
    Number("time", "Seconds").Required(),
    kWeightsByName,
    Schema(
        "pose", "format weights, posed frames: the nodes moved from rest, by name",
        R"({"type": "object", "additionalProperties": {"$ref": "#/components/schemas/PosedJoint"}})"),
    Number("sum", "format weights: the weights' sum"),
    Schema("primitives", "As the mesh route's JSON answer: each primitive's positions and normals",
           R"({"type": "array", "items": {"type": "object"}})"),
};
// Each member is the request JointPose's own member of that name (members_test checks).
inline constexpr Member kPosedJoint[] = {
    Schema("translation", "Scene units",
           R"({"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3})")
        .Required(),
    Schema("rotation", "A quaternion [x, y, z, w]",
           R"({"type": "array", "items": {"type": "number"}, "minItems": 4, "maxItems": 4})")
        .Required(),
    Schema("scale", "Factors",
           R"({"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3})")
        .Required(),
};
inline constexpr Member kStreamFrame[] = {
    Integer("frame", "Frame number from 0, at the request's fps", 0, kUnbounded).Required(),
    Number("time", "Seconds").Required(),
    kWeightsByName,
    kWarningList,
};
inline constexpr Member kReduced[] = {
    Schema("keys", "The keys kept, each a sequence request's key",
           R"({"type": "array", "items": {"$ref": "#/components/schemas/SequenceKey"}})")
        .Required(),
    String("transition", "The sequence's transition, which the kept keys blend by").Required(),
    Integer("kept", "Keys kept", 0, kUnbounded).Required(),
    Integer("removed", "Keys removed", 0, kUnbounded).Required(),
    Number("max_error", "The largest vertex error of the kept keys against the original")
        .Required(),
    Number("tolerance", "The tolerance asked for").Required(),
};
// Each member is the request Key's own member of that name (members_test checks), so a client can
// post the kept keys back as a sequence.
inline constexpr Member kSequenceKey[] = {
    Number("time", "Seconds").Required(),
    kWeightsByName,
    String("transition", "Into the next key (as the sequence's transition)"),
};
inline constexpr char kVisemes[] =
    R"({"type": "string", "enum": ["sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E", "ih", "oh", "ou"]})";
inline constexpr Member kSpeech[] = {
    Choice("source", "What timed the phonemes", "espeak-ng|pocketsphinx|pocketsphinx-aligned")
        .Required(),
    String("voice", "espeak-ng's voice"),
    Number("duration", "Seconds of audio").Required(),
    Number("fps", "Frames a second of the keys").Required(),
    Integer("frames", "Frames the speech lasts at fps", 0, kUnbounded).Required(),
    Number("voiced_seconds", "Recognized speech: the seconds in which a voice was heard"),
    Schema("phonemes", "The phonemes, timed",
           R"({"type": "array", "items": {"$ref": "#/components/schemas/TimedPhoneme"}})")
        .Required(),
    Schema("visemes", "The visemes, timed",
           R"({"type": "array", "items": {"$ref": "#/components/schemas/TimedViseme"}})")
        .Required(),
    Schema("keys", "The face's keys, as a sequence request's",
           R"({"type": "array", "items": {"$ref": "#/components/schemas/SequenceKey"}})")
        .Required(),
    String("transition", "How the keys blend (a sequence's transition)").Required(),
    kWarningList,
    Schema("audio_wav", "with_audio: the speech as a WAV file",
           R"({"type": "string", "contentEncoding": "base64"})"),
};
inline constexpr Member kTimedPhoneme[] = {
    String("name", "The phoneme (espeak-ng's or CMU's)").Required(),
    Number("start", "Seconds").Required(),
    Number("end", "Seconds").Required(),
};
inline constexpr Member kTimedViseme[] = {
    Schema("viseme", "The viseme (Oculus's 15)", kVisemes).Required(),
    Number("start", "Seconds").Required(),
    Number("end", "Seconds").Required(),
};
inline constexpr Member kTopology[] = {
    Schema("primitives", "Triangle lists per primitive, in the order of the f32 and JSON meshes",
           R"({"type": "array", "items": {"$ref": "#/components/schemas/TopologyPrimitive"}})")
        .Required(),
    Schema("focus", "Where the shapes act (world space), for clients that frame a view",
           R"({"type": "object", "required": ["min", "max"], "additionalProperties": false,)"
           R"( "properties": {"min": {"type": "array", "items": {"type": "number"}, "minItems": 3,)"
           R"( "maxItems": 3}, "max": {"type": "array", "items": {"type": "number"},)"
           R"( "minItems": 3, "maxItems": 3}}})"),
};
inline constexpr Member kTopologyPrimitive[] = {
    Integer("mesh", "The glTF mesh", 0, kUnbounded).Required(),
    Integer("primitive", "The primitive within its mesh", 0, kUnbounded).Required(),
    Integer("vertices", "Its vertices in the f32 and JSON meshes", 0, kUnbounded).Required(),
    Integer("mode", "glTF's primitive mode (4: triangles)", 0, 6).Required(),
    Schema("color",
           "Linear RGBA a client drawing no textures shows: the material's base colour times its "
           "texture's mean; alpha 0 is see-through (a material morph shows it)",
           R"({"type": "array", "items": {"type": "number"}, "minItems": 4, "maxItems": 4})"),
    Schema("indices", "Triangles as vertex indices, three each",
           R"({"type": "array", "items": {"type": "integer", "minimum": 0}})")
        .Required(),
};

}  // namespace answers

// Each answer written member by member.
enum class Answer : unsigned char {
  kCheck,              // POST check.
  kFit,                // POST fit.
  kResidual,           // The fit's residual.
  kSequenceFrames,     // POST sequence/sample.
  kFrame,              // One of its frames.
  kPosedJoint,         // A frame's moved node.
  kStreamFrame,        // One line of POST sequence/stream's ndjson.
  kReduced,            // POST sequence/reduce.
  kSequenceKey,        // One of its keys.
  kSpeech,             // POST speech as JSON.
  kTimedPhoneme,       // One of its phonemes.
  kTimedViseme,        // One of its visemes (and the live socket's viseme event).
  kTopology,           // GET topology.
  kTopologyPrimitive,  // One of its primitives.
};
// Each answer's component name in the document, what it is, and its members: kAnswerTables[a].
struct AnswerTable {
  Answer answer;
  std::string_view name, doc;
  std::span<const Member> members;
};
inline constexpr AnswerTable kAnswerTables[] = {
    {Answer::kCheck, "Check", "Where a point lies in face space, and its warnings",
     answers::kCheck},
    {Answer::kFit, "Fit", "The weights that best reproduce a mesh", answers::kFit},
    {Answer::kResidual, "Residual", "How far the fitted mesh is from the target",
     answers::kResidual},
    {Answer::kSequenceFrames, "SequenceFrames", "A sequence sampled at the times asked",
     answers::kSequenceFrames},
    {Answer::kFrame, "Frame", "One frame of a sampled sequence", answers::kFrame},
    {Answer::kPosedJoint, "PosedJoint", "A node moved from rest, as a request's JointPose",
     answers::kPosedJoint},
    {Answer::kStreamFrame, "StreamFrame", "One line of a streamed sequence (ndjson)",
     answers::kStreamFrame},
    {Answer::kReduced, "Reduced", "A sequence with the keys it does not need removed",
     answers::kReduced},
    {Answer::kSequenceKey, "SequenceKey", "One key of a sequence answer, as a request's key",
     answers::kSequenceKey},
    {Answer::kSpeech, "Speech", "Speech as phonemes, visemes and the face's keys",
     answers::kSpeech},
    {Answer::kTimedPhoneme, "TimedPhoneme", "A phoneme and when it is said",
     answers::kTimedPhoneme},
    {Answer::kTimedViseme, "TimedViseme", "A viseme and when it shows", answers::kTimedViseme},
    {Answer::kTopology, "Topology", "A rig's triangles, for clients that draw it themselves",
     answers::kTopology},
    {Answer::kTopologyPrimitive, "TopologyPrimitive", "One primitive's triangles and flat colour",
     answers::kTopologyPrimitive},
};
constexpr const AnswerTable& TableOf(Answer a) { return kAnswerTables[static_cast<size_t>(a)]; }
static_assert([] {
  for (size_t i = 0; i < std::size(kAnswerTables); ++i)
    if (static_cast<size_t>(kAnswerTables[i].answer) != i) return false;
  return true;
}());  // In the enum's order, so TableOf indexes.
constexpr std::span<const Member> Members(Answer a) { return TableOf(a).members; }

// Writes one answer as JSON text into `out` ("{" at construction, "}" at End), each member named
// from A's table: w.Number("sum", 0.5) compiles only when A declares "sum".
template <Answer A>
class AnswerWriter {
 public:
  struct Name {
    consteval Name(const char* name) : member(Find(name)) {}  // NOLINT: implicit by design.
    const Member* member;

   private:
    static consteval const Member* Find(std::string_view name) {
      for (const Member& m : Members(A))
        if (m.name == name) return &m;
      throw "the answer's table does not declare this member";
    }
  };

  explicit AnswerWriter(std::string& out) : out_(out) { out_ += '{'; }
  // `json`: a value's JSON text (a nested answer, a number list, ...).
  AnswerWriter& Raw(Name n, std::string_view json) {
    Key(n);
    out_ += json;
    return *this;
  }
  AnswerWriter& Number(Name n, double v) { return Raw(n, FormatNumber(v)); }
  AnswerWriter& Count(Name n, size_t v) { return Raw(n, std::to_string(v)); }
  // Opens the member's value for the caller to append (an array written in place).
  std::string& Open(Name n) {
    Key(n);
    return out_;
  }
  std::string& End() {
    out_ += '}';
    return out_;
  }

 private:
  void Key(Name n) {
    out_ += first_ ? "\"" : ",\"";
    first_ = false;
    out_ += n.member->name;
    out_ += "\":";
  }
  std::string& out_;
  bool first_ = true;
};

}  // namespace facespace::evaluator
