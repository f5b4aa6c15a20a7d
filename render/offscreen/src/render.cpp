// OSMesa (llvmpipe) renderer: a bounded pool of GL 3.3 core contexts shared by every thread,
// an offscreen float framebuffer, glTF metallic-roughness under a studio light in linear light,
// tone mapped (Khronos PBR Neutral).
#include "facespace/offscreen/render.h"

#include <GL/gl.h>
#include <GL/glext.h>
#include <GL/osmesa.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <list>
#include <memory>
#include <mutex>
#include <thread>

#include "facespace/engine/hierarchy.h"
#include "facespace/engine/shape_tools.h"
#include "facespace/engine/transform.h"
#include "gl_context.h"
#include "internal.h"

namespace facespace::offscreen {

OsMesaRenderer::OsMesaRenderer(int max_contexts) : pool_(std::make_unique<ContextPool>()) {
  pool_->SetLimit(max_contexts);
}
OsMesaRenderer::~OsMesaRenderer() = default;

std::string OsMesaRenderer::Info() const {
  auto lease = pool_->Acquire();
  if (!lease.ok()) return "unavailable: " + lease.status().message;
  return lease.value().get()->info;
}

void OsMesaRenderer::SetMaxContexts(int n) { pool_->SetLimit(n); }

int OsMesaRenderer::Concurrency() const { return pool_->Limit(); }

namespace {

// One primitive's draw call over the shared vertex and index arrays.
struct DrawCall {
  size_t first_vertex, first_index, index_count;
  PrimitiveMode mode;
  int material;
};

// What one render gathers before it draws: the world-space vertices (gl.verts: position, normal,
// uv, colour, displacement, baked occlusion: kFloatsPerVertex floats) and indices (gl.indices), a
// draw call per primitive, and the boxes the camera may frame.
constexpr size_t kFloatsPerVertex = 13 + kOcclusionFloats;
struct Scene {
  std::vector<DrawCall> draws;
  Eigen::AlignedBox3f box, shape_box, rest_box, joint_box;
  bool frame_shapes = false;
  int joint_node = -1;  // The joint the camera frames, or -1.
  bool carry_shapes =
      false;  // Auto framing of a skinned face: the shapes' box, carried by the joint.
  std::vector<int> joint_in_skin;  // Its index among each skin's joints (-1: not in it).
  float heat_max = 0.0f;           // The largest displacement (the heatmap's scale).
};

// Framing the shapes (auto or shapes): the rest-pose box of what they move (stable while sliders
// move); on a skinned rig, by default, the joint carrying them, which a pose carries along.
// frame=joint:NAME: that joint, an error naming it when the rig has no such joint.
Status ChooseFraming(const Rig& rig, const picture::Camera& c, Scene& scene) {
  if (c.frame == picture::Framing::kAuto || c.frame == picture::Framing::kShapes) {
    std::array<float, 3> lo = c.focus_min, hi = c.focus_max;
    const bool found = c.has_focus || ShapeFocusBox(rig, lo, hi);
    const bool small = c.has_focus ? c.focus_small : found && FrameShapesByDefault(rig, lo, hi);
    if (found) {
      scene.frame_shapes = c.frame == picture::Framing::kShapes || small;
      scene.shape_box = Eigen::AlignedBox3f(Eigen::Vector3f(lo[0], lo[1], lo[2]),
                                            Eigen::Vector3f(hi[0], hi[1], hi[2]));
      // By default a face on a body is framed with a margin of 40% (its ears and hair may crop).
      if (c.frame == picture::Framing::kAuto && small) {
        const Eigen::Vector3f centre = scene.shape_box.center(),
                              half = 0.7f * scene.shape_box.sizes();
        scene.shape_box = Eigen::AlignedBox3f(centre - half, centre + half);
      }
    }
    if (c.frame == picture::Framing::kAuto && small) {
      scene.joint_node = c.has_focus ? c.focus_joint : ShapeFocusJoint(rig);
      scene.carry_shapes = found;
    }
  }
  if (c.frame == picture::Framing::kJoint) {
    scene.joint_node = FindNode(rig, c.frame_joint);
    std::vector<std::string_view> names;
    for (const Skin& skin : rig.skins) {
      for (int j : skin.joints) names.push_back(rig.nodes[static_cast<size_t>(j)].name);
    }
    if (names.empty())
      return InvalidArgument("frame: joint:" + c.frame_joint + ": the rig has no skeleton");
    if (scene.joint_node < 0)
      return InvalidArgument("frame: no joint '" + c.frame_joint + "' in the rig" +
                             DidYouMean(c.frame_joint, names));
  }
  scene.joint_in_skin.assign(rig.skins.size(), -1);
  for (size_t s = 0; scene.joint_node >= 0 && s < rig.skins.size(); ++s) {
    const auto& joints = rig.skins[s].joints;
    const auto it = std::find(joints.begin(), joints.end(), scene.joint_node);
    if (it != joints.end()) scene.joint_in_skin[s] = static_cast<int>(it - joints.begin());
  }
  return Status::Ok();
}

// Whether the framed joint carries vertex v of p (a third of its weight or more).
bool CarriedBy(const Primitive& p, size_t v, int joint) {
  for (size_t k = 0; joint >= 0 && k < p.influences; ++k) {
    const size_t at = v * p.influences + k;
    if (p.joints[at] == joint && p.joint_weights[at] >= 1.0f / 3.0f) return true;
  }
  return false;
}

// Whether material `m` draws as a soft stand-in (StandIn::kSoft) for want of its base colour's
// image.
bool SoftStandIn(const Rig& rig, int m) {
  if (m < 0 || static_cast<size_t>(m) >= rig.materials.size()) return false;
  const Material& mat = rig.materials[static_cast<size_t>(m)];
  const int image = mat.base_color_image;
  const bool missing = image < 0 || static_cast<size_t>(image) >= rig.images.size() ||
                       rig.images[static_cast<size_t>(image)].bytes.empty();
  return mat.stand_in == StandIn::kSoft && missing;
}

// A soft stand-in's opacity per vertex of `p`: 1 in the middle of its UV island (the triangles
// sharing vertices), fading to 0 at the island's UV box (an ellipse inscribed in it).
std::vector<float> SoftFade(const Primitive& p, std::span<const float> uv) {
  const size_t n = p.vertex_count();
  std::vector<float> fade(n, 1.0f);
  if (uv.size() < 2 * n) return fade;
  std::vector<uint32_t> root(n);
  for (uint32_t v = 0; v < n; ++v) root[v] = v;
  auto find = [&root](uint32_t v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  for (size_t i = 0; i + 2 < p.indices.size(); i += 3) {
    if (p.indices[i] >= n || p.indices[i + 1] >= n || p.indices[i + 2] >= n) continue;
    root[find(p.indices[i + 1])] = find(p.indices[i]);
    root[find(p.indices[i + 2])] = find(p.indices[i]);
  }
  std::vector<float> box(4 * n);  // Per root: u and v, least and greatest.
  for (uint32_t v = 0; v < n; ++v)
    box[4 * v] = box[4 * v + 2] = INFINITY, box[4 * v + 1] = box[4 * v + 3] = -INFINITY;
  for (uint32_t v = 0; v < n; ++v) {
    float* b = &box[4 * find(v)];
    b[0] = std::min(b[0], uv[2 * v]), b[1] = std::max(b[1], uv[2 * v]);
    b[2] = std::min(b[2], uv[2 * v + 1]), b[3] = std::max(b[3], uv[2 * v + 1]);
  }
  for (uint32_t v = 0; v < n; ++v) {
    const float* b = &box[4 * find(v)];
    const float x = (2.0f * uv[2 * v] - b[0] - b[1]) / std::max(b[1] - b[0], 1e-12f);
    const float y = (2.0f * uv[2 * v + 1] - b[2] - b[3]) / std::max(b[3] - b[2], 1e-12f);
    const float t = std::clamp((std::sqrt(x * x + y * y) - 0.25f) / 0.75f, 0.0f, 1.0f);
    fade[v] = 1.0f - t * t * (3.0f - 2.0f * t);
  }
  return fade;
}

// One primitive's vertices in world space into `verts`, the boxes extended. `occlusion`: the
// primitive's baked occlusion (kOcclusionFloats per vertex), or empty: open. `soft`: it draws as a
// soft stand-in (SoftStandIn).
void GatherPrimitive(const Primitive& p, const BlendedPrimitive& b, bool posed, int joint,
                     std::span<const float> occlusion, bool soft, Scene& scene,
                     std::vector<float>& verts) {
  const auto& m = b.world;
  const Eigen::Matrix3f nm =
      Eigen::Map<const Eigen::Matrix4f>(m.data()).topLeftCorner<3, 3>().inverse().transpose();
  const std::span<const float> texcoords = TexcoordsOf(p, b);  // UV morphs move them.
  const std::vector<float> fade = soft ? SoftFade(p, texcoords) : std::vector<float>();
  for (size_t v = 0; v < p.vertex_count(); ++v) {
    float q[3], rest[3], moved[3];
    TransformPoint(m, &b.positions[3 * v], q);
    // The rest shape, for a camera that does not move with the weights (a skinned primitive's
    // positions are in scene space already).
    if (b.skinned)
      std::copy(q, q + 3, rest);
    else
      TransformPoint(m, &p.positions[3 * v], rest);
    // Displacement by the shapes: world space, or for skinned primitives the morph in
    // mesh space (the skeleton's motion is not the shapes').
    for (int c = 0; c < 3; ++c)
      moved[c] =
          b.skinned ? b.morphed_positions[3 * v + c] - p.positions[3 * v + c] : q[c] - rest[c];
    Eigen::Vector3f n = (nm * Eigen::Map<const Eigen::Vector3f>(&b.normals[3 * v])).normalized();
    if (!n.allFinite()) n = Eigen::Vector3f::UnitZ();
    const float d = std::sqrt(moved[0] * moved[0] + moved[1] * moved[1] + moved[2] * moved[2]);
    scene.heat_max = std::max(scene.heat_max, d);
    scene.box.extend(Eigen::Vector3f(q[0], q[1], q[2]));
    if (!posed) scene.rest_box.extend(Eigen::Vector3f(rest[0], rest[1], rest[2]));
    if (CarriedBy(p, v, joint)) scene.joint_box.extend(Eigen::Vector3f(q[0], q[1], q[2]));
    const float uv[2] = {texcoords.empty() ? 0.0f : texcoords[2 * v],
                         texcoords.empty() ? 0.0f : texcoords[2 * v + 1]};
    verts.insert(verts.end(), {q[0], q[1], q[2], n.x(), n.y(), n.z(), uv[0], uv[1]});
    if (p.colors.empty())
      verts.insert(verts.end(), {1.0f, 1.0f, 1.0f, 1.0f});
    else
      verts.insert(verts.end(), p.colors.begin() + 4 * v, p.colors.begin() + 4 * v + 4);
    if (soft) verts.back() *= fade[v];
    verts.push_back(d);
    const bool baked = occlusion.size() >= kOcclusionFloats * (v + 1);
    if (baked)
      verts.insert(verts.end(), occlusion.begin() + static_cast<long>(kOcclusionFloats * v),
                   occlusion.begin() + static_cast<long>(kOcclusionFloats * (v + 1)));
    else
      verts.insert(verts.end(), kOpenOcclusion.begin(), kOpenOcclusion.end());
  }
}

// The shapes' rest box as the framed joint carries it under the pose (its world now times its world
// at rest, inverted): the face and not the whole head (ears, hair), moving with the head.
Eigen::AlignedBox3f CarriedShapeBox(const Rig& rig, const BlendedRig& blended, const Scene& scene) {
  const size_t node = static_cast<size_t>(scene.joint_node);
  if (node >= blended.node_world.size()) return scene.shape_box;
  const std::vector<std::array<float, 16>> rest = NodeWorldMatrices(rig);
  if (node >= rest.size()) return scene.shape_box;
  const Eigen::Matrix4f now = Eigen::Map<const Eigen::Matrix4f>(blended.node_world[node].data());
  const Eigen::Matrix4f at_rest = Eigen::Map<const Eigen::Matrix4f>(rest[node].data());
  const Eigen::Affine3f carry(now * at_rest.inverse());
  Eigen::AlignedBox3f box;
  for (int corner = 0; corner < 8; ++corner)
    box.extend(carry *
               scene.shape_box.corner(static_cast<Eigen::AlignedBox3f::CornerType>(corner)));
  return box;
}

// Every primitive's vertices and indices, and a draw call each. A framed joint no vertex follows (a
// root, an end site) frames its position, in a tenth of the whole.
void GatherScene(const Rig& rig, const BlendedRig& blended, const RigOcclusion* occlusion,
                 Scene& scene, std::vector<float>& verts, std::vector<uint32_t>& indices) {
  verts.clear();
  indices.clear();
  for (size_t pi = 0; pi < rig.primitives.size(); ++pi) {
    const Primitive& p = rig.primitives[pi];
    const int skin = p.mesh >= 0 && static_cast<size_t>(p.mesh) < rig.meshes.size()
                         ? rig.meshes[static_cast<size_t>(p.mesh)].skin
                         : -1;
    const int joint = skin >= 0 && static_cast<size_t>(skin) < scene.joint_in_skin.size()
                          ? scene.joint_in_skin[static_cast<size_t>(skin)]
                          : -1;
    const size_t first = verts.size() / kFloatsPerVertex;
    const std::span<const float> baked = occlusion && pi < occlusion->size()
                                             ? std::span<const float>((*occlusion)[pi])
                                             : std::span<const float>();
    GatherPrimitive(p, blended.primitives[pi], blended.posed, p.influences > 0 ? joint : -1, baked,
                    SoftStandIn(rig, p.material), scene, verts);
    scene.draws.push_back({first, indices.size(), p.indices.size(), p.mode, p.material});
    for (uint32_t i : p.indices) indices.push_back(static_cast<uint32_t>(first + i));
  }
  if (scene.joint_node >= 0 && scene.carry_shapes && !scene.shape_box.isEmpty())
    scene.joint_box = CarriedShapeBox(rig, blended, scene);
  if (scene.joint_node >= 0 && scene.joint_box.isEmpty()) {
    const size_t node = static_cast<size_t>(scene.joint_node);
    const auto& world = node < blended.node_world.size()
                            ? blended.node_world[node]
                            : std::array<float, 16>{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    const Eigen::Vector3f at(world[12], world[13], world[14]);
    const float r = scene.box.isEmpty() ? 0.1f : 0.05f * scene.box.diagonal().norm();
    scene.joint_box.extend(at - Eigen::Vector3f::Constant(r));
    scene.joint_box.extend(at + Eigen::Vector3f::Constant(r));
  }
}

struct Matrices {
  Eigen::Matrix4f view, proj;
};

// The eye: the look-at camera's, or the orbit's around the framed box, far enough that its bounding
// sphere fits both the vertical and horizontal field of view (of the part of the image left of a
// heatmap's legend: `used`).
void PlaceEye(const picture::Camera& c, const Eigen::Vector3f& center, float radius, float fov,
              float aspect, float used, Eigen::Vector3f& eye, Eigen::Vector3f& target,
              Eigen::Vector3f& up) {
  if (c.look_at) {
    eye = Eigen::Vector3f(c.eye[0], c.eye[1], c.eye[2]);
    target = Eigen::Vector3f(c.target[0], c.target[1], c.target[2]);
    up = Eigen::Vector3f(c.up[0], c.up[1], c.up[2]);
    return;
  }
  const float fit =
      radius /
      std::sin(0.5f * std::min(fov, 2.0f * std::atan(std::tan(0.5f * fov) * aspect * used)));
  const float dist = (c.distance > 0 ? c.distance : fit) / std::max(c.zoom, 1e-3f);
  const float yaw = c.yaw * static_cast<float>(M_PI) / 180.0f,
              pitch = c.pitch * static_cast<float>(M_PI) / 180.0f;
  eye = center + dist * Eigen::Vector3f(std::cos(pitch) * std::sin(yaw), std::sin(pitch),
                                        std::cos(pitch) * std::cos(yaw));
  target = center;
  up = Eigen::Vector3f::UnitY();
}

// The view and projection of the camera over the framed box: the joint's, the shapes', else the
// whole (the rest shape's when not posed, so the camera stays still while weights change).
Result<Matrices> CameraMatrices(const picture::RenderOptions& o, const Scene& scene, bool posed) {
  const picture::Camera& c = o.camera;
  const Eigen::AlignedBox3f& whole =
      !posed && !scene.rest_box.isEmpty() ? scene.rest_box : scene.box;
  const Eigen::AlignedBox3f& framed = scene.joint_node >= 0 ? scene.joint_box
                                      : scene.frame_shapes && !scene.shape_box.isEmpty()
                                          ? scene.shape_box
                                          : whole;
  const Eigen::Vector3f center = framed.isEmpty() ? Eigen::Vector3f(Eigen::Vector3f::Zero())
                                                  : Eigen::Vector3f(framed.center());
  const float radius = framed.isEmpty() ? 1.0f : std::max(0.5f * framed.diagonal().norm(), 1e-6f);
  const float fov = std::clamp(c.fov, 1.0f, 170.0f) * static_cast<float>(M_PI) / 180.0f;
  const float aspect = static_cast<float>(o.width) / static_cast<float>(o.height);
  // A heatmap's legend takes the right of the image: the orbit frames the model left of it (the
  // same scale both ways, the image centre shifted), so no ear runs under the legend.
  const float used = o.view == picture::View::kHeatmap && !c.look_at
                         ? std::clamp(static_cast<float>(HeatLegendLeft(o.width, o.height)) /
                                          static_cast<float>(o.width),
                                      0.5f, 1.0f)
                         : 1.0f;
  Eigen::Vector3f eye, target, up;
  PlaceEye(c, center, radius, fov, aspect, used, eye, target, up);
  Eigen::Vector3f fwd = (target - eye);
  if (fwd.norm() < 1e-12f) return InvalidArgument("camera eye and target coincide");
  fwd.normalize();
  Eigen::Vector3f right = fwd.cross(up);
  if (right.norm() < 1e-6f) right = fwd.cross(Eigen::Vector3f::UnitZ());
  right.normalize();
  const Eigen::Vector3f cam_up = right.cross(fwd);
  Matrices m;
  m.view = Eigen::Matrix4f::Identity();
  m.view.block<1, 3>(0, 0) = right.transpose();
  m.view.block<1, 3>(1, 0) = cam_up.transpose();
  m.view.block<1, 3>(2, 0) = -fwd.transpose();
  m.view(0, 3) = -right.dot(eye);
  m.view(1, 3) = -cam_up.dot(eye);
  m.view(2, 3) = fwd.dot(eye);
  const float center_dist = (center - eye).dot(fwd);
  const float znear = std::max(center_dist - 2.0f * radius,
                               center_dist * 1e-3f > 0 ? center_dist * 1e-3f : radius * 1e-3f);
  const float zfar = std::max(center_dist + 2.0f * radius, znear * 2.0f);
  const float f = 1.0f / std::tan(0.5f * fov);
  m.proj = Eigen::Matrix4f::Zero();
  m.proj(0, 0) = f / aspect;
  m.proj(0, 2) =
      1.0f - used;  // NDC x shifted by used - 1: the centre of the part left of the legend.
  m.proj(1, 1) = f;
  m.proj(2, 2) = (zfar + znear) / (znear - zfar);
  m.proj(2, 3) = 2.0f * zfar * znear / (znear - zfar);
  m.proj(3, 2) = -1.0f;
  return m;
}

// The target bound and cleared: the picture to the background, the label planes (with `labels`) to
// 0.
void ClearTarget(GlContext& gl, int w, int h, bool srgb8, const std::array<float, 4>& bg,
                 bool labels) {
  gl.BindTarget(w, h, srgb8, labels);
  glViewport(0, 0, w, h);
  const float colour[4] = {SrgbToLinear(bg[0]), SrgbToLinear(bg[1]), SrgbToLinear(bg[2]), bg[3]},
              nothing[4] = {0, 0, 0, 0};
  glClearBufferfv(GL_COLOR, 0, colour);
  for (int plane = 1; labels && plane <= 2; ++plane) glClearBufferfv(GL_COLOR, plane, nothing);
  glClear(GL_DEPTH_BUFFER_BIT);
}

// The target cleared, the vertex and index arrays uploaded and laid out.
void Upload(GlContext& gl, int w, int h, bool srgb8, const std::array<float, 4>& bg, bool labels) {
  ClearTarget(gl, w, h, srgb8, bg, labels);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glBindVertexArray(gl.vao);
  glBindBuffer(GL_ARRAY_BUFFER, gl.vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(gl.verts.size() * 4), gl.verts.data(),
               GL_STREAM_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, gl.ibo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(gl.indices.size() * 4),
               gl.indices.data(), GL_STREAM_DRAW);
  const GLsizei stride = kFloatsPerVertex * 4;
  const int sizes[6] = {3, 3, 2, 4, 1, 4}, offsets[6] = {0, 3, 6, 8, 12, 13};
  for (int a = 0; a < 6; ++a) {
    glEnableVertexAttribArray(a);
    glVertexAttribPointer(a, sizes[a], GL_FLOAT, GL_FALSE, stride,
                          reinterpret_cast<void*>(static_cast<uintptr_t>(offsets[a] * 4)));
  }
}

// What every draw call of one pass shares.
struct Pass {
  int shader_mode;  // 0 shaded, 1 edges, 2 heatmap, 3 normals, 4 clay.
  Matrices matrices;
  float heat_max, exposure;
  bool occlusion;  // Baked occlusion drawn (else every vertex is open).
  Eigen::Matrix3f light = Eigen::Matrix3f::Identity();  // Turns the studio's lights.
  bool labels = false;  // The label planes written too (attachments 1 and 2 of the target).
  const std::vector<uint32_t>* segments = nullptr;  // RenderOptions::segment_of_primitive.
};

// The studio's lights turned by yaw about the camera's up, then pitch about its right (degrees).
Eigen::Matrix3f LightTurn(const picture::RenderOptions& o) {
  const float rad = static_cast<float>(M_PI) / 180.0f;
  return (Eigen::AngleAxisf(o.light_yaw * rad, Eigen::Vector3f::UnitY()) *
          Eigen::AngleAxisf(-o.light_pitch * rad, Eigen::Vector3f::UnitX()))
      .toRotationMatrix();
}

// A material's uniforms and textures on `program`.
void SetMaterial(GLuint program, const Pass& pass, const Material& mat,
                 const std::array<float, 4>& base, const GLuint (&textures)[5]) {
  static const char* const kSamplers[5] = {"u_texture", "u_metal_rough_texture", "u_normal_texture",
                                           "u_occlusion_texture", "u_emissive_texture"};
  glUseProgram(program);
  auto at = [program](const char* name) { return glGetUniformLocation(program, name); };
  glUniformMatrix4fv(at("u_view"), 1, GL_FALSE, pass.matrices.view.data());
  glUniformMatrix4fv(at("u_proj"), 1, GL_FALSE, pass.matrices.proj.data());
  glUniform1f(at("u_heat_max"), pass.heat_max);
  glUniform1f(at("u_exposure"), pass.exposure);
  glUniform1f(at("u_baked"), pass.occlusion ? 1.0f : 0.0f);
  glUniform4f(at("u_base_color"), base[0], base[1], base[2], base[3]);
  glUniform2f(at("u_metal_rough"), mat.metallic_factor, mat.roughness_factor);
  glUniform1f(at("u_normal_scale"), mat.normal_scale);
  glUniform1f(at("u_occlusion_strength"), mat.occlusion_strength);
  glUniform3f(at("u_emissive"), mat.emissive_factor[0], mat.emissive_factor[1],
              mat.emissive_factor[2]);
  glUniform1f(at("u_alpha_cutoff"), mat.alpha_cutoff);
  glUniformMatrix3fv(at("u_light"), 1, GL_FALSE, pass.light.data());
  for (int unit = 0; unit < 5; ++unit) {
    glUniform1i(at(kSamplers[unit]), unit);
    glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(unit));
    glBindTexture(GL_TEXTURE_2D, textures[unit]);
  }
}

// Whether a draw call shows in the labels: triangles of a material that is not wholly transparent
// (MMD's hidden overlays, shown by material morphs, have alpha 0 until then).
bool Labelled(const Rig& rig, const BlendedRig& blended, const DrawCall& d) {
  return d.mode == PrimitiveMode::kTriangles && DrawnAlpha(rig, blended, d.material) > 0.0f;
}

// Whether draws write the label planes (attachments 1 and 2): on for the draws they show, off for
// the others (no depth either: a wholly transparent overlay hides nothing).
void LabelWrites(bool on) {
  for (GLuint plane = 1; plane <= 2; ++plane) glColorMaski(plane, on, on, on, on);
}

// One pass over every draw call. A primitive with no material draws as light grey clay, not glTF's
// default (a rough metal, dark without a detailed environment), so material-less meshes (OBJ,
// MakeHuman) read as shapes.
Status DrawPass(GlContext& gl, const Rig& rig, const BlendedRig& blended, const Scene& scene,
                const Pass& pass) {
  Material none;
  none.base_color_factor = {0.8f, 0.8f, 0.8f, 1.0f};
  none.metallic_factor = 0.0f;
  none.roughness_factor = 0.5f;
  for (const DrawCall& d : scene.draws) {
    const Material& mat = d.material >= 0 ? rig.materials[static_cast<size_t>(d.material)] : none;
    // The colour under the shapes' material morphs (MMD's blush, pallor), else the material's own.
    const bool morphed =
        d.material >= 0 && static_cast<size_t>(d.material) < blended.material_colors.size();
    const auto& base =
        morphed ? blended.material_colors[static_cast<size_t>(d.material)] : mat.base_color_factor;
    const bool blend =
        mat.alpha_mode == "BLEND" || (morphed && base[3] < 1.0f) || SoftStandIn(rig, d.material);
    // The material's textures (clay, heatmap, normals and edges use none), each decoded before
    // any is bound: a decode binds on the active unit.
    const bool textured = pass.shader_mode == 0;
    const int images[5] = {mat.base_color_image, mat.metallic_roughness_image, mat.normal_image,
                           mat.occlusion_image, mat.emissive_image};
    const bool srgb[5] = {true, false, false, false, true};
    GLuint textures[5] = {};
    for (int unit = 0; textured && unit < 5; ++unit) {
      if (images[unit] >= 0)
        textures[unit] = gl.TextureFor(rig.images[static_cast<size_t>(images[unit])], srgb[unit]);
    }
    const int alpha_mode = !textured ? 0 : blend ? 2 : mat.alpha_mode == "MASK" ? 1 : 0;
    const GLuint program =
        gl.Program(ShaderKey(pass.shader_mode, alpha_mode, textures, pass.labels));
    if (!program) return Internal("renderer: " + gl.error);
    SetMaterial(program, pass, mat, base, textures);
    if (pass.labels) {
      const size_t i = static_cast<size_t>(&d - scene.draws.data());
      const uint32_t id =
          i < pass.segments->size() ? (*pass.segments)[i] : static_cast<uint32_t>(d.material + 1);
      glUniform1f(glGetUniformLocation(program, "u_segment"),
                  static_cast<float>(std::min<uint32_t>(id, 65535)));
      const bool shows = Labelled(rig, blended, d);
      LabelWrites(shows);
      glDepthMask(shows ? GL_TRUE : GL_FALSE);
    }
    if (alpha_mode == 2) {
      glEnablei(
          GL_BLEND,
          0);  // The picture only: the label planes take the nearest surface as it is, not a mix.
      glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE,
                          GL_ONE_MINUS_SRC_ALPHA);  // "Over", alpha too.
    } else {
      glDisable(GL_BLEND);
    }
    const GLenum prim = d.mode == PrimitiveMode::kTriangles ? GL_TRIANGLES
                        : d.mode == PrimitiveMode::kLines   ? GL_LINES
                                                            : GL_POINTS;
    glDrawElements(prim, static_cast<GLsizei>(d.index_count), GL_UNSIGNED_INT,
                   reinterpret_cast<void*>(static_cast<uintptr_t>(d.first_index * 4)));
  }
  // Writes on again: masks hold for clears too, and a plane left masked would keep the last
  // render's labels.
  if (pass.labels) LabelWrites(true);
  glDepthMask(GL_TRUE);
  return Status::Ok();
}

// Whether the label planes are drawn with the picture, by the same fragments (one sample a pixel),
// or apart after it (a supersampled picture: DrawLabelsApart).
bool LabelsInPicture(const picture::RenderOptions& o) { return o.labels && o.supersample == 1; }

// The view's passes: one, or for the wireframe the shaded surface pushed back and its edges over
// it.
Status DrawView(GlContext& gl, const Rig& rig, const BlendedRig& blended, const Scene& scene,
                const picture::RenderOptions& o, const Matrices& m) {
  const int mode = o.view == picture::View::kHeatmap   ? 2
                   : o.view == picture::View::kNormals ? 3
                   : o.view == picture::View::kClay    ? 4
                                                       : 0;
  Pass pass{mode,
            m,
            scene.heat_max,
            std::exp2(std::clamp(o.exposure, -10.0f, 10.0f)),
            o.occlusion != nullptr,
            LightTurn(o)};
  pass.labels = LabelsInPicture(o);
  pass.segments = &o.segment_of_primitive;
  if (o.view == picture::View::kWireframe) {
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.0f, 1.0f);
  }
  Status drawn = DrawPass(gl, rig, blended, scene, pass);
  glDisable(GL_POLYGON_OFFSET_FILL);
  if (o.view == picture::View::kWireframe && drawn.ok()) {
    glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
    glDepthFunc(GL_LEQUAL);
    pass.shader_mode = 1;
    pass.labels = false;  // The edges are not the surface: its labels stay.
    LabelWrites(false);
    drawn = DrawPass(gl, rig, blended, scene, pass);
    LabelWrites(true);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    glDepthFunc(GL_LESS);
  }
  return drawn;
}

// The w x h target into `data`, top row first (MESA_pack_invert): no 4 MB copy to flip the rows.
Status ReadTopFirst(int w, int h, GLenum format, GLenum type, void* data) {
  glPixelStorei(GL_PACK_INVERT_MESA, GL_TRUE);
  glReadPixels(0, 0, w, h, format, type, data);
  glPixelStorei(GL_PACK_INVERT_MESA, GL_FALSE);
  const GLenum err = glGetError();
  return err == GL_NO_ERROR ? Status::Ok() : Internal("GL error " + std::to_string(err));
}

// Bottom-row-first supersampled floats box-filtered (in linear light) into `out`, top row first.
void BoxFilter(std::span<const float> pixels, int w, int h, int ss, picture::Image& out) {
  // Zeros where the supersamples add up; rows copied over whatever was there otherwise.
  if (ss > 1)
    out.rgba.assign(static_cast<size_t>(out.width) * out.height * 4, 0.0f);
  else
    out.rgba.resize(static_cast<size_t>(out.width) * out.height * 4);
  const float inv = 1.0f / static_cast<float>(ss * ss);
  for (int y = 0; ss == 1 && y < out.height; ++y) {  // No supersampling: rows flipped, as they are.
    std::memcpy(&out.rgba[static_cast<size_t>(y) * out.width * 4],
                &pixels[static_cast<size_t>(h - 1 - y) * w * 4], static_cast<size_t>(w) * 16);
  }
  for (int y = 0; ss > 1 && y < out.height; ++y) {
    for (int x = 0; x < out.width; ++x) {
      float* dst = &out.rgba[(static_cast<size_t>(y) * out.width + x) * 4];
      for (int sy = 0; sy < ss; ++sy) {
        const int gy = h - 1 - (y * ss + sy);
        for (int sx = 0; sx < ss; ++sx) {
          const float* src = &pixels[(static_cast<size_t>(gy) * w + x * ss + sx) * 4];
          for (int ch = 0; ch < 4; ++ch) dst[ch] += src[ch] * inv;
        }
      }
    }
  }
}

// The drawn target into `out`: the sRGB bytes as they are, or floats (box-filtered when
// supersampled), with the heatmap's legend drawn over.
Status ReadBack(GlContext& gl, const picture::RenderOptions& o, bool srgb8, float heat_max,
                picture::Image& out) {
  const int ss = o.supersample, w = o.width * ss, h = o.height * ss;
  out.width = o.width;
  out.height = o.height;
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  if (srgb8) {
    glDisable(GL_FRAMEBUFFER_SRGB);  // The stored sRGB bytes, no conversion on the way out.
    out.rgba.clear();
    out.srgb8.resize(static_cast<size_t>(w) * h * 4);
    return ReadTopFirst(w, h, GL_RGBA, GL_UNSIGNED_BYTE, out.srgb8.data());
  }
  out.srgb8.clear();
  if (ss == 1 && gl.pack_invert) {
    out.rgba.resize(static_cast<size_t>(w) * h * 4);
    if (Status s = ReadTopFirst(w, h, GL_RGBA, GL_FLOAT, out.rgba.data()); !s.ok()) return s;
  } else {
    std::vector<float>& pixels = gl.pixels;
    pixels.resize(static_cast<size_t>(w) * h * 4);
    glReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, pixels.data());
    if (const GLenum err = glGetError(); err != GL_NO_ERROR)
      return Internal("GL error " + std::to_string(err));
    BoxFilter(pixels, w, h, ss, out);
  }
  if (o.view == picture::View::kHeatmap) DrawHeatLegend(out, heat_max);
  return Status::Ok();
}

// The label planes (attachments 1 and 2 of the bound target, w x h) into `out`, top row first.
Status ReadLabels(GlContext& gl, int w, int h, picture::LabelPlanes& out) {
  const size_t n = static_cast<size_t>(w) * h;
  gl.pixels.resize(4 * n);
  glReadBuffer(GL_COLOR_ATTACHMENT1);
  Status s = ReadTopFirst(w, h, GL_RGBA, GL_FLOAT, gl.pixels.data());
  out.distance.resize(n);
  out.normal.resize(3 * n);
  for (size_t i = 0; i < n && s.ok(); ++i) {
    out.distance[i] = gl.pixels[4 * i];
    for (int c = 0; c < 3; ++c) out.normal[3 * i + c] = gl.pixels[4 * i + 1 + c];
  }
  glReadBuffer(GL_COLOR_ATTACHMENT2);
  if (s.ok()) s = ReadTopFirst(w, h, GL_RED, GL_FLOAT, gl.pixels.data());
  out.segment.resize(n);
  for (size_t i = 0; i < n && s.ok(); ++i)
    out.segment[i] = static_cast<uint16_t>(gl.pixels[i] + 0.5f);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  return s;
}

// The label planes of a supersampled picture: drawn again at its size (the arrays the picture
// uploaded), one sample a pixel, colour not written.
Status DrawLabelsApart(GlContext& gl, const Rig& rig, const BlendedRig& blended, const Scene& scene,
                       const picture::RenderOptions& o, const Matrices& m,
                       picture::LabelPlanes& out) {
  ClearTarget(gl, o.width, o.height, false, {0, 0, 0, 0}, true);
  glColorMaski(0, GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
  Pass pass{1, m, 0.0f, 1.0f, false};
  pass.labels = true;
  pass.segments = &o.segment_of_primitive;
  Status s = DrawPass(gl, rig, blended, scene, pass);
  glColorMaski(0, GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  return s.ok() ? ReadLabels(gl, o.width, o.height, out) : s;
}

}  // namespace

// The draw as its stages: framing, the scene gathered in world space, the camera, the upload, the
// view's passes, the read-back.
Status OsMesaRenderer::Draw(const Rig& rig, const BlendedRig& blended,
                            const picture::RenderOptions& o, picture::Image& out) const {
  if (Status s = CheckDrawInputs(rig, blended, o); !s.ok()) return s;
  Scene scene;
  if (Status s = ChooseFraming(rig, o.camera, scene); !s.ok()) return s;
  // A context from the pool for the whole render: the vertex arrays and the read-back below
  // then exist for at most Concurrency() renders at once, however many requests wait.
  auto lease = pool_->Acquire(o.helper_cpu);
  if (!lease.ok()) return lease.status();
  GlContext& gl = *lease.value().get();
  struct Trim {  // Before the lease lets the context go: it is still current here.
    GlContext& gl;
    ~Trim() { gl.TrimLarge(); }
  } trim{gl};
  GatherScene(rig, blended, o.occlusion.get(), scene, gl.verts, gl.indices);
  auto matrices = CameraMatrices(o, scene, blended.posed);
  if (!matrices.ok()) return matrices.status();
  // Straight to 8 bits where asked and nothing after the draw needs floats (the box filter of
  // supersamples, the heatmap's legend).
  const bool srgb8 =
      o.srgb8 && o.supersample == 1 && o.view != picture::View::kHeatmap && gl.pack_invert;
  Upload(gl, o.width * o.supersample, o.height * o.supersample, srgb8, o.background,
         LabelsInPicture(o));
  if (Status s = DrawView(gl, rig, blended, scene, o, matrices.value()); !s.ok()) return s;
  if (Status s = ReadBack(gl, o, srgb8, scene.heat_max, out); !s.ok()) return s;
  Eigen::Map<Eigen::Matrix4f>(out.view.data()) = matrices->view;
  Eigen::Map<Eigen::Matrix4f>(out.projection.data()) = matrices->proj;
  if (!o.labels) {
    out.labels.distance.clear(), out.labels.normal.clear(), out.labels.segment.clear();
    return Status::Ok();
  }
  if (!gl.pack_invert) return Internal("renderer: the labels need GL_MESA_pack_invert");
  if (LabelsInPicture(o)) return ReadLabels(gl, o.width, o.height, out.labels);
  return DrawLabelsApart(gl, rig, blended, scene, o, matrices.value(), out.labels);
}

}  // namespace facespace::offscreen
