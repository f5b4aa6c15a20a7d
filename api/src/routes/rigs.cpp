// /v1/rigs, /v1/rigs/{id}, /v1/rigs/{id}/topology: the rigs in the store.
#include <cmath>

#include "facespace/api/describe.h"
#include "facespace/core/lod.h"
#include "facespace/core/transform.h"
#include "routes.h"

namespace facespace::api::http {

namespace {

using nlohmann::json;

json RigSummary(const StoredRig& s) {
  const Rig& r = s.rig;
  json o = {{"id", s.id},           {"name", r.name},
            {"vertices", r.vertex_count()}, {"triangles", r.triangle_count()},
            {"shapes", r.shapes.size()},    {"primitives", r.primitives.size()},
            {"has_skeleton", r.skin_count > 0}, {"version", s.version}};
  if (!r.credit.empty()) o["credit"] = r.credit;
  return o;
}

json RigDetail(const StoredRig& s) {
  json j = RigSummary(s);
  j.update(DescribeRig(s.rig));
  return j;
}

}  // namespace

void ListRigs(Context& ctx, const httplib::Request&, httplib::Response& res) {
  json list = json::array();
  for (const auto& r : ctx.store.List()) list.push_back(RigSummary(*r));
  SendJson(res, 200, {{"rigs", list}});
}

void GetRig(Context& ctx, const httplib::Request& req, httplib::Response& res) {
  if (auto r = FindRig(ctx, req, res, req.matches[1])) {
    res.set_header("ETag", "\"" + r->version + "\"");
    SendJson(res, 200, RigDetail(*r));
  }
}

// The rig format of an upload: from its media type, or for application/octet-stream from the file
// name it carries (Content-Disposition's filename, or ?filename=), else from the bytes' magic.
Status UploadFormat(const httplib::Request& req, RigFormat* format) {
  const std::string ct = MediaType(req.get_header_value("Content-Type"));
  static const std::pair<const char*, RigFormat> kTypes[] = {
      {"model/gltf-binary", RigFormat::kGlb},        {"model/gltf+json", RigFormat::kGltf},
      {"model/vnd.collada+xml", RigFormat::kCollada}, {"model/x-fbx", RigFormat::kFbx},
      {"application/vnd.autodesk.fbx", RigFormat::kFbx}};
  for (const auto& [type, f] : kTypes) {
    if (ct == type) {
      *format = f;
      return Status::Ok();
    }
  }
  const char* kAccepted =
      "upload a rig as model/gltf-binary (.glb), model/gltf+json (.gltf with embedded buffers), model/vnd.collada+xml (.dae), "
      "or application/octet-stream with a file name (Content-Disposition: attachment; filename=\"face.fbx\") for .fbx, .dae, .glb or .gltf";
  if (ct != "application/octet-stream") return InvalidArgument(std::string(kAccepted) + (ct.empty() ? "" : ", not " + ct));
  std::string name = req.has_param("filename") ? req.get_param_value("filename") : "";
  const std::string disposition = req.get_header_value("Content-Disposition");
  if (const size_t at = disposition.find("filename="); name.empty() && at != std::string::npos) {
    name = disposition.substr(at + 9);
    if (!name.empty() && name[0] == '"') name = name.substr(1, name.find('"', 1) == std::string::npos ? std::string::npos : name.find('"', 1) - 1);
    name = name.substr(0, name.find(';'));
  }
  if (!name.empty() && RigFormatFromPath(name, format) && *format != RigFormat::kMd5) return Status::Ok();
  const auto* data = reinterpret_cast<const unsigned char*>(req.body.data());
  if (name.empty() && SniffRigFormat(std::span<const unsigned char>(data, req.body.size()), format) && *format != RigFormat::kMd5) {
    return Status::Ok();
  }
  return InvalidArgument(std::string(kAccepted) + (name.empty() ? "; the bytes are none of these" : "; '" + name.substr(0, 80) + "' is none of these"));
}

void PutRig(Context& ctx, const httplib::Request& req, httplib::Response& res) {
  if (!Authorized(ctx, req, res)) return;
  const std::string id = req.matches[1];
  if (!IsValidRigId(id)) {
    SendProblem(req, res, 422, "invalid-id", "rig ids are 1 to 64 characters of [a-z0-9_-], starting with a letter or digit",
                {{"?id", "invalid rig id"}});
    return;
  }
  RigFormat format;
  if (Status s = UploadFormat(req, &format); !s.ok()) {
    SendProblem(req, res, 415, "unsupported-media-type", s.message);
    return;
  }
  if (req.body.empty()) {
    SendProblem(req, res, 422, "invalid-rig", "the body is empty");
    return;
  }
  bool created = false;
  const auto* data = reinterpret_cast<const unsigned char*>(req.body.data());
  Status s = ctx.store.Put(id, std::span<const unsigned char>(data, req.body.size()), format, &created);
  if (!s.ok()) {
    if (s.reason.empty()) s.reason = s.code == StatusCode::kStorageFull ? "storage-full" : s.code == StatusCode::kInternal ? "storage-failed" : "invalid-rig";
    SendStatus(req, res, s);
    return;
  }
  auto stored = ctx.store.Get(id);
  res.set_header("Location", "/v1/rigs/" + id);
  SendJson(res, created ? 201 : 200, stored ? RigSummary(*stored) : json{{"id", id}});
}

void DeleteRig(Context& ctx, const httplib::Request& req, httplib::Response& res) {
  if (!Authorized(ctx, req, res)) return;
  const std::string id = req.matches[1];
  Status s = IsValidRigId(id) ? ctx.store.Delete(id) : NotFound("");
  if (s.code == StatusCode::kNotFound) {
    SendProblem(req, res, 404, "rig-not-found", "no rig with id '" + id.substr(0, 80) + "'");
  } else if (!s.ok()) {
    SendStatus(req, res, WithReason(s, "storage-failed"));
  } else {
    res.status = 204;
  }
}

void GetTopology(Context& ctx, const httplib::Request& req, httplib::Response& res) {
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  if (!stored) return;
  int lod = 0;
  if (req.has_param("lod")) {
    const std::string v = req.get_param_value("lod");
    if (v.size() != 1 || v[0] < '0' || v[0] - '0' > kMaxLod) {
      SendProblem(req, res, 422, "invalid-request", "lod: must be an integer level of detail 0.." + std::to_string(kMaxLod),
                  {{"?lod", "must be 0.." + std::to_string(kMaxLod)}});
      return;
    }
    lod = v[0] - '0';
  }
  const auto derived = ctx.derived.At(stored, lod);
  if (!derived) {
    SendProblem(req, res, 500, "internal", "the level of detail failed");
    return;
  }
  // Triangle lists per primitive, in the order of the f32 and JSON mesh outputs.
  const Rig& at = *derived->rig;
  std::string out = "{\"primitives\":[";
  for (size_t p = 0; p < at.primitives.size(); ++p) {
    const Primitive& pr = at.primitives[p];
    if (p) out += ',';
    out += "{\"mesh\":" + std::to_string(pr.mesh) + ",\"primitive\":" + std::to_string(pr.index_in_mesh) +
           ",\"vertices\":" + std::to_string(pr.vertex_count()) + ",\"mode\":" + std::to_string(static_cast<int>(pr.mode)) +
           ",\"indices\":[";
    for (size_t i = 0; i < pr.indices.size(); ++i) {
      if (i) out += ',';
      out += std::to_string(pr.indices[i]);
    }
    out += "]}";
  }
  out += "]";
  if (derived->has_focus) {  // Where the shapes act, for clients that frame a view.
    const auto& lo = derived->focus_min;
    const auto& hi = derived->focus_max;
    out += ",\"focus\":{\"min\":[" + FormatNumber(lo[0]) + "," + FormatNumber(lo[1]) + "," + FormatNumber(lo[2]) + "],\"max\":[" +
           FormatNumber(hi[0]) + "," + FormatNumber(hi[1]) + "," + FormatNumber(hi[2]) + "]}";
  }
  out += "}";
  res.set_header("ETag", "\"" + stored->version + "-" + std::to_string(lod) + "\"");
  res.set_header("Cache-Control", "no-cache");
  res.set_content(std::move(out), "application/json");
}

}  // namespace facespace::api::http
