// /v1/rigs, /v1/rigs/{id}, /v1/rigs/{id}/topology: the rigs in the store.
#include <array>
#include <cmath>
#include <optional>

#include "../http/cost.h"
#include "facespace/engine/enum_table.h"
#include "facespace/engine/transform.h"
#include "facespace/evaluator/answers.h"
#include "facespace/formats/lod.h"
#include "facespace/http/describe.h"
#include "facespace/offscreen/render.h"
#include "http/encoded.h"
#include "routes.h"

namespace facespace::http {

namespace {

using nlohmann::json;

json RigSummary(const evaluator::StoredRig& s) {
  const Rig& r = s.rig;
  json o = {{"id", s.id},
            {"name", r.name},
            {"vertices", r.vertex_count()},
            {"triangles", r.triangle_count()},
            {"shapes", r.shapes.size()},
            {"primitives", r.primitives.size()},
            {"has_skeleton", r.skin_count > 0},
            {"version", s.version}};
  if (!r.credit.empty()) o["credit"] = r.credit;
  return o;
}

json RigDetail(const evaluator::StoredRig& s) {
  json j = RigSummary(s);
  j.update(DescribeRig(s.rig));
  return j;
}

// Per material, the one colour a client that draws no textures shows (linear RGBA): the base colour
// factor times its texture's mean (FaceCap's skin map; MakeHuman's eyes). A texture that does not
// decode (not read, or not an image) counts as white.
std::vector<std::array<float, 4>> FlatColors(const Rig& rig) {
  std::vector<std::array<float, 4>> out;
  std::vector<std::optional<std::array<float, 4>>> mean(rig.images.size());
  for (const Material& m : rig.materials) {
    std::array<float, 4> c = m.base_color_factor;
    if (m.base_color_image >= 0 && static_cast<size_t>(m.base_color_image) < rig.images.size()) {
      auto& kept = mean[static_cast<size_t>(m.base_color_image)];
      if (!kept) {
        kept = std::array<float, 4>{1, 1, 1, 1};
        const Image& image = rig.images[static_cast<size_t>(m.base_color_image)];
        if (auto decoded = offscreen::Decode(image.bytes, image.mime_type);
            decoded.ok()) {  // Not read (no bytes): not an image.
          const std::vector<float>& px = decoded->rgba;
          std::array<double, 4> sum{0, 0, 0, 0};
          for (size_t i = 0; i + 3 < px.size(); i += 4) {
            for (int k = 0; k < 4; ++k) sum[k] += px[i + k];
          }
          const double n = std::max<double>(1.0, static_cast<double>(px.size() / 4));
          for (int k = 0; k < 4; ++k) (*kept)[k] = static_cast<float>(sum[k] / n);
        }
      }
      for (int k = 0; k < 3; ++k) c[k] *= (*kept)[k];
      if (m.alpha_mode == "BLEND") c[3] *= (*kept)[3];
    }
    if (m.alpha_mode == "OPAQUE" || m.alpha_mode == "MASK") c[3] = 1.0f;
    out.push_back(c);
  }
  return out;
}

// Triangle lists per primitive, in the order of the f32 and JSON mesh outputs, its flat colour, and
// where the shapes act.
std::string TopologyJson(const Rig& at, const evaluator::DerivedRig& derived) {
  using evaluator::Answer;
  using evaluator::AnswerWriter;
  const std::vector<std::array<float, 4>> colors = FlatColors(at);
  const auto numbers = [](std::span<const float> v) {
    std::string s;
    for (size_t k = 0; k < v.size(); ++k) s += (k ? "," : "[") + FormatNumber(v[k]);
    return s + "]";
  };
  std::string out;
  AnswerWriter<Answer::kTopology> topology(out);
  std::string& list = topology.Open("primitives");
  for (size_t p = 0; p < at.primitives.size(); ++p) {
    const Primitive& pr = at.primitives[p];
    list += p ? ',' : '[';
    AnswerWriter<Answer::kTopologyPrimitive> w(list);
    w.Count("mesh", static_cast<size_t>(pr.mesh))
        .Count("primitive", static_cast<size_t>(pr.index_in_mesh))
        .Count("vertices", pr.vertex_count())
        .Count("mode", static_cast<size_t>(pr.mode));
    if (pr.material >= 0 && static_cast<size_t>(pr.material) < colors.size())
      w.Raw("color", numbers(colors[static_cast<size_t>(pr.material)]));
    std::string& indices = w.Open("indices");
    indices += '[';
    for (size_t i = 0; i < pr.indices.size(); ++i) {
      if (i) indices += ',';
      indices += std::to_string(pr.indices[i]);
    }
    indices += ']';
    w.End();
  }
  if (at.primitives.empty()) list += '[';
  list += ']';
  if (derived.has_focus) {  // For clients that frame a view: {min, max}, as the document's Box.
    topology.Raw("focus", "{\"min\":" + numbers(derived.focus_min) +
                              ",\"max\":" + numbers(derived.focus_max) + "}");
  }
  return topology.End();
}

std::string TopologyKey(const evaluator::StoredRig& s, int lod) {
  return "topology|" + s.id + "@" + s.version + "|" + std::to_string(lod);
}
std::string RigKey(const evaluator::StoredRig& s) { return "rig|" + s.id + "@" + s.version; }

}  // namespace

void WarmRig(ServerState& ctx, const std::shared_ptr<const evaluator::StoredRig>& stored) {
  const auto derived = ctx.evaluator.Derived(stored, 0);
  for (ContentCoding coding : {ContentCoding::kBrotli, ContentCoding::kGzip}) {
    ContentCoding c = coding;
    EncodedOnce(ctx, RigKey(*stored), c, "application/json",
                [&stored] { return RigDetail(*stored).dump(); });
    c = coding;
    if (derived)
      EncodedOnce(ctx, TopologyKey(*stored, 0), c, "application/json",
                  [&] { return TopologyJson(*derived->rig, *derived); });
  }
  ctx.evaluator.WarmPictures(stored, 0);
}

void ListRigs(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  const auto rigs = ctx.store.List();
  std::string key = "rigs";  // The list changes with the rigs' ids and versions alone.
  for (const auto& r : rigs) key += "|" + r->id + "@" + r->version;
  SendEncodedOnce(ctx, req, res, key, "application/json", [&rigs] {
    json list = json::array();
    for (const auto& r : rigs) list.push_back(RigSummary(*r));
    return json{{"rigs", list}}.dump();
  });
}

void GetRig(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  if (auto r = FindRig(ctx, req, res, req.matches[1])) {
    SendEncodedOnce(ctx, req, res, RigKey(*r), "application/json",
                    [&r] { return RigDetail(*r).dump(); });
  }
}

// The rig format of an upload: from its media type, or for application/octet-stream (or a
// multipart part with no type) from the file name it carries, else from the bytes' magic.
Status UploadFormat(const std::string& media_type, std::string name, std::string_view bytes,
                    formats::RigFormat* format) {
  const std::string ct = MediaType(media_type);
  static const std::pair<const char*, formats::RigFormat> kTypes[] = {
      {"model/gltf-binary", formats::RigFormat::kGlb},
      {"model/gltf+json", formats::RigFormat::kGltf},
      {"model/vnd.collada+xml", formats::RigFormat::kCollada},
      {"model/x-fbx", formats::RigFormat::kFbx},
      {"application/vnd.autodesk.fbx", formats::RigFormat::kFbx}};
  for (const auto& [type, f] : kTypes) {
    if (ct == type) {
      *format = f;
      return Status::Ok();
    }
  }
  const char* kAccepted =
      "upload a rig as model/gltf-binary (.glb), model/gltf+json (.gltf with embedded buffers), "
      "model/vnd.collada+xml (.dae), "
      "or application/octet-stream with a file name (Content-Disposition: attachment; "
      "filename=\"face.fbx\") for .fbx, .dae, .glb or .gltf; "
      "or multipart/form-data with a part \"rig\" (the file) and an optional part \"manifest\" "
      "(JSON)";
  if (ct != "application/octet-stream" && !ct.empty())
    return InvalidArgument(std::string(kAccepted) + ", not " + ct);
  if (!name.empty() && RigFormatFromPath(name, format) && *format != formats::RigFormat::kMd5)
    return Status::Ok();
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  if (name.empty() && SniffRigFormat(std::span<const unsigned char>(data, bytes.size()), format) &&
      *format != formats::RigFormat::kMd5) {
    return Status::Ok();
  }
  return InvalidArgument(std::string(kAccepted) +
                         (name.empty() ? "; the bytes are none of these"
                                       : "; '" + name.substr(0, 80) + "' is none of these"));
}

namespace {

// The file name of a plain upload: ?filename=, else Content-Disposition's filename.
std::string UploadName(const httplib::Request& req) {
  if (req.has_param("filename")) return req.get_param_value("filename");
  const std::string disposition = req.get_header_value("Content-Disposition");
  std::string name;
  if (const size_t at = disposition.find("filename="); at != std::string::npos) {
    name = disposition.substr(at + 9);
    if (!name.empty() && name[0] == '"')
      name = name.substr(
          1, name.find('"', 1) == std::string::npos ? std::string::npos : name.find('"', 1) - 1);
    name = name.substr(0, name.find(';'));
  }
  return name;
}

// The parts of a multipart upload: "rig" (required, once) and "manifest" (optional, once); any
// other part is refused naming it. On failure the problem is sent and false returned.
bool UploadParts(const httplib::Request& req, httplib::Response& res,
                 const httplib::MultipartFormData** rig,
                 const httplib::MultipartFormData** manifest) {
  static constexpr std::string_view kParts[] = {"rig", "manifest"};
  for (const auto& [name, part] : req.files) {
    if (name != "rig" && name != "manifest") {
      SendProblem(req, res, Problem::kInvalidRequest,
                  "unknown part '" + name.substr(0, 80) + "'" + DidYouMean(name, kParts) +
                      "; an upload has a part \"rig\" and an optional \"manifest\"",
                  {{"/" + JsonPointerEscape(name.substr(0, 80)), "unknown part"}});
      return false;
    }
    if (req.files.count(name) > 1) {
      SendProblem(req, res, Problem::kInvalidRequest,
                  "the part '" + name + "' is given more than once",
                  {{"/" + name, "given more than once"}});
      return false;
    }
  }
  auto it = req.files.find("rig");
  if (it == req.files.end()) {
    SendProblem(req, res, Problem::kInvalidRequest,
                "a multipart upload needs a part \"rig\": the rig file", {{"/rig", "missing"}});
    return false;
  }
  *rig = &it->second;
  auto m = req.files.find("manifest");
  *manifest = m == req.files.end() ? nullptr : &m->second;
  return true;
}

// A manifest body must be a JSON object: its own problems are the core's, these are the HTTP ones.
bool ManifestIsJsonObject(const httplib::Request& req, httplib::Response& res,
                          const std::string& text, const std::string& pointer) {
  const json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) {
    SendStatus(req, res,
               WithReason(InvalidArgument(
                              (pointer == "/" ? std::string("the manifest") : pointer.substr(1)) +
                              ": not valid JSON"),
                          evaluator::kMalformedJson));
    return false;
  }
  if (!j.is_object()) {
    SendProblem(req, res, Problem::kInvalidManifest,
                pointer.substr(1) + ": must be a JSON object (README \"Manifest\")",
                {{pointer, "must be an object"}});
    return false;
  }
  return true;
}

void SendStoreStatus(const httplib::Request& req, httplib::Response& res, Status s,
                     const char* bad_input) {
  if (s.reason.empty()) {
    // A limit, not-found or cancellation keeps its code's own problem.
    const bool input =
        s.code == StatusCode::kInvalidArgument || s.code == StatusCode::kFailedPrecondition;
    s.reason = s.code == StatusCode::kStorageFull ? "storage-full"
               : s.code == StatusCode::kInternal  ? "storage-failed"
               : input                            ? bad_input
                                                  : "";
  }
  SendStatus(req, res, s);
}

}  // namespace

void PutRig(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  if (!Authorized(ctx, req, res) || !WithinBudget(ctx, req, res, UploadCost(req.body.size())))
    return;
  const std::string id = req.matches[1];
  if (!evaluator::IsValidRigId(id)) {
    SendProblem(req, res, Problem::kInvalidId,
                "rig ids are 1 to 64 characters of [a-z0-9_-], starting with a letter or digit",
                {{"?id", "invalid rig id"}});
    return;
  }
  // A plain body is the rig; multipart/form-data carries the rig and its manifest together.
  std::string_view bytes = req.body;
  std::string media_type = req.get_header_value("Content-Type"), name, manifest;
  if (req.is_multipart_form_data()) {
    const httplib::MultipartFormData *rig_part = nullptr, *manifest_part = nullptr;
    if (!UploadParts(req, res, &rig_part, &manifest_part)) return;
    bytes = rig_part->content;
    media_type = rig_part->content_type;
    name = rig_part->filename;
    if (manifest_part) {
      manifest = manifest_part->content;
      if (!ManifestIsJsonObject(req, res, manifest, "/manifest")) return;
    }
  } else {
    name = UploadName(req);
    if (MediaType(media_type).empty()) media_type = "none";  // A plain upload says what it is.
  }
  formats::RigFormat format;
  if (Status s = UploadFormat(media_type, name, bytes, &format); !s.ok()) {
    SendProblem(req, res, Problem::kUnsupportedMediaType, s.message);
    return;
  }
  if (bytes.empty()) {
    SendProblem(req, res, Problem::kInvalidRig, "the body is empty");
    return;
  }
  bool created = false;
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  if (Status s = ctx.store.Put(id, std::span<const unsigned char>(data, bytes.size()), format,
                               manifest, &created);
      !s.ok()) {
    SendStoreStatus(req, res, s, "invalid-rig");
    return;
  }
  auto stored = ctx.store.Get(id);
  res.set_header("Location", "/v1/rigs/" + id);
  SendJson(res, created ? 201 : 200, stored ? RigSummary(*stored) : json{{"id", id}});
}

void GetManifest(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  if (auto r = FindRig(ctx, req, res, req.matches[1])) {
    const std::string etag = "\"" + r->version + "\"";
    res.set_header("ETag", etag);
    if (req.get_header_value("If-None-Match").find(etag) != std::string::npos) {
      res.status = 304;  // The client's copy is this version's.
      return;
    }
    res.set_content(formats::ManifestJson(r->rig), "application/json");
  }
}

void PutManifest(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  if (!Authorized(ctx, req, res) || !WithinBudget(ctx, req, res, UploadCost(req.body.size())))
    return;
  const std::string id = req.matches[1];
  if (MediaType(req.get_header_value("Content-Type")) != "application/json") {
    SendProblem(req, res, Problem::kUnsupportedMediaType,
                "a manifest is application/json (README \"Manifest\")");
    return;
  }
  if (!ManifestIsJsonObject(req, res, req.body, "/")) return;
  Status s = evaluator::IsValidRigId(id) ? ctx.store.PutManifest(id, req.body) : NotFound("");
  if (s.code == StatusCode::kNotFound) {
    SendProblem(req, res, Problem::kRigNotFound, "no rig with id '" + id.substr(0, 80) + "'");
    return;
  }
  if (!s.ok()) {
    for (FieldError& f : s.fields) {  // The body is the manifest itself: pointers from its root.
      if (f.pointer.rfind("/manifest", 0) == 0)
        f.pointer = f.pointer.substr(9).empty() ? "/" : f.pointer.substr(9);
    }
    SendStoreStatus(req, res, s, "invalid-manifest");
    return;
  }
  auto stored = ctx.store.Get(id);
  res.set_header("Location", "/v1/rigs/" + id + "/manifest");
  SendJson(res, 200, stored ? RigSummary(*stored) : json{{"id", id}});
}

void DeleteRig(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  if (!Authorized(ctx, req, res)) return;
  const std::string id = req.matches[1];
  Status s = evaluator::IsValidRigId(id) ? ctx.store.Delete(id) : NotFound("");
  if (s.code == StatusCode::kNotFound) {
    SendProblem(req, res, Problem::kRigNotFound, "no rig with id '" + id.substr(0, 80) + "'");
  } else if (!s.ok()) {
    SendStatus(
        req, res,
        s.reason.empty() && s.code == StatusCode::kInternal ? WithReason(s, "storage-failed") : s);
  } else {
    res.status = 204;
  }
}

void GetTopology(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  if (!stored) return;
  int lod = 0;
  if (req.has_param("lod") && !formats::ParseLod(req.get_param_value("lod"), &lod)) {
    SendProblem(req, res, Problem::kInvalidRequest, "lod: must be " + formats::LodExpected(),
                {{"?lod", "must be " + formats::LodExpected()}});
    return;
  }
  // The triangles as JSON, or the indices alone as little-endian uint32.
  enum class TopologyFormat { kJson, kU32 };
  static constexpr EnumName<TopologyFormat> kTopologyFormats[] = {{TopologyFormat::kJson, "json"},
                                                                  {TopologyFormat::kU32, "u32"}};
  TopologyFormat format = TopologyFormat::kJson;
  if (req.has_param("format") &&
      !ParseEnum(kTopologyFormats, req.get_param_value("format"), &format)) {
    SendProblem(req, res, Problem::kInvalidRequest,
                "format: must be json or u32 (the indices alone, little-endian)",
                {{"?format", "must be json or u32"}});
    return;
  }
  const auto derived = ctx.evaluator.Derived(stored, lod);
  if (!derived) {
    SendProblem(req, res, Problem::kInternal, "the level of detail failed");
    return;
  }
  const Rig& at = *derived->rig;
  if (format == TopologyFormat::kU32) {
    // For WebGL clients: every primitive's triangle indices as little-endian uint32, one after the
    // other, in the order of the f32 and JSON mesh outputs; the headers say how many each has.
    std::string vertices, indices;
    for (const Primitive& p : at.primitives) {
      vertices += (vertices.empty() ? "" : ",") + std::to_string(p.vertex_count());
      indices += (indices.empty() ? "" : ",") + std::to_string(p.indices.size());
    }
    res.set_header("Facespace-Vertex-Counts", vertices);
    res.set_header("Facespace-Index-Counts", indices);
    SendEncodedOnce(
        ctx, req, res, TopologyKey(*stored, lod) + "|u32", "application/octet-stream", [&at] {
          std::string out;
          for (const Primitive& p : at.primitives) {
            for (uint32_t i : p.indices) {
              const unsigned char le[4] = {
                  static_cast<unsigned char>(i), static_cast<unsigned char>(i >> 8),
                  static_cast<unsigned char>(i >> 16), static_cast<unsigned char>(i >> 24)};
              out.append(reinterpret_cast<const char*>(le), 4);
            }
          }
          return out;
        });
    return;
  }
  SendEncodedOnce(ctx, req, res, TopologyKey(*stored, lod), "application/json",
                  [&at, &derived] { return TopologyJson(at, *derived); });
}

}  // namespace facespace::http
