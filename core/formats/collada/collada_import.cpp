// COLLADA 1.4/1.5 (.dae) as a Rig: geometry (triangles, polylist, polygons; shared or split
// inputs), the node hierarchy (matrix, translate, rotate, scale), morph controllers (NORMALIZED and
// RELATIVE), skin controllers (bind shape matrix, inverse binds, any number of influences), a skin
// over a morph, base colours, and animated morph weights as clips.
//
// A parser of untrusted XML (pugixml reads it): every index is checked against its source's
// accessor, every reference resolved or reported, nesting and instancing capped.
#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <map>
#include <pugixml.hpp>
#include <set>
#include <string_view>
#include <unordered_map>

#include "collada/reader.h"

namespace facespace::formats::collada {

Result<Rig> Reader::Run() {
  root_ = doc_.child("COLLADA");
  if (!root_) return Bad("no <COLLADA> root element");
  IndexIds(root_);
  if (Status s = Scene(); !s.ok()) return s;
  if (rig_.primitives.empty()) return Bad("the scene shows no mesh");
  if (Status s = Animations(); !s.ok()) return s;
  CountMovedVertices(rig_);
  DetectSymmetricPartners(rig_);
  RepairNames(rig_);
  if (Status s = ValidateRig(rig_); !s.ok()) return s;
  return std::move(rig_);
}

Mat4 Reader::LocalTransform(pugi::xml_node node) {
  Mat4 m = Mat4::Identity();
  for (pugi::xml_node t : node.children()) {
    const std::string_view kind = t.name();
    std::vector<double> v;
    if (kind != "matrix" && kind != "translate" && kind != "rotate" && kind != "scale" &&
        kind != "lookat" && kind != "skew")
      continue;
    if (!ParseNumbers(t.child_value(), v, 16)) v.clear();
    if (kind == "matrix" && v.size() == 16) {
      m = m * RowMajor(v.data());
    } else if (kind == "translate" && v.size() == 3) {
      m = m * Eigen::Affine3d(Eigen::Translation3d(v[0], v[1], v[2])).matrix();
    } else if (kind == "rotate" && v.size() == 4 && Vec3(v[0], v[1], v[2]).norm() > 0) {
      m = m * Eigen::Affine3d(
                  Eigen::AngleAxisd(v[3] * M_PI / 180.0, Vec3(v[0], v[1], v[2]).normalized()))
                  .matrix();
    } else if (kind == "scale" && v.size() == 3) {
      m = m * Eigen::Affine3d(Eigen::Scaling(v[0], v[1], v[2])).matrix();
    } else {
      rig_.load_warnings.push_back(
          {"transform_skipped",
           Describe(node) + ": <" + std::string(kind) + "> is not read (or malformed)", "", 0.0,
           false});
    }
  }
  return m;
}

Status Reader::Scene() {
  pugi::xml_node scene =
      ById(root_.child("scene").child("instance_visual_scene").attribute("url").value());
  if (!scene) scene = root_.child("library_visual_scenes").child("visual_scene");
  if (!scene) return Bad("no <visual_scene>");
  // Z_UP (or X_UP) files get a root node that turns them Y-up, as glTF wants.
  const std::string_view up = root_.child("asset").child_value("up_axis");
  int parent = -1;
  if (up == "Z_UP" || up == "X_UP") {
    Node r;
    r.name = "collada_root";
    r.rotation = up == "Z_UP" ? std::array<float, 4>{-0.70710678f, 0, 0, 0.70710678f}
                              : std::array<float, 4>{0, 0, 0.70710678f, 0.70710678f};
    rig_.nodes.push_back(r);
    rig_.scene_roots.push_back(0);
    parent = 0;
  }
  first_node_ = rig_.nodes.size();
  // Nodes first (joints must exist before skins resolve them), instances after.
  std::vector<std::pair<pugi::xml_node, int>> instances;
  struct Item {
    pugi::xml_node node;
    int parent;
    size_t depth;
  };
  std::vector<Item> stack;
  for (pugi::xml_node n = scene.last_child(); n; n = n.previous_sibling()) {
    if (std::strcmp(n.name(), "node") == 0) stack.push_back({n, parent, 0});
  }
  while (!stack.empty()) {
    const Item it = stack.back();
    stack.pop_back();
    if (it.depth >= kMaxDepth)
      return Bad(Describe(it.node) + ": nodes nested deeper than " + std::to_string(kMaxDepth) +
                 " (or an <instance_node> cycle)");
    if (rig_.nodes.size() >= kMaxNodes)
      return Bad("more than " + std::to_string(kMaxNodes) + " nodes");
    Node n;
    n.name = it.node.attribute("name").value()[0] ? it.node.attribute("name").value()
                                                  : it.node.attribute("id").value();
    n.parent = it.parent;
    SetNodeLocal(n, LocalTransform(it.node));
    const int index = static_cast<int>(rig_.nodes.size());
    if (it.parent >= 0) {
      rig_.nodes[it.parent].children.push_back(index);
    } else {
      rig_.scene_roots.push_back(index);
    }
    rig_.nodes.push_back(std::move(n));
    node_xml_.push_back(it.node);
    std::vector<pugi::xml_node> kids;
    for (pugi::xml_node c : it.node.children()) {
      const std::string_view kind = c.name();
      if (kind == "node") kids.push_back(c);
      if (kind == "instance_node") {
        pugi::xml_node target = ById(c.attribute("url").value());
        if (target && std::strcmp(target.name(), "node") == 0) kids.push_back(target);
      }
      if (kind == "instance_geometry" || kind == "instance_controller")
        instances.emplace_back(c, index);
    }
    for (auto k = kids.rbegin(); k != kids.rend(); ++k) stack.push_back({*k, index, it.depth + 1});
  }
  world_ = NodeWorldMatrices(rig_);
  for (const auto& [inst, node] : instances) {
    if (Status s = Instance(inst, node); !s.ok()) return s;
  }
  return Status::Ok();
}

// The node a skin's joint name means: a sid under the <skeleton> roots, else an id, else a name.
int Reader::JointNode(const std::string& name, bool is_id,
                      const std::vector<int>& skeleton_roots) const {
  auto find = [&](auto match) {
    for (size_t i = 0; i < node_xml_.size(); ++i) {
      if (match(node_xml_[i])) return static_cast<int>(first_node_ + i);
    }
    return -1;
  };
  if (!is_id && !skeleton_roots.empty()) {
    for (size_t i = 0; i < node_xml_.size(); ++i) {
      const int ni = static_cast<int>(first_node_ + i);
      if (name != node_xml_[i].attribute("sid").value()) continue;
      for (int a = ni; a >= 0; a = rig_.nodes[a].parent) {
        if (std::find(skeleton_roots.begin(), skeleton_roots.end(), a) != skeleton_roots.end())
          return ni;
      }
    }
  }
  int n = find([&](pugi::xml_node x) { return name == x.attribute("id").value(); });
  if (n < 0 && !is_id)
    n = find([&](pugi::xml_node x) { return name == x.attribute("sid").value(); });
  if (n < 0) n = find([&](pugi::xml_node x) { return name == x.attribute("name").value(); });
  return n;
}

int Reader::NodeOfXml(pugi::xml_node x) const {
  for (size_t i = 0; i < node_xml_.size(); ++i) {
    if (node_xml_[i] == x) return static_cast<int>(first_node_ + i);
  }
  return -1;
}

Mat4 Reader::World(int node) const {
  Mat4 m;
  for (int k = 0; k < 16; ++k) m(k % 4, k / 4) = world_[node][k];
  return m;
}

// The file a diffuse <texture texture="NAME"> shows: NAME is a sampler2D newparam whose <source>
// names a surface newparam whose <init_from> is an image (COLLADA 1.4), or a sampler2D with an
// <instance_image> (1.5), or, as some exporters write, the image's id itself. The image's URI is
// made a path relative to the model's folder ("file://" and %-escapes undone); an absolute path
// keeps its file name only (exporters write where the image was on the author's disk; tools then
// look beside the model). LoadImagesBeside reads it from the model's folder, never outside it.
std::string Reader::TextureFile(pugi::xml_node profile, const std::string& name) const {
  auto param = [&](const std::string& sid) {
    for (pugi::xml_node np : profile.children("newparam")) {
      if (sid == np.attribute("sid").value()) return np;
    }
    return pugi::xml_node();
  };
  auto trim = [](std::string t) {
    const size_t a = t.find_first_not_of(" \t\r\n"), b = t.find_last_not_of(" \t\r\n");
    return a == std::string::npos ? std::string() : t.substr(a, b - a + 1);
  };
  std::string image_id = name;
  if (pugi::xml_node sampler = param(name).child("sampler2D")) {
    if (pugi::xml_node inst = sampler.child("instance_image"))
      image_id = std::string(Fragment(inst.attribute("url").value()));
    else if (pugi::xml_node surface = param(trim(sampler.child_value("source"))).child("surface"))
      image_id = trim(surface.child_value("init_from"));
  }
  pugi::xml_node image = ById(image_id);
  if (!image || std::strcmp(image.name(), "image") != 0) return "";
  pugi::xml_node init = image.child("init_from");
  std::string uri = trim(init.child("ref") ? init.child_value("ref") : init.child_value());
  if (uri.rfind("file://", 0) == 0) uri.erase(0, 7);
  const auto hex = [](char c) {
    return std::isxdigit(static_cast<unsigned char>(c))
               ? (std::isdigit(static_cast<unsigned char>(c)) ? c - '0' : (c | 0x20) - 'a' + 10)
               : -1;
  };
  std::string path;
  for (size_t k = 0; k < uri.size(); ++k) {
    if (uri[k] == '%' && k + 2 < uri.size() && hex(uri[k + 1]) >= 0 && hex(uri[k + 2]) >= 0) {
      path += static_cast<char>(hex(uri[k + 1]) * 16 + hex(uri[k + 2]));
      k += 2;
    } else {
      path += uri[k] == '\\' ? '/' : uri[k];
    }
  }
  if (!path.empty() && (path[0] == '/' || path.find(':') != std::string::npos))
    path = path.substr(path.find_last_of("/:") + 1);
  return path;
}

// The rig's image for a file beside the model: one per file, however many materials show it.
int Reader::ImageNamed(const std::string& file) {
  for (size_t i = 0; i < rig_.images.size(); ++i) {
    if (rig_.images[i].name == file) return static_cast<int>(i);
  }
  return AddImageBeside(rig_, file);
}

int Reader::Material(pugi::xml_node inst, const std::string& symbol) {
  for (pugi::xml_node im :
       inst.child("bind_material").child("technique_common").children("instance_material")) {
    if (symbol != im.attribute("symbol").value()) continue;
    pugi::xml_node mat = ById(im.attribute("target").value());
    if (!mat) return -1;
    const std::string id = mat.attribute("id").value();
    if (auto it = material_of_.find(id); it != material_of_.end()) return it->second;
    facespace::Material m;
    m.name = mat.attribute("name").value()[0] ? mat.attribute("name").value() : id;
    m.metallic_factor = 0.0f;
    m.roughness_factor = 0.8f;
    pugi::xml_node effect = ById(mat.child("instance_effect").attribute("url").value());
    for (pugi::xml_node tech : effect.child("profile_COMMON").child("technique").children()) {
      pugi::xml_node diffuse = tech.child("diffuse");
      std::vector<double> c;
      if (diffuse.child("color") && ParseNumbers(diffuse.child_value("color"), c, 4) &&
          c.size() >= 3) {
        for (size_t k = 0; k < 3; ++k)
          m.base_color_factor[k] = static_cast<float>(std::clamp(c[k], 0.0, 1.0));
      } else if (pugi::xml_node texture = diffuse.child("texture")) {
        const std::string file =
            TextureFile(effect.child("profile_COMMON"), texture.attribute("texture").value());
        if (file.empty()) {
          rig_.load_warnings.push_back(
              {"texture_not_loaded",
               "material '" + m.name + "': its diffuse texture names no image", m.name, 0.0,
               false});
        } else {
          m.base_color_image = ImageNamed(file);
        }
      }
    }
    rig_.materials.push_back(m);
    material_of_[id] = static_cast<int>(rig_.materials.size()) - 1;
    return material_of_[id];
  }
  return -1;
}

Status Reader::ResolveInstance(pugi::xml_node inst, InstanceChain& chain) {
  chain.target = ById(inst.attribute("url").value());
  for (int hops = 0;
       chain.target && std::strcmp(chain.target.name(), "controller") == 0 && hops < 4; ++hops) {
    if (pugi::xml_node s = chain.target.child("skin"); s && !chain.skin) {
      chain.skin = s;
      chain.skin_controller = chain.target;
      chain.target = ById(s.attribute("source").value());
    } else if (pugi::xml_node m = chain.target.child("morph"); m && !chain.morph) {
      chain.morph = m;
      chain.morph_controller = chain.target;
      chain.target = ById(m.attribute("source").value());
    } else {
      return Bad(Describe(chain.target) +
                 ": a controller chain that is not skin -> morph -> geometry");
    }
  }
  return Status::Ok();
}

void Reader::PlacePrimitives(pugi::xml_node inst, int mesh_index, const SkinData* skin,
                             const Morph& m, Split& split) {
  const Eigen::Matrix3d linear =
      skin ? Eigen::Matrix3d(skin->bind_shape.block<3, 3>(0, 0)) : Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d normal_matrix = linear.inverse().transpose();
  for (size_t p = 0; p < split.primitives.size(); ++p) {
    Primitive& prim = split.primitives[p];
    prim.mesh = mesh_index;
    prim.index_in_mesh = static_cast<int>(p);
    prim.material = Material(inst, split.material_symbol[p]);
    const std::vector<uint32_t>& points = split.point_of_vertex[p];
    for (size_t v = 0; skin && v < points.size();
         ++v) {  // The bind shape matrix goes into the vertices, as glTF has none.
      const Eigen::Vector4d q =
          skin->bind_shape * Eigen::Vector4d(prim.positions[3 * v], prim.positions[3 * v + 1],
                                             prim.positions[3 * v + 2], 1.0);
      for (int a = 0; a < 3; ++a) prim.positions[3 * v + a] = static_cast<float>(q[a]);
      if (!prim.normals.empty()) {
        const Vec3 n = (normal_matrix *
                        Vec3(prim.normals[3 * v], prim.normals[3 * v + 1], prim.normals[3 * v + 2]))
                           .normalized();
        for (int a = 0; a < 3; ++a) prim.normals[3 * v + a] = static_cast<float>(n[a]);
      }
    }
    for (const std::vector<double>& delta : m.targets) {
      SparseTarget t;
      for (size_t v = 0; v < points.size(); ++v) {
        const Vec3 d = linear * Vec3(&delta[3 * points[v]]);
        if (d.isZero(0)) continue;
        t.indices.push_back(static_cast<uint32_t>(v));
        for (int a = 0; a < 3; ++a) t.position_deltas.push_back(static_cast<float>(d[a]));
      }
      FinalizeTarget(t);
      prim.targets.push_back(std::move(t));
    }
  }
}

void Reader::AddMorphShapes(const Morph& m, int node, facespace::Mesh& mesh) {
  for (size_t t = 0; t < m.targets.size(); ++t) {
    Shape shape;
    shape.name = m.names[t];
    for (int k = 2; FindShape(rig_, shape.name) >= 0; ++k)
      shape.name = mesh.name + "." + m.names[t] + (k > 2 ? "_" + std::to_string(k) : "");
    shape.default_weight = static_cast<float>(m.weights[t]);
    shape.min = std::min(0.0f, shape.default_weight);
    shape.max = std::max(1.0f, shape.default_weight);
    mesh.target_shapes.push_back(static_cast<uint32_t>(rig_.shapes.size()));
    morph_shapes_[m.weights_source].push_back(static_cast<uint32_t>(rig_.shapes.size()));
    rig_.shapes.push_back(shape);
  }
  if (!m.weights_source.empty()) morph_node_[m.weights_source] = node;
}

Status Reader::AddSkin(pugi::xml_node inst, const InstanceChain& chain, int node, SkinData& sd,
                       Split& split, facespace::Mesh& mesh) {
  std::vector<int> roots;
  for (pugi::xml_node s : inst.children("skeleton")) {
    const int r = NodeOfXml(ById(s.child_value()));
    if (r >= 0) roots.push_back(r);
  }
  facespace::Skin out;
  out.name = chain.skin_controller.attribute("id").value();
  for (size_t j = 0; j < sd.joint_names.size(); ++j) {
    const int jn = JointNode(sd.joint_names[j], sd.names_are_ids, roots);
    if (jn < 0)
      return Bad(Describe(chain.skin_controller) + ": joint '" + sd.joint_names[j].substr(0, 60) +
                 "' is no node of the scene");
    out.joints.push_back(jn);
    for (int k = 0; k < 16; ++k)
      out.inverse_bind.push_back(static_cast<float>(sd.inverse_binds[j](k % 4, k / 4)));
  }
  // Vertices no joint weighs follow the instancing node.
  bool unweighted = false;
  for (const auto& inf : sd.influences) unweighted |= inf.empty();
  if (unweighted) {
    const uint32_t extra = static_cast<uint32_t>(out.joints.size());
    out.joints.push_back(node);
    const Mat4 ib = World(node).inverse();
    for (int k = 0; k < 16; ++k) out.inverse_bind.push_back(static_cast<float>(ib(k % 4, k / 4)));
    for (auto& inf : sd.influences) {
      if (inf.empty()) inf.emplace_back(extra, 1.0f);
    }
    rig_.load_warnings.push_back({"unweighted_vertices",
                                  Describe(chain.skin_controller) +
                                      ": vertices without joint weights follow node '" +
                                      rig_.nodes[node].name + "'",
                                  "", 0.0, false});
  }
  for (size_t p = 0; p < split.primitives.size(); ++p)
    SetInfluences(split.primitives[p], split.point_of_vertex[p], sd.influences);
  mesh.skin = static_cast<int>(rig_.skins.size());
  rig_.joint_count += out.joints.size();
  rig_.skins.push_back(std::move(out));
  rig_.skin_count = rig_.skins.size();
  return Status::Ok();
}

void Reader::AttachMesh(Split& split, facespace::Mesh mesh, int node,
                        const std::string& weights_source) {
  const int mesh_index = static_cast<int>(rig_.meshes.size());
  for (Primitive& p : split.primitives) {
    FinalizePrimitive(p);
    mesh.primitives.push_back(static_cast<int>(rig_.primitives.size()));
    rig_.primitives.push_back(std::move(p));
  }
  rig_.meshes.push_back(std::move(mesh));
  if (rig_.nodes[node].mesh < 0) {
    rig_.nodes[node].mesh = mesh_index;
    return;
  }
  Node extra;  // A second instance on one node: a child node carries it.
  extra.name = rig_.nodes[node].name + "_" + std::to_string(mesh_index);
  extra.parent = node;
  extra.mesh = mesh_index;
  rig_.nodes[node].children.push_back(static_cast<int>(rig_.nodes.size()));
  rig_.nodes.push_back(extra);
  world_ = NodeWorldMatrices(rig_);
  if (!morph_node_.empty() && !weights_source.empty())
    morph_node_[weights_source] = static_cast<int>(rig_.nodes.size()) - 1;
}

Status Reader::Instance(pugi::xml_node inst, int node) {
  InstanceChain chain;
  if (Status s = ResolveInstance(inst, chain); !s.ok()) return s;
  if (!chain.target || std::strcmp(chain.target.name(), "geometry") != 0) {
    rig_.load_warnings.push_back({"instance_skipped",
                                  Describe(inst) + " '" +
                                      std::string(inst.attribute("url").value()).substr(0, 60) +
                                      "' does not lead to a geometry",
                                  "", 0.0, false});
    return Status::Ok();
  }
  Split split;
  if (Status s = SplitGeometry(chain.target, split); !s.ok()) return s;
  if (split.primitives.empty()) return Status::Ok();
  facespace::Mesh mesh;
  mesh.name = rig_.nodes[node].name;
  Morph m;
  if (chain.morph) {
    if (Status s =
            ReadMorph(chain.morph_controller, chain.morph, split.point_count, split.points, m);
        !s.ok())
      return s;
  }
  SkinData sd;
  if (chain.skin) {
    if (Status s = ReadSkin(chain.skin_controller, chain.skin, split.point_count, sd); !s.ok())
      return s;
  }
  PlacePrimitives(inst, static_cast<int>(rig_.meshes.size()), chain.skin ? &sd : nullptr, m, split);
  AddMorphShapes(m, node, mesh);
  if (chain.skin) {
    if (Status s = AddSkin(inst, chain, node, sd, split, mesh); !s.ok()) return s;
  }
  AttachMesh(split, std::move(mesh), node, m.weights_source);
  return Status::Ok();
}

Status Reader::Animations() {
  // Channels whose target is "<weights source id>(<index>)": a morph weight.
  std::map<std::string, std::map<size_t, Curve>>
      curves;  // weights source -> target index -> curve.
  size_t skipped = 0;
  std::vector<pugi::xml_node> stack;
  for (pugi::xml_node a : root_.child("library_animations").children("animation"))
    stack.push_back(a);
  while (!stack.empty()) {
    pugi::xml_node anim = stack.back();
    stack.pop_back();
    for (pugi::xml_node a : anim.children("animation")) {
      if (stack.size() < kMaxNodes) stack.push_back(a);
    }
    for (pugi::xml_node ch : anim.children("channel")) {
      const std::string target = ch.attribute("target").value();
      const size_t open = target.find('(');
      const std::string src = target.substr(0, open);
      if (open == std::string::npos || target.back() != ')' || !morph_shapes_.count(src)) {
        ++skipped;
        continue;
      }
      const long long index = std::strtoll(target.c_str() + open + 1, nullptr,
                                           10);  // Saturates where atoll is undefined.
      if (index < 0 || static_cast<size_t>(index) >= morph_shapes_[src].size()) {
        ++skipped;
        continue;
      }
      pugi::xml_node sampler = ById(ch.attribute("source").value());
      Curve c;
      Source in, out, tin, tout, interp;
      for (pugi::xml_node i : sampler.children("input")) {
        const std::string_view sem = i.attribute("semantic").value();
        Source* dst = sem == "INPUT"           ? &in
                      : sem == "OUTPUT"        ? &out
                      : sem == "IN_TANGENT"    ? &tin
                      : sem == "OUT_TANGENT"   ? &tout
                      : sem == "INTERPOLATION" ? &interp
                                               : nullptr;
        if (dst) {
          if (Status s = ReadSource(ById(i.attribute("source").value()), *dst); !s.ok()) return s;
        }
      }
      if (in.count == 0 || in.count != out.count || out.numbers.empty())
        return Bad(Describe(sampler) + ": INPUT and OUTPUT differ in length (or are empty)");
      for (size_t k = 0; k < in.count; ++k) {
        c.t.push_back(in.At(k)[0]);
        c.v.push_back(out.At(k)[0]);
        if (k && !(c.t[k] > c.t[k - 1]))
          return Bad(Describe(sampler) + ": key times are not ascending");
      }
      c.interp.assign(interp.names.begin(),
                      interp.names.begin() +
                          static_cast<std::ptrdiff_t>(std::min(interp.names.size(), in.count)));
      if (tin.stride == 2 && tin.count == in.count)
        c.in.assign(tin.numbers.begin(),
                    tin.numbers.begin() + static_cast<std::ptrdiff_t>(2 * in.count));
      if (tout.stride == 2 && tout.count == in.count)
        c.out.assign(tout.numbers.begin(),
                     tout.numbers.begin() + static_cast<std::ptrdiff_t>(2 * in.count));
      curves[src][static_cast<size_t>(index)] = std::move(c);
    }
  }
  if (skipped) {
    rig_.load_warnings.push_back(CountWarning(
        "animation_skipped", skipped,
        "animation channels target nodes or other properties; only morph weights are read"));
  }
  if (curves.empty()) return Status::Ok();
  // One weights channel per morphed mesh, its keys every key of its curves, each segment the curves
  // cut there (kBezier): the curves as drawn, not resampled.
  AnimationInfo clip;
  clip.name = "animation";
  for (const auto& [src, by_index] : curves) {
    const int node = morph_node_.count(src) ? morph_node_.at(src) : -1;
    if (node < 0 || rig_.nodes[node].mesh < 0) continue;
    const Mesh& mesh = rig_.meshes[rig_.nodes[node].mesh];
    std::vector<double> times;
    for (const auto& [index, c] : by_index) times.insert(times.end(), c.t.begin(), c.t.end());
    std::sort(times.begin(), times.end());
    times.erase(std::unique(times.begin(), times.end()), times.end());
    const size_t n = mesh.target_shapes.size();
    if (times.size() * n > kMaxSamples)
      return Bad("an animated morph has more than " + std::to_string(kMaxSamples) +
                 " keys x targets");
    AnimationSampler s;
    s.components = n;
    s.interpolation = Interpolation::kBezier;
    s.values.assign(times.size() * 6 * n, 0.0f);
    const std::vector<uint32_t>& shapes = morph_shapes_.at(src);
    for (size_t k = 0; k < times.size(); ++k) {
      s.times.push_back(static_cast<float>(times[k]));
      const double a = times[k], b = k + 1 < times.size() ? times[k + 1] : times[k] + 1.0;
      for (size_t j = 0; j < n; ++j) {
        const uint32_t shape = mesh.target_shapes[j];
        std::array<double, 6> part{
            rig_.shapes[shape].default_weight, 1.0 / 3,
            rig_.shapes[shape].default_weight, 2.0 / 3,
            rig_.shapes[shape].default_weight, rig_.shapes[shape].default_weight};
        for (size_t i = 0; i < shapes.size(); ++i) {
          if (shapes[i] == shape && by_index.count(i)) part = by_index.at(i).Part(a, b);
        }
        for (size_t f = 0; f < 6; ++f)
          s.values[k * 6 * n + f * n + j] = static_cast<float>(part[f]);
      }
    }
    clip.duration = std::max(clip.duration, s.times.back());
    clip.channel_data.push_back(
        {static_cast<int>(clip.sampler_data.size()), node, ChannelPath::kWeights});
    clip.sampler_data.push_back(std::move(s));
  }
  if (clip.channel_data.empty()) return Status::Ok();
  clip.has_weights = true;
  clip.channels = clip.channel_data.size();
  rig_.animations.push_back(std::move(clip));
  return Status::Ok();
}
}  // namespace facespace::formats::collada

namespace facespace::formats {

using collada::Reader;

Result<Rig> LoadColladaMemory(std::span<const unsigned char> bytes, const std::string& name) {
  pugi::xml_document doc;
  const pugi::xml_parse_result parsed =
      doc.load_buffer(bytes.data(), bytes.size(), pugi::parse_default, pugi::encoding_auto);
  if (!parsed) {
    return InvalidArgument(name + ": COLLADA: not well-formed XML at byte " +
                           std::to_string(parsed.offset) + ": " + parsed.description());
  }
  Reader reader(doc, name);
  Result<Rig> rig = reader.Run();
  if (!rig.ok()) return Prefixed(rig.status(), name + ": ");
  return rig;
}

}  // namespace facespace::formats
