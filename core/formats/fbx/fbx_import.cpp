// FBX 7.x (binary and ASCII) scenes as a Rig: meshes, the node hierarchy with FBX's transform
// stack, blend shapes with in-betweens, skins, materials and animation (sampled per frame).
//
// The objects (Model, Geometry, Deformer, AnimationCurve, ...) live in a flat list with ids;
// "Connections" link them (OO: object to object, OP: object to a property). What links to what:
//   Model -> Model (parent)             Geometry(Mesh) -> Model          Material -> Model
//   Deformer(Skin) -> Geometry          SubDeformer(Cluster) -> Skin      Model(bone) -> Cluster
//   Deformer(BlendShape) -> Geometry    SubDeformer(BlendShapeChannel) -> BlendShape
//   Geometry(Shape) -> BlendShapeChannel
//   AnimationLayer -> AnimationStack    AnimationCurveNode -> AnimationLayer
//   AnimationCurveNode -OP-> Model ("Lcl Translation" ...) or BlendShapeChannel ("DeformPercent")
//   AnimationCurve -OP-> AnimationCurveNode ("d|X", "d|Y", "d|Z", "d|DeformPercent")
// Every index read from the file is checked before use; errors name the object.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <iterator>
#include <map>
#include <set>
#include <unordered_map>

#include "common/split_mesh.h"
#include "facespace/engine/bezier.h"
#include "facespace/formats/io.h"
#include "fbx/fbx_scene.h"

namespace facespace::formats {

namespace {

using namespace fbx_scene;

class Importer {
 public:
  Importer(const Scene& scene, const std::string& name) : scene_(scene) { rig_.name = name; }

  Result<Rig> Run() {
    if (Status s = Nodes(); !s.ok()) return s;
    if (Status s = Meshes(); !s.ok()) return s;
    if (Status s = Animations(); !s.ok()) return s;
    if (rig_.primitives.empty()) return InvalidArgument("FBX: the file has no mesh");
    CountMovedVertices(rig_);
    DetectSymmetricPartners(rig_);
    return std::move(rig_);
  }

 private:
  // The Model hierarchy as nodes, parents first. Node 0 turns the file's up axis into +Y when
  // it is not already.
  Status Nodes() {
    std::vector<const Object*> models;
    for (int64_t id : scene_.order()) {
      const Object* o = scene_.Get(id);
      if (o->cls == "Model") models.push_back(o);
    }
    std::unordered_map<int64_t, int64_t> parent;
    std::unordered_map<int64_t, std::vector<int64_t>> children;
    std::vector<int64_t> roots;
    for (const Object* m : models) {
      const auto up = scene_.Targets(m->id, "Model");
      if (!up.empty() && up[0].second.empty()) {
        parent[m->id] = up[0].first->id;
        children[up[0].first->id].push_back(m->id);
      } else {
        roots.push_back(m->id);
      }
    }
    const int up = IntIn(scene_.Setting("UpAxis", 1), 0, 2, 1),
              up_sign = scene_.Setting("UpAxisSign", 1) < 0 ? -1 : 1;
    const int right = IntIn(scene_.Setting("CoordAxis", 0), 0, 2, 0),
              right_sign = scene_.Setting("CoordAxisSign", 1) < 0 ? -1 : 1;
    int first = 0;
    if ((up != 1 || up_sign != 1) && up >= 0 && up < 3 && right >= 0 && right < 3 && up != right) {
      Vec3 u = Vec3::Zero(), r = Vec3::Zero();
      u[up] = up_sign;
      r[right] = right_sign;
      Eigen::Matrix3d m;
      m.row(0) = r;
      m.row(1) = u;
      m.row(2) = r.cross(u);
      Node root;
      root.name = "fbx_root";
      const Eigen::Quaterniond q(m);
      root.rotation = {static_cast<float>(q.x()), static_cast<float>(q.y()),
                       static_cast<float>(q.z()), static_cast<float>(q.w())};
      rig_.nodes.push_back(root);
      rig_.scene_roots = {0};
      first = 1;
    }
    // Depth first from the roots; a Model never reached sits on a cycle.
    std::vector<std::pair<int64_t, int>> stack;
    for (auto it = roots.rbegin(); it != roots.rend(); ++it)
      stack.emplace_back(*it, first ? 0 : -1);
    while (!stack.empty()) {
      const auto [id, parent_node] = stack.back();
      stack.pop_back();
      const Object& m = *scene_.Get(id);
      Node n;
      n.name = m.name;
      n.parent = parent_node;
      const TransformStack st = ReadStack(scene_, m);
      SetNodeLocal(n, st.Local());
      const int index = static_cast<int>(rig_.nodes.size());
      if (parent_node >= 0) {
        rig_.nodes[parent_node].children.push_back(index);
      } else {
        rig_.scene_roots.push_back(index);
      }
      node_of_[id] = index;
      stacks_.push_back(st);
      model_of_node_.push_back(&m);
      rig_.nodes.push_back(std::move(n));
      auto kids = children.find(id);
      if (kids != children.end()) {
        for (auto it = kids->second.rbegin(); it != kids->second.rend(); ++it)
          stack.emplace_back(*it, index);
      }
    }
    for (const Object* m : models) {
      if (!node_of_.count(m->id))
        return InvalidArgument("FBX: the node graph has a cycle through Model '" + m->name + "'");
    }
    world_ = NodeWorldMatrices(rig_);
    return Status::Ok();
  }

  const TransformStack& StackOf(int node) const {
    return stacks_[node - (rig_.nodes.size() - stacks_.size())];
  }
  const Object* ModelOf(int node) const {
    const size_t offset = rig_.nodes.size() - model_of_node_.size();
    return node < static_cast<int>(offset) ? nullptr : model_of_node_[node - offset];
  }

  Mat4 World(int node) const {
    Mat4 m;
    for (int k = 0; k < 16; ++k) m(k % 4, k / 4) = world_[node][k];
    return m;
  }

  int MaterialFor(const Object& model, int slot) {
    const auto mats = scene_.Sources(model.id, "Material");
    if (slot < 0 || static_cast<size_t>(slot) >= mats.size()) return -1;
    const Object& mat = *mats[slot].first;
    auto it = material_of_.find(mat.id);
    if (it != material_of_.end()) return it->second;
    Material m;
    m.name = mat.name;
    const Vec3 diffuse =
        scene_.Vector(mat, "DiffuseColor", scene_.Vector(mat, "Diffuse", Vec3(0.8, 0.8, 0.8)));
    const double factor = scene_.Number(mat, "DiffuseFactor", 1.0);
    double opacity = scene_.Number(mat, "Opacity", 1.0);
    if (const double tf = scene_.Number(mat, "TransparencyFactor", -1);
        tf >= 0 && tf <= 1 && !scene_.Property(mat, "Opacity"))
      opacity = 1.0 - tf;
    for (int c = 0; c < 3; ++c)
      m.base_color_factor[c] = static_cast<float>(std::clamp(diffuse[c] * factor, 0.0, 1.0));
    m.base_color_factor[3] = static_cast<float>(std::clamp(opacity, 0.0, 1.0));
    if (m.base_color_factor[3] < 1.0f) m.alpha_mode = "BLEND";
    m.metallic_factor = 0.0f;
    m.roughness_factor = 0.8f;
    // A diffuse texture embedded in the file (Video Content) becomes the base colour image.
    for (const auto& [tex, prop] : scene_.Sources(mat.id, "Texture")) {
      if (prop != "DiffuseColor" && prop != "Maya|baseColor" && prop != "base_color") continue;
      for (const auto& [video, unused] : scene_.Sources(tex->id, "Video")) {
        const FNode* content = video->node->Find("Content");
        if (!content || content->props.empty() || content->props[0].kind != Prop::kString) continue;
        const std::string& bytes = content->props[0].s;
        std::string mime;
        if (bytes.size() > 8 && std::memcmp(bytes.data(), "\x89PNG", 4) == 0) mime = "image/png";
        if (bytes.size() > 3 && std::memcmp(bytes.data(), "\xff\xd8\xff", 3) == 0)
          mime = "image/jpeg";
        if (mime.empty()) continue;
        rig_.images.push_back(
            {video->name, mime, std::vector<unsigned char>(bytes.begin(), bytes.end())});
        m.base_color_image = static_cast<int>(rig_.images.size()) - 1;
        break;
      }
      if (m.base_color_image < 0) {
        rig_.load_warnings.push_back(
            {"texture_not_loaded",
             "material '" + mat.name + "': its diffuse texture '" + tex->name +
                 "' is not embedded in the file (or not PNG/JPEG) and is not read",
             mat.name, 0.0, false});
      }
    }
    rig_.materials.push_back(m);
    material_of_[mat.id] = static_cast<int>(rig_.materials.size()) - 1;
    return material_of_[mat.id];
  }

  Status Meshes() {
    std::unordered_map<int64_t, int> mesh_of_geometry;
    for (size_t ni = 0; ni < rig_.nodes.size(); ++ni) {
      const Object* model = ModelOf(static_cast<int>(ni));
      if (!model) continue;
      const auto geoms = scene_.Sources(model->id, "Geometry", "Mesh");
      if (geoms.empty()) continue;
      const Object& geom = *geoms[0].first;
      if (auto it = mesh_of_geometry.find(geom.id); it != mesh_of_geometry.end()) {
        rig_.nodes[ni].mesh = it->second;  // An instance of a mesh read already.
        continue;
      }
      SplitMesh split;
      const TransformStack& st = StackOf(static_cast<int>(ni));
      if (Status s = SplitGeometry(geom, st.geometric, rig_.load_warnings, split); !s.ok())
        return s;
      if (split.primitives.empty()) continue;
      Mesh mesh;
      mesh.name = model->name;
      const int mesh_index = static_cast<int>(rig_.meshes.size());
      const size_t first_prim = rig_.primitives.size();
      for (size_t p = 0; p < split.primitives.size(); ++p) {
        split.primitives[p].mesh = mesh_index;
        split.primitives[p].index_in_mesh = static_cast<int>(p);
        split.primitives[p].material = MaterialFor(*model, split.material_slot[p]);
        mesh.primitives.push_back(static_cast<int>(first_prim + p));
      }
      if (Status s = BlendShapes(geom, st.geometric, split, mesh); !s.ok()) return s;
      if (Status s = Skin(geom, static_cast<int>(ni), split, mesh); !s.ok()) return s;
      for (Primitive& p : split.primitives) {
        FinalizePrimitive(p);
        rig_.primitives.push_back(std::move(p));
      }
      rig_.meshes.push_back(std::move(mesh));
      rig_.nodes[ni].mesh = mesh_index;
      mesh_of_geometry[geom.id] = mesh_index;
      mesh_node_[mesh_index] = static_cast<int>(ni);
    }
    return Status::Ok();
  }

  // Shape names must be unique across the rig: a clash gets the mesh's name in front.
  std::string UniqueShapeName(const std::string& want, const std::string& mesh) {
    std::string name = want.empty() ? "shape" : want;
    if (FindShape(rig_, name) >= 0) name = mesh + "." + name;
    for (int k = 2; FindShape(rig_, name) >= 0; ++k)
      name = mesh + "." + want + "_" + std::to_string(k);
    return name;
  }

  // A Shape geometry's deltas on every primitive of the split mesh.
  // `scale`: per entry of Indexes, a percentage its delta is scaled by; empty: 100.
  Status AddTarget(const Object& shape, const Mat4& geometric, const std::vector<double>& scale,
                   SplitMesh& split) {
    const Prop* ip = ArrayOf(*shape.node, "Indexes");
    const Prop* vp = ArrayOf(*shape.node, "Vertices");
    if (!ip || !vp)
      return InvalidArgument("FBX: " + shape.Describe() + " has no Indexes or Vertices");
    const std::vector<int64_t> index = Ints(*ip);
    const std::vector<double> delta = Numbers(*vp);
    std::vector<double> normal;
    if (const Prop* np = ArrayOf(*shape.node, "Normals")) normal = Numbers(*np);
    if (delta.size() != 3 * index.size()) {
      return InvalidArgument("FBX: " + shape.Describe() + ": " + std::to_string(index.size()) +
                             " Indexes but " + std::to_string(delta.size()) + " Vertices numbers");
    }
    if (!normal.empty() && normal.size() != delta.size()) normal.clear();
    std::vector<int32_t> slot(split.point_count, -1);
    for (size_t k = 0; k < index.size(); ++k) {
      if (index[k] < 0 || static_cast<uint64_t>(index[k]) >= split.point_count) {
        return InvalidArgument("FBX: " + shape.Describe() + ": Indexes[" + std::to_string(k) +
                               "] = " + std::to_string(index[k]) + " is beyond the " +
                               std::to_string(split.point_count) + " control points");
      }
      for (int c = 0; c < 3; ++c) {
        if (!std::isfinite(delta[3 * k + c]) ||
            (!normal.empty() && !std::isfinite(normal[3 * k + c]))) {
          return InvalidArgument("FBX: " + shape.Describe() + ": a delta is not finite");
        }
      }
      slot[static_cast<size_t>(index[k])] = static_cast<int32_t>(k);
    }
    const Eigen::Matrix3d linear = geometric.block<3, 3>(0, 0);
    const Eigen::Matrix3d normal_matrix = linear.inverse().transpose();
    for (size_t p = 0; p < split.primitives.size(); ++p) {
      SparseTarget t;
      const std::vector<uint32_t>& points = split.point_of_vertex[p];
      for (size_t v = 0; v < points.size(); ++v) {
        const int32_t k = slot[points[v]];
        if (k < 0) continue;
        const double f = scale.empty() ? 1.0 : (std::isfinite(scale[k]) ? scale[k] / 100.0 : 0.0);
        const Vec3 d = f * (linear * Vec3(&delta[3 * k]));
        const Vec3 n =
            normal.empty() ? Vec3::Zero() : Vec3(f * (normal_matrix * Vec3(&normal[3 * k])));
        if (d.isZero(0) && n.isZero(0)) continue;
        t.indices.push_back(static_cast<uint32_t>(v));
        for (int c = 0; c < 3; ++c) t.position_deltas.push_back(static_cast<float>(d[c]));
        if (!normal.empty() && split.primitives[p].source_has_normals) {
          for (int c = 0; c < 3; ++c) t.normal_deltas.push_back(static_cast<float>(n[c]));
        }
      }
      FinalizeTarget(t);
      split.primitives[p].targets.push_back(std::move(t));
    }
    return Status::Ok();
  }

  // BlendShape deformers -> channels -> shapes. A channel is one slider (a Shape of the rig)
  // reaching its last shape at its last FullWeight; the other shapes are its in-betweens.
  Status BlendShapes(const Object& geom, const Mat4& geometric, SplitMesh& split, Mesh& mesh) {
    for (const auto& [deformer, unused] : scene_.Sources(geom.id, "Deformer", "BlendShape")) {
      for (const auto& [channel, unused2] :
           scene_.Sources(deformer->id, "Deformer", "BlendShapeChannel")) {
        const auto shapes = scene_.Sources(channel->id, "Geometry", "Shape");
        if (shapes.empty()) {
          rig_.load_warnings.push_back({"shape_skipped",
                                        "blend shape channel '" + channel->name + "' has no shape",
                                        channel->name, 0.0, false});
          continue;
        }
        std::vector<double> full;
        if (const Prop* fw = ArrayOf(*channel->node, "FullWeights")) full = Numbers(*fw);
        // Blender (4.4 on) writes a single shape's vertex-group weights as FullWeights, one
        // percentage per entry of its Indexes: they scale that shape's deltas, and it is reached at
        // 100.
        std::vector<double> per_index;
        if (shapes.size() == 1 && full.size() > 1) {
          if (const Prop* ip = ArrayOf(*shapes[0].first->node, "Indexes");
              ip && ip->ArraySize() == full.size()) {
            per_index = std::move(full);
            full = {100.0};
          }
        }
        if (full.size() != shapes.size()) {
          if (!full.empty()) {
            rig_.load_warnings.push_back({"inbetweens_guessed",
                                          "channel '" + channel->name +
                                              "': " + std::to_string(full.size()) +
                                              " FullWeights for " + std::to_string(shapes.size()) +
                                              " shapes; spaced evenly instead",
                                          channel->name, 0.0, false});
          }
          full.clear();
          for (size_t k = 0; k < shapes.size(); ++k)
            full.push_back(100.0 * static_cast<double>(k + 1) / static_cast<double>(shapes.size()));
        }
        // The slider's own shape is the one at the largest full weight; the rest are keys.
        std::vector<size_t> order(shapes.size());
        for (size_t k = 0; k < order.size(); ++k) order[k] = k;
        std::stable_sort(order.begin(), order.end(),
                         [&](size_t a, size_t b) { return full[a] < full[b]; });
        bool valid = true;
        for (size_t k = 0; k < order.size(); ++k) {
          const double w = full[order[k]];
          if (!std::isfinite(w) || w == 0.0 || (k && w == full[order[k - 1]])) valid = false;
        }
        if (!valid) {
          return InvalidArgument("FBX: channel '" + channel->name +
                                 "': FullWeights must be finite, non-zero and distinct");
        }
        std::string name = channel->name;
        if (name.rfind(deformer->name + ".", 0) == 0 && name.size() > deformer->name.size() + 1)
          name = name.substr(deformer->name.size() + 1);
        const size_t slider_k = order.back();
        Shape slider;
        slider.name = UniqueShapeName(name, mesh.name);
        if (slider.name != channel->name) slider.aliases.push_back(channel->name);
        const double percent = scene_.Number(*channel, "DeformPercent", 0.0);
        slider.default_weight = std::isfinite(percent) ? static_cast<float>(percent / 100.0) : 0.0f;
        const float full_slider = static_cast<float>(full[slider_k] / 100.0);
        slider.min = std::min(
            {0.0f, static_cast<float>(full[order.front()] / 100.0), slider.default_weight});
        slider.max = std::max({1.0f, full_slider, slider.default_weight});
        const uint32_t slider_index = static_cast<uint32_t>(rig_.shapes.size());
        rig_.shapes.push_back(slider);
        if (Status s = AddTarget(*shapes[slider_k].first, geometric, per_index, split); !s.ok())
          return s;
        mesh.target_shapes.push_back(slider_index);
        channel_shape_[channel->id] = slider_index;
        if (shapes.size() > 1) {
          InBetweens ib;
          ib.slider = slider_index;
          ib.full = full_slider;
          for (size_t k : order) {
            if (k == slider_k) continue;
            Shape in;
            in.name = UniqueShapeName(shapes[k].first->name.empty() ? name + "_" + std::to_string(k)
                                                                    : shapes[k].first->name,
                                      mesh.name);
            in.driven = true;
            in.group = "inbetween";
            const uint32_t index = static_cast<uint32_t>(rig_.shapes.size());
            rig_.shapes.push_back(in);
            if (Status s = AddTarget(*shapes[k].first, geometric, {}, split); !s.ok()) return s;
            mesh.target_shapes.push_back(index);
            ib.keys.emplace_back(static_cast<float>(full[k] / 100.0), index);
          }
          rig_.inbetweens.push_back(std::move(ib));
        }
      }
    }
    return Status::Ok();
  }

  // Skin deformers: each Cluster is a joint (its linked Model), with control point weights.
  Status Skin(const Object& geom, int mesh_node, SplitMesh& split, Mesh& mesh) {
    for (const auto& [other, unused] : scene_.Sources(geom.id, "Deformer")) {
      if (other->sub == "Skin" || other->sub == "BlendShape") continue;
      rig_.load_warnings.push_back({"deformer_skipped",
                                    "mesh '" + mesh.name + "': deformer '" + other->name + "' (" +
                                        other->sub.substr(0, 40) +
                                        ") is not read; only skins and blend shapes are",
                                    mesh.name, 0.0, false});
    }
    const auto skins = scene_.Sources(geom.id, "Deformer", "Skin");
    if (skins.empty()) return Status::Ok();
    if (skins.size() > 1) {
      rig_.load_warnings.push_back({"skin_skipped",
                                    "geometry of '" + mesh.name + "' has " +
                                        std::to_string(skins.size()) +
                                        " skins; only the first is used",
                                    mesh.name, 0.0, false});
    }
    facespace::Skin skin;
    skin.name = skins[0].first->name;
    std::vector<Influences> influences(split.point_count);
    Mat4 mesh_bind = World(mesh_node);
    bool have_mesh_bind = false;
    for (const auto& source : scene_.Sources(skins[0].first->id, "Deformer", "Cluster")) {
      const Object* cluster = source.first;
      const auto bones = scene_.Sources(cluster->id, "Model");
      if (bones.empty() || !node_of_.count(bones[0].first->id)) {
        rig_.load_warnings.push_back({"cluster_skipped",
                                      "skin cluster '" + cluster->name + "' has no bone",
                                      cluster->name, 0.0, false});
        continue;
      }
      if (skin.joints.size() >= kMaxJoints)
        return InvalidArgument("FBX: skin '" + skin.name + "' has more than " +
                               std::to_string(kMaxJoints) + " clusters");
      const int joint_node = node_of_.at(bones[0].first->id);
      // Transform maps the mesh node to the bone at bind time (what exporters write: the bone's
      // bind world inverted, times the mesh's), TransformLink is the bone's bind world. So
      // Transform is the inverse bind matrix itself; without it, the bone's and mesh's rest worlds
      // give it.
      Mat4 link = World(joint_node), inverse_bind = World(joint_node).inverse() * World(mesh_node);
      const bool have_link = ClusterMatrix(*cluster, "TransformLink", link);
      if (!ClusterMatrix(*cluster, "Transform", inverse_bind) && have_link)
        inverse_bind = link.inverse() * World(mesh_node);
      if (!have_mesh_bind && have_link) {
        mesh_bind = link * inverse_bind;
        have_mesh_bind = true;
      }
      const uint32_t joint = static_cast<uint32_t>(skin.joints.size());
      skin.joints.push_back(joint_node);
      for (int k = 0; k < 16; ++k)
        skin.inverse_bind.push_back(static_cast<float>(inverse_bind(k % 4, k / 4)));
      if (Status s = ClusterWeights(*cluster, joint, split.point_count, influences); !s.ok())
        return s;
    }
    if (skin.joints.empty()) return Status::Ok();
    // Control points no cluster weighs follow the mesh's own node, as in FBX.
    size_t unweighted = 0;
    for (const auto& inf : influences) unweighted += inf.empty();
    if (unweighted) {
      const uint32_t joint = static_cast<uint32_t>(skin.joints.size());
      skin.joints.push_back(mesh_node);
      // At rest the node's joint matrix, world x inverse bind, must place them where the clusters'
      // bind does.
      const Mat4 inverse_bind = World(mesh_node).inverse() * mesh_bind;
      for (int k = 0; k < 16; ++k)
        skin.inverse_bind.push_back(static_cast<float>(inverse_bind(k % 4, k / 4)));
      for (auto& inf : influences) {
        if (inf.empty()) inf.emplace_back(joint, 1.0f);
      }
    }
    for (size_t p = 0; p < split.primitives.size(); ++p)
      SetInfluences(split.primitives[p], split.point_of_vertex[p], influences);
    mesh.skin = static_cast<int>(rig_.skins.size());
    rig_.joint_count += skin.joints.size();
    rig_.skins.push_back(std::move(skin));
    rig_.skin_count = rig_.skins.size();
    return Status::Ok();
  }

  // Each AnimationStack is a clip, its curves sampled at the scene's frame rate (and at its first
  // and last key), linear between samples: exact at every frame, whatever the curves' kinds.
  Status Animations() {
    const double fps = FrameRate(scene_);
    for (int64_t id : scene_.order()) {
      const Object& stack = *scene_.Get(id);
      if (stack.cls != "AnimationStack") continue;
      const auto layers = scene_.Sources(stack.id, "AnimationLayer");
      if (layers.empty()) continue;
      if (layers.size() > 1) {
        rig_.load_warnings.push_back({"animation_layers_skipped",
                                      "clip '" + stack.name +
                                          "': " + std::to_string(layers.size() - 1) +
                                          " layers above the first are not blended in",
                                      stack.name, 0.0, false});
      }
      std::deque<Curve> curves;
      std::map<int, AnimatedProperty> translation, rotation, scaling;  // By node.
      std::map<uint32_t, AnimatedProperty> percent;                    // By slider shape.
      double start = INFINITY, end = -INFINITY;
      for (const auto& [curve_node, unused] :
           scene_.Sources(layers[0].first->id, "AnimationCurveNode")) {
        for (const auto& [target, prop] : scene_.Targets(curve_node->id, "Model")) {
          auto n = node_of_.find(target->id);
          if (n == node_of_.end()) continue;
          if (prop == "Lcl Translation")
            Bind(*curve_node, translation[n->second], curves, start, end);
          if (prop == "Lcl Rotation") Bind(*curve_node, rotation[n->second], curves, start, end);
          if (prop == "Lcl Scaling") Bind(*curve_node, scaling[n->second], curves, start, end);
        }
        for (const auto& [target, prop] :
             scene_.Targets(curve_node->id, "Deformer", "BlendShapeChannel")) {
          auto s = channel_shape_.find(target->id);
          if (s != channel_shape_.end() && prop == "DeformPercent")
            Bind(*curve_node, percent[s->second], curves, start, end);
        }
      }
      if (!curve_error_.ok()) return curve_error_;
      if (!(end >= start)) continue;  // No curve.
      std::vector<float> times;
      const double first_frame = std::ceil(start * fps - 1e-6),
                   last_frame = std::floor(end * fps + 1e-6);
      if (last_frame - first_frame + 3 > static_cast<double>(kMaxFrames)) {
        return InvalidArgument("FBX: clip '" + stack.name + "' spans more than " +
                               std::to_string(kMaxFrames) + " frames");
      }
      if (first_frame / fps > start + 1e-9) times.push_back(static_cast<float>(start));
      for (double f = first_frame; f <= last_frame; ++f)
        times.push_back(static_cast<float>(f / fps));
      if (times.empty() || times.back() < static_cast<float>(end) - 1e-6f)
        times.push_back(static_cast<float>(end));
      const size_t channels =
          translation.size() + rotation.size() + scaling.size() + percent.size();
      if (times.size() * channels * 4 > kMaxClipValues)
        return InvalidArgument("FBX: clip '" + stack.name + "' holds too many samples");
      AnimationInfo clip;
      clip.name = stack.name;
      std::set<int> moved;
      for (const auto& m : {&translation, &rotation, &scaling}) {
        for (const auto& [node, unused] : *m) moved.insert(node);
      }
      for (int node : moved) NodeChannels(node, times, translation, rotation, scaling, clip);
      WeightChannels(times, percent, clip);
      clip.duration = times.back();
      clip.channels = clip.channel_data.size();
      rig_.animations.push_back(std::move(clip));
    }
    return Status::Ok();
  }

  void Bind(const Object& curve_node, AnimatedProperty& prop, std::deque<Curve>& curves,
            double& start, double& end) {
    for (const auto& [curve, which] : scene_.Sources(curve_node.id, "AnimationCurve")) {
      int c = -1;
      if (which == "d|X" || which == "d|DeformPercent") c = 0;
      if (which == "d|Y") c = 1;
      if (which == "d|Z") c = 2;
      if (c < 0) continue;
      curves.emplace_back();
      if (Status s = ReadCurve(*curve, curves.back()); !s.ok()) {
        if (curve_error_.ok()) curve_error_ = s;
        return;
      }
      if (curves.back().times.empty()) continue;
      prop.curves[c] = &curves.back();
      start = std::min(start, curves.back().times.front());
      end = std::max(end, curves.back().times.back());
    }
  }

  static Vec3 Sample(const AnimatedProperty* p, const Vec3& rest, double t) {
    Vec3 v = rest;
    if (p) {
      for (int c = 0; c < 3; ++c) {
        if (p->curves[c]) v[c] = p->curves[c]->At(t);
      }
    }
    return v;
  }

  void NodeChannels(int node, const std::vector<float>& times,
                    const std::map<int, AnimatedProperty>& translation,
                    const std::map<int, AnimatedProperty>& rotation,
                    const std::map<int, AnimatedProperty>& scaling, AnimationInfo& clip) {
    auto find = [&](const std::map<int, AnimatedProperty>& m) {
      auto it = m.find(node);
      return it == m.end() ? nullptr : &it->second;
    };
    const AnimatedProperty *t = find(translation), *r = find(rotation), *s = find(scaling);
    const TransformStack& st = StackOf(node);
    AnimationSampler ts, rs, ss;
    ts.components = ss.components = 3;
    rs.components = 4;
    std::array<float, 4> previous{0, 0, 0, 1};
    bool sheared = false;
    for (size_t k = 0; k < times.size(); ++k) {
      const double time = times[k];
      std::array<float, 3> tt, sc;
      std::array<float, 4> q;
      sheared |= !DecomposeTrs(
          st.Local(Sample(t, st.t, time), Sample(r, st.r, time), Sample(s, st.s, time)), tt, q, sc);
      if (k &&
          q[0] * previous[0] + q[1] * previous[1] + q[2] * previous[2] + q[3] * previous[3] < 0) {
        for (float& c : q) c = -c;  // The short way round from the previous key.
      }
      previous = q;
      ts.values.insert(ts.values.end(), tt.begin(), tt.end());
      rs.values.insert(rs.values.end(), q.begin(), q.end());
      ss.values.insert(ss.values.end(), sc.begin(), sc.end());
    }
    if (sheared || rig_.nodes[node].has_matrix) {
      rig_.load_warnings.push_back({"animation_sheared",
                                    "node '" + rig_.nodes[node].name +
                                        "': its animated transform shears (non-uniform scale under "
                                        "rotation); the clip keeps the nearest rotation and scale",
                                    rig_.nodes[node].name, 0.0, false});
      rig_.nodes[node].has_matrix = false;
    }
    const ChannelPath paths[3] = {ChannelPath::kTranslation, ChannelPath::kRotation,
                                  ChannelPath::kScale};
    AnimationSampler* samplers[3] = {&ts, &rs, &ss};
    for (int c = 0; c < 3; ++c) {
      samplers[c]->times = times;
      samplers[c]->interpolation = Interpolation::kLinear;
      clip.channel_data.push_back({static_cast<int>(clip.sampler_data.size()), node, paths[c]});
      clip.sampler_data.push_back(std::move(*samplers[c]));
    }
  }

  // One weights channel per mesh with an animated slider: every target's weight per sample
  // (sliders from their DeformPercent / 100, in-betweens 0: the rig derives them).
  void WeightChannels(const std::vector<float>& times,
                      const std::map<uint32_t, AnimatedProperty>& percent, AnimationInfo& clip) {
    for (size_t mi = 0; mi < rig_.meshes.size(); ++mi) {
      const Mesh& mesh = rig_.meshes[mi];
      bool animated = false;
      for (uint32_t s : mesh.target_shapes) animated |= percent.count(s) > 0;
      if (!animated || !mesh_node_.count(static_cast<int>(mi))) continue;
      AnimationSampler ws;
      ws.components = mesh.target_shapes.size();
      ws.times = times;
      ws.interpolation = Interpolation::kLinear;
      for (double time : times) {
        for (uint32_t s : mesh.target_shapes) {
          const Shape& shape = rig_.shapes[s];
          auto it = percent.find(s);
          float w = shape.driven ? 0.0f : shape.default_weight;
          if (it != percent.end() && it->second.curves[0])
            w = static_cast<float>(it->second.curves[0]->At(time) / 100.0);
          ws.values.push_back(w);
        }
      }
      clip.has_weights = true;
      clip.channel_data.push_back({static_cast<int>(clip.sampler_data.size()),
                                   mesh_node_.at(static_cast<int>(mi)), ChannelPath::kWeights});
      clip.sampler_data.push_back(std::move(ws));
    }
  }

  const Scene& scene_;
  Rig rig_;
  std::unordered_map<int64_t, int> node_of_;             // Model id -> node.
  std::vector<TransformStack> stacks_;                   // Per Model node.
  std::vector<const Object*> model_of_node_;             // Per Model node.
  std::vector<std::array<float, 16>> world_;             // Rest world matrices.
  std::unordered_map<int64_t, int> material_of_;         // Material id -> rig material.
  std::unordered_map<int64_t, uint32_t> channel_shape_;  // BlendShapeChannel id -> slider shape.
  std::unordered_map<int, int> mesh_node_;               // Mesh -> the node showing it.
  Status curve_error_;
};

}  // namespace

Result<Rig> LoadFbxMemory(std::span<const unsigned char> bytes, const std::string& name) {
  Result<fbx::Document> doc = fbx::Parse(bytes);
  if (!doc.ok()) return Prefixed(doc.status(), name + ": ");
  if (doc->version && doc->version < 7000) {
    return InvalidArgument(name + ": FBX version " + std::to_string(doc->version) +
                           " is not supported (7.0 and later are)");
  }
  Scene scene;
  if (Status s = scene.Index(doc.value()); !s.ok()) return Prefixed(s, name + ": ");
  Importer importer(scene, name);
  Result<Rig> rig = importer.Run();
  if (!rig.ok()) return Prefixed(rig.status(), name + ": ");
  RepairNames(rig.value());
  if (Status s = ValidateRig(rig.value()); !s.ok()) return Prefixed(s, name + ": ");
  return rig;
}

}  // namespace facespace::formats
