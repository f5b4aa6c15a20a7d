// Doom 3 MD5 meshes (.md5mesh) and clips (.md5anim), read as a skinned Rig.
//
// A parser of untrusted text: every count is capped, every index checked, every number finite;
// an error names the file's line. Coordinates: MD5 is Z-up; a root node turns it Y-up as glTF
// wants (-90 degrees about X), units are kept. Quaternions store x, y, z; w is rebuilt as
// -sqrt(1 - x^2 - y^2 - z^2) (0 when that is negative), id's convention.
#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>

#include "facespace/formats/io.h"

namespace facespace::formats {

namespace {

constexpr size_t kMaxJoints = 4096;  // Joint indices are uint16 in a Primitive.
constexpr size_t kMaxMeshes = 1024;
constexpr size_t kMaxVerts = 2000000;
constexpr size_t kMaxTris = 4000000;
constexpr size_t kMaxWeights = 8000000;
constexpr size_t kMaxFrames = 100000;
constexpr size_t kMaxInfluences = 32;
constexpr size_t kMaxFrameJoints = 4000000;  // Keys of a clip: frames x joints (7 floats each).

struct Token {
  enum Kind { kEnd, kWord, kString, kSymbol } kind = kEnd;
  std::string_view text;
  int line = 0;
};

// Words, "strings", and the symbols ( ) { }; // comments run to the end of the line.
class Lexer {
 public:
  explicit Lexer(std::string_view text) : s_(text) {}

  Token Next() {
    for (;;) {
      while (pos_ < s_.size() &&
             (s_[pos_] == ' ' || s_[pos_] == '\t' || s_[pos_] == '\r' || s_[pos_] == '\n')) {
        if (s_[pos_] == '\n') ++line_;
        ++pos_;
      }
      if (pos_ + 1 < s_.size() && s_[pos_] == '/' && s_[pos_ + 1] == '/') {
        while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;
        continue;
      }
      break;
    }
    Token t;
    t.line = line_;
    if (pos_ >= s_.size()) return t;
    const char c = s_[pos_];
    if (c == '(' || c == ')' || c == '{' || c == '}') {
      t.kind = Token::kSymbol;
      t.text = s_.substr(pos_++, 1);
      return t;
    }
    if (c == '"') {
      const size_t end = s_.find('"', pos_ + 1);
      const size_t newline = s_.find('\n', pos_ + 1);
      if (end == std::string_view::npos || (newline != std::string_view::npos && newline < end)) {
        t.kind = Token::kEnd;  // An unterminated string: reported by the caller as unexpected.
        t.text = "unterminated string";
        pos_ = s_.size();
        return t;
      }
      t.kind = Token::kString;
      t.text = s_.substr(pos_ + 1, end - pos_ - 1);
      pos_ = end + 1;
      return t;
    }
    const size_t start = pos_;
    while (pos_ < s_.size() && !std::isspace(static_cast<unsigned char>(s_[pos_])) &&
           s_[pos_] != '(' && s_[pos_] != ')' && s_[pos_] != '{' && s_[pos_] != '}' &&
           s_[pos_] != '"') {
      ++pos_;
    }
    t.kind = Token::kWord;
    t.text = s_.substr(start, pos_ - start);
    return t;
  }

 private:
  std::string_view s_;
  size_t pos_ = 0;
  int line_ = 1;
};

// The parse state of one file: the lexer and the first error.
class Md5Reader {
 public:
  Md5Reader(std::string_view text, std::string file) : lex_(text), file_(std::move(file)) {}

  bool ok() const { return error_.empty(); }
  Status status() const { return InvalidArgument(error_); }

  // The first error, at `at`'s line (the last token read when `at` has none).
  bool Fail(const Token& at, const std::string& message) {
    if (error_.empty())
      error_ = file_ + ":" + std::to_string(at.line > 0 ? at.line : last_line_) + ": " + message;
    return false;
  }

  Token Take() {
    Token t = lex_.Next();
    last_line_ = t.line;
    return t;
  }

  bool Expect(std::string_view text) {
    const Token t = Take();
    if ((t.kind == Token::kWord || t.kind == Token::kSymbol) && t.text == text) return true;
    return Fail(t, "expected '" + std::string(text) + "', got " + Describe(t));
  }

  bool Int(long long lo, long long hi, long long* out, const char* what) {
    const Token t = Take();
    if (t.kind != Token::kWord)
      return Fail(t, std::string("expected ") + what + ", got " + Describe(t));
    const std::string s(t.text);
    char* end = nullptr;
    errno = 0;
    const long long v = std::strtoll(s.c_str(), &end, 10);
    if (s.empty() || *end || errno == ERANGE)
      return Fail(t, std::string(what) + ": '" + s.substr(0, 40) + "' is not an integer");
    if (v < lo || v > hi)
      return Fail(t, std::string(what) + " " + s + " is outside " + std::to_string(lo) + ".." +
                         std::to_string(hi));
    *out = v;
    return true;
  }

  bool Count(size_t hi, size_t* out, const char* what) {
    long long v = 0;
    if (!Int(0, static_cast<long long>(hi), &v, what)) return false;
    *out = static_cast<size_t>(v);
    return true;
  }

  bool Float(float* out, const char* what) {
    const Token t = Take();
    if (t.kind != Token::kWord)
      return Fail(t, std::string("expected ") + what + ", got " + Describe(t));
    const std::string s(t.text);
    char* end = nullptr;
    const float v = std::strtof(s.c_str(), &end);
    if (s.empty() || *end || !std::isfinite(v))
      return Fail(t, std::string(what) + ": '" + s.substr(0, 40) + "' is not a finite number");
    *out = v;
    return true;
  }

  // ( a b c ... ): n floats in parentheses.
  bool Floats(float* out, int n, const char* what) {
    if (!Expect("(")) return false;
    for (int i = 0; i < n; ++i) {
      if (!Float(&out[i], what)) return false;
    }
    return Expect(")");
  }

  bool String(std::string* out, const char* what) {
    const Token t = Take();
    if (t.kind != Token::kString)
      return Fail(t, std::string("expected ") + what + " (a quoted string), got " + Describe(t));
    *out = std::string(t.text);
    return true;
  }

 private:
  static std::string Describe(const Token& t) {
    switch (t.kind) {
      case Token::kEnd: return t.text.empty() ? "the end of the file" : std::string(t.text);
      case Token::kString: return "\"" + std::string(t.text.substr(0, 40)) + "\"";
      default: return "'" + std::string(t.text.substr(0, 40)) + "'";
    }
  }

  Lexer lex_;
  std::string file_;
  std::string error_;
  int last_line_ = 1;
};

using Quat = Eigen::Quaternionf;

// id's unit quaternion from x, y, z.
Quat FromXyz(const float* q) {
  const float t = 1.0f - q[0] * q[0] - q[1] * q[1] - q[2] * q[2];
  return Quat(t < 0.0f ? 0.0f : -std::sqrt(t), q[0], q[1], q[2]);
}

struct Joint {
  std::string name;
  int parent = -1;
  Eigen::Vector3f pos;  // Object space (md5mesh) or parent space (md5anim base frame).
  Quat orient;
};

bool ReadHeader(Md5Reader& r) {
  long long version = 0;
  if (!r.Expect("MD5Version") || !r.Int(0, 1 << 20, &version, "the version")) return false;
  if (version != 10)
    return r.Fail(Token{}, "MD5Version " + std::to_string(version) + " is not supported (only 10)");
  std::string command;
  return r.Expect("commandline") && r.String(&command, "the command line");
}

struct Md5Weight {
  int joint = 0;
  float bias = 0.0f;
  Eigen::Vector3f pos;
};

struct Md5Mesh {
  std::string shader;
  std::vector<float> uv;        // 2 per vertex.
  std::vector<uint32_t> first;  // Per vertex: its first weight.
  std::vector<uint32_t> count;  // Per vertex: its number of weights.
  std::vector<uint32_t> tris;   // 3 per triangle.
  std::vector<Md5Weight> weights;
};

// The n-th item of a list must say it is the n-th: files list them in order, and memory then grows
// only with what the file really holds, never with what its counts claim.
bool InOrder(Md5Reader& r, size_t n, size_t count, const char* what) {
  long long i = 0;
  if (!r.Int(0, static_cast<long long>(count) - 1, &i, what)) return false;
  if (static_cast<size_t>(i) != n)
    return r.Fail(Token{}, std::string(what) + " " + std::to_string(i) + " where " +
                               std::to_string(n) + " was due");
  return true;
}

bool ReadMesh(Md5Reader& r, size_t joints, Md5Mesh& m) {
  size_t nverts = 0, ntris = 0, nweights = 0;
  if (!r.Expect("{") || !r.Expect("shader") || !r.String(&m.shader, "the shader")) return false;
  if (!r.Expect("numverts") || !r.Count(kMaxVerts, &nverts, "numverts")) return false;
  for (size_t k = 0; k < nverts; ++k) {
    long long start = 0, n = 0;
    float uv[2];
    if (!r.Expect("vert") || !InOrder(r, k, nverts, "the vertex index") ||
        !r.Floats(uv, 2, "a texture coordinate"))
      return false;
    if (!r.Int(0, static_cast<long long>(kMaxWeights), &start, "the first weight") ||
        !r.Int(1, static_cast<long long>(kMaxInfluences), &n, "the weight count")) {
      return false;
    }
    m.uv.insert(m.uv.end(), uv, uv + 2);
    m.first.push_back(static_cast<uint32_t>(start));
    m.count.push_back(static_cast<uint32_t>(n));
  }
  if (!r.Expect("numtris") || !r.Count(kMaxTris, &ntris, "numtris")) return false;
  for (size_t k = 0; k < ntris; ++k) {
    long long v[3] = {0, 0, 0};
    if (!r.Expect("tri") || !InOrder(r, k, ntris, "the triangle index")) return false;
    for (long long& x : v) {
      if (!r.Int(0, static_cast<long long>(nverts) - 1, &x, "a triangle's vertex")) return false;
      m.tris.push_back(static_cast<uint32_t>(x));
    }
  }
  if (!r.Expect("numweights") || !r.Count(kMaxWeights, &nweights, "numweights")) return false;
  for (size_t k = 0; k < nweights; ++k) {
    long long j = 0;
    Md5Weight w;
    float p[3];
    if (!r.Expect("weight") || !InOrder(r, k, nweights, "the weight index") ||
        !r.Int(0, static_cast<long long>(joints) - 1, &j, "the weight's joint") ||
        !r.Float(&w.bias, "the weight's bias") || !r.Floats(p, 3, "a weight position")) {
      return false;
    }
    w.joint = static_cast<int>(j);
    w.pos = Eigen::Vector3f(p[0], p[1], p[2]);
    m.weights.push_back(w);
  }
  for (size_t v = 0; v < nverts; ++v) {
    if (static_cast<size_t>(m.first[v]) + m.count[v] > nweights) {
      return r.Fail(Token{}, "vertex " + std::to_string(v) + " uses weights " +
                                 std::to_string(m.first[v]) + ".." +
                                 std::to_string(m.first[v] + m.count[v] - 1) + " of " +
                                 std::to_string(nweights));
    }
  }
  return r.Expect("}");
}

Eigen::Matrix4f Matrix(const Eigen::Vector3f& t, const Quat& q) {
  Eigen::Affine3f a = Eigen::Affine3f::Identity();
  a.translate(t);
  a.rotate(q.normalized());
  return a.matrix();
}

void SetTrs(Node& node, const Eigen::Vector3f& t, const Quat& q) {
  const Quat n = q.normalized();
  node.translation = {t.x(), t.y(), t.z()};
  node.rotation = {n.x(), n.y(), n.z(), n.w()};
}

// An .md5anim as a clip over the mesh's joints (nodes first_joint ...), or an error.
Status ReadAnim(std::string_view text, const std::string& file, const std::string& name,
                const std::vector<Joint>& joints, int first_joint, AnimationInfo& clip) {
  Md5Reader r(text, file);
  size_t frames = 0, njoints = 0, ncomponents = 0;
  long long rate = 0;
  if (!ReadHeader(r) || !r.Expect("numFrames") || !r.Count(kMaxFrames, &frames, "numFrames") ||
      !r.Expect("numJoints") || !r.Count(kMaxJoints, &njoints, "numJoints") ||
      !r.Expect("frameRate") || !r.Int(1, 1000, &rate, "frameRate") ||
      !r.Expect("numAnimatedComponents") ||
      !r.Count(6 * kMaxJoints, &ncomponents, "numAnimatedComponents")) {
    return r.status();
  }
  if (frames == 0) return InvalidArgument(file + ": the clip has no frame");
  if (frames * njoints > kMaxFrameJoints) {
    return InvalidArgument(file + ": " + std::to_string(frames) + " frames of " +
                           std::to_string(njoints) + " joints is over the limit of " +
                           std::to_string(kMaxFrameJoints) + " joint keys");
  }
  if (njoints != joints.size()) {
    return InvalidArgument(file + ": " + std::to_string(njoints) + " joints, the mesh has " +
                           std::to_string(joints.size()));
  }
  std::vector<int> flags(njoints), start(njoints);
  if (!r.Expect("hierarchy") || !r.Expect("{")) return r.status();
  for (size_t j = 0; j < njoints; ++j) {
    std::string jname;
    long long parent = 0, f = 0, s = 0;
    if (!r.String(&jname, "a joint name") ||
        !r.Int(-1, static_cast<long long>(j) - 1, &parent, "the parent") ||
        !r.Int(0, 63, &f, "the flags") ||
        !r.Int(0, static_cast<long long>(ncomponents), &s, "the start index")) {
      return r.status();
    }
    if (jname != joints[j].name || parent != joints[j].parent) {
      return InvalidArgument(file + ": joint " + std::to_string(j) + " is '" + jname +
                             "' (parent " + std::to_string(parent) + "), the mesh's is '" +
                             joints[j].name + "' (parent " + std::to_string(joints[j].parent) +
                             ")");
    }
    if (s + __builtin_popcount(static_cast<unsigned>(f)) > static_cast<long long>(ncomponents)) {
      return InvalidArgument(file + ": joint '" + jname +
                             "' reads components beyond numAnimatedComponents");
    }
    flags[j] = static_cast<int>(f);
    start[j] = static_cast<int>(s);
  }
  if (!r.Expect("}") || !r.Expect("bounds") || !r.Expect("{")) return r.status();
  for (size_t f = 0; f < frames; ++f) {
    float b[3];
    if (!r.Floats(b, 3, "a bound") || !r.Floats(b, 3, "a bound")) return r.status();
  }
  std::vector<float> base(6 * njoints);
  if (!r.Expect("}") || !r.Expect("baseframe") || !r.Expect("{")) return r.status();
  for (size_t j = 0; j < njoints; ++j) {
    if (!r.Floats(&base[6 * j], 3, "a base position") ||
        !r.Floats(&base[6 * j + 3], 3, "a base orientation"))
      return r.status();
  }
  if (!r.Expect("}")) return r.status();

  // One translation and one rotation sampler per joint, a key per frame.
  clip.name = name;
  clip.sampler_data.assign(2 * njoints, {});
  clip.channel_data.clear();
  for (size_t j = 0; j < njoints; ++j) {
    for (int k = 0; k < 2; ++k) {
      AnimationSampler& s = clip.sampler_data[2 * j + k];
      s.components = k == 0 ? 3 : 4;
      s.interpolation = Interpolation::kLinear;
      clip.channel_data.push_back({static_cast<int>(2 * j + k), first_joint + static_cast<int>(j),
                                   k == 0 ? ChannelPath::kTranslation : ChannelPath::kRotation});
    }
  }
  std::vector<float> comp(ncomponents);
  for (size_t f = 0; f < frames; ++f) {
    if (!r.Expect("frame") || !InOrder(r, f, frames, "the frame index") || !r.Expect("{"))
      return r.status();
    for (float& c : comp) {
      if (!r.Float(&c, "a component")) return r.status();
    }
    if (!r.Expect("}")) return r.status();
    for (size_t j = 0; j < njoints; ++j) {
      float v[6];
      std::copy(&base[6 * j], &base[6 * j] + 6, v);
      int at = start[j];
      for (int b = 0; b < 6; ++b) {
        if (flags[j] & (1 << b)) v[b] = comp[at++];
      }
      const Quat q = FromXyz(&v[3]).normalized();
      const float time = static_cast<float>(f) / static_cast<float>(rate);
      AnimationSampler& st = clip.sampler_data[2 * j];
      AnimationSampler& sr = clip.sampler_data[2 * j + 1];
      st.times.push_back(time);
      sr.times.push_back(time);
      st.values.insert(st.values.end(), v, v + 3);
      const float rq[4] = {q.x(), q.y(), q.z(), q.w()};
      sr.values.insert(sr.values.end(), rq, rq + 4);
    }
  }
  // Neighbouring keys the short way round, so that linear interpolation never flips.
  for (size_t j = 0; j < njoints; ++j) {
    std::vector<float>& q = clip.sampler_data[2 * j + 1].values;
    for (size_t f = 1; f < frames; ++f) {
      float dot = 0;
      for (int c = 0; c < 4; ++c) dot += q[4 * f + c] * q[4 * (f - 1) + c];
      if (dot < 0) {
        for (int c = 0; c < 4; ++c) q[4 * f + c] = -q[4 * f + c];
      }
    }
  }
  clip.duration = static_cast<float>(frames - 1) / static_cast<float>(rate);
  clip.channels = clip.channel_data.size();
  clip.has_weights = false;
  return Status::Ok();
}

// The joints block: each joint's name, parent (an earlier joint), position and orientation.
bool ReadJoints(Md5Reader& r, size_t njoints, std::vector<Joint>& joints) {
  joints.resize(njoints);
  for (size_t j = 0; j < njoints; ++j) {
    Joint& jt = joints[j];
    long long parent = 0;
    float p[3], q[3];
    if (!r.String(&jt.name, "a joint name") ||
        !r.Int(-1, static_cast<long long>(j) - 1, &parent, "the parent (an earlier joint)") ||
        !r.Floats(p, 3, "a joint position") || !r.Floats(q, 3, "a joint orientation")) {
      return false;
    }
    jt.parent = static_cast<int>(parent);
    jt.pos = Eigen::Vector3f(p[0], p[1], p[2]);
    jt.orient = FromXyz(q).normalized();
  }
  return r.Expect("}");
}

// Node 0 turns Z-up into Y-up; then a node per joint (from kFirstJoint), and the one skin over
// them.
constexpr int kFirstJoint = 1;
void AddSkeleton(std::span<const Joint> joints, Rig& rig) {
  Node root;
  root.name = "md5_root";
  root.rotation = {-0.70710678f, 0.0f, 0.0f, 0.70710678f};
  rig.nodes.push_back(root);
  rig.scene_roots = {0};
  Skin skin;
  skin.name = "md5_skeleton";
  for (size_t j = 0; j < joints.size(); ++j) {
    const Joint& jt = joints[j];
    Node n;
    n.name = jt.name;
    n.parent = jt.parent < 0 ? 0 : kFirstJoint + jt.parent;
    if (jt.parent < 0) {
      SetTrs(n, jt.pos, jt.orient);
    } else {
      const Joint& p = joints[jt.parent];
      const Quat inv = p.orient.conjugate();
      SetTrs(n, inv * (jt.pos - p.pos), inv * jt.orient);
    }
    rig.nodes[n.parent].children.push_back(static_cast<int>(rig.nodes.size()));
    rig.nodes.push_back(n);
    skin.joints.push_back(kFirstJoint + static_cast<int>(j));
    const Eigen::Matrix4f inv_bind = Matrix(jt.pos, jt.orient).inverse();
    skin.inverse_bind.insert(skin.inverse_bind.end(), inv_bind.data(), inv_bind.data() + 16);
  }
  rig.skins.push_back(std::move(skin));
  rig.skin_count = 1;
  rig.joint_count = joints.size();
}

// Each vertex's bind-pose position (sum of bias x the joint's transform of the weight's position)
// and its influences, the biases normalised. MD5 triangles wind clockwise seen from outside; glTF's
// front faces wind counter-clockwise.
Status FillPrimitive(const Md5Mesh& m, std::span<const Joint> joints, const std::string& where,
                     Primitive& p) {
  const size_t n = m.first.size();
  p.positions.assign(3 * n, 0.0f);
  p.texcoords = m.uv;
  size_t k = 1;
  for (uint32_t c : m.count) k = std::max<size_t>(k, c);
  p.influences = k;
  p.joints.assign(n * k, 0);
  p.joint_weights.assign(n * k, 0.0f);
  for (size_t v = 0; v < n; ++v) {
    Eigen::Vector3f pos = Eigen::Vector3f::Zero();
    float total = 0.0f;
    for (uint32_t i = 0; i < m.count[v]; ++i) {
      const Md5Weight& w = m.weights[m.first[v] + i];
      const Joint& jt = joints[w.joint];
      pos += w.bias * (jt.orient * w.pos + jt.pos);
      total += w.bias;
      p.joints[v * k + i] = static_cast<uint16_t>(w.joint);
      p.joint_weights[v * k + i] = w.bias;
    }
    if (!(total > 1e-6f))
      return InvalidArgument(where + ", vertex " + std::to_string(v) +
                             ": its weights' biases sum to " + std::to_string(total));
    for (uint32_t i = 0; i < m.count[v]; ++i) p.joint_weights[v * k + i] /= total;
    for (int c = 0; c < 3; ++c) p.positions[3 * v + c] = pos[c];
  }
  p.indices.resize(m.tris.size());
  for (size_t t = 0; t < m.tris.size(); t += 3) {
    p.indices[t] = m.tris[t];
    p.indices[t + 1] = m.tris[t + 2];
    p.indices[t + 2] = m.tris[t + 1];
  }
  return Status::Ok();
}

// The material a shader names, one per shader (its textures are not read: said once).
int MaterialOf(const std::string& shader, Rig& rig) {
  for (size_t i = 0; i < rig.materials.size(); ++i) {
    if (rig.materials[i].name == shader) return static_cast<int>(i);
  }
  Material mat;
  mat.name = shader;
  mat.metallic_factor = 0.0f;
  rig.materials.push_back(mat);
  if (!shader.empty()) {
    rig.load_warnings.push_back(
        {"texture_not_loaded",
         "shader '" + shader + "': MD5 names a material, whose textures are not read", shader, 0.0,
         false});
  }
  return static_cast<int>(rig.materials.size()) - 1;
}

// Each mesh as a primitive of a mesh of its own, under a node of its own.
Status AddMeshes(std::span<const Md5Mesh> meshes, std::span<const Joint> joints,
                 const std::string& mesh_name, Rig& rig) {
  for (size_t mi = 0; mi < meshes.size(); ++mi) {
    const Md5Mesh& m = meshes[mi];
    Primitive p;
    p.mesh = static_cast<int>(mi);
    if (Status s = FillPrimitive(m, joints, mesh_name + ": mesh " + std::to_string(mi), p); !s.ok())
      return s;
    p.material = MaterialOf(m.shader, rig);
    FinalizePrimitive(p);
    rig.primitives.push_back(std::move(p));
    Mesh mesh;
    mesh.name =
        m.shader.empty() ? "mesh" + std::to_string(mi) : m.shader.substr(0, m.shader.rfind('.'));
    mesh.primitives = {static_cast<int>(mi)};
    mesh.skin = 0;
    rig.meshes.push_back(std::move(mesh));
    Node node;
    node.name = rig.meshes.back().name;
    node.parent = 0;
    node.mesh = static_cast<int>(mi);
    rig.nodes[0].children.push_back(static_cast<int>(rig.nodes.size()));
    rig.nodes.push_back(node);
  }
  return Status::Ok();
}

}  // namespace

Result<Rig> LoadMd5Memory(std::string_view mesh_text, const std::string& mesh_name,
                          std::span<const std::pair<std::string, std::string>> anims) {
  Md5Reader r(mesh_text, mesh_name);
  size_t njoints = 0, nmeshes = 0;
  if (!ReadHeader(r) || !r.Expect("numJoints") || !r.Count(kMaxJoints, &njoints, "numJoints") ||
      !r.Expect("numMeshes") || !r.Count(kMaxMeshes, &nmeshes, "numMeshes") ||
      !r.Expect("joints") || !r.Expect("{")) {
    return r.status();
  }
  if (njoints == 0) return InvalidArgument(mesh_name + ": the mesh has no joint");
  std::vector<Joint> joints;
  if (!ReadJoints(r, njoints, joints)) return r.status();
  std::vector<Md5Mesh> meshes(nmeshes);
  for (Md5Mesh& m : meshes) {
    if (!r.Expect("mesh") || !ReadMesh(r, njoints, m)) return r.status();
  }
  Rig rig;
  AddSkeleton(joints, rig);
  if (Status s = AddMeshes(meshes, joints, mesh_name, rig); !s.ok()) return s;
  for (const auto& [name, text] : anims) {
    AnimationInfo clip;
    if (Status s = ReadAnim(text, name + ".md5anim", name, joints, kFirstJoint, clip); !s.ok()) {
      rig.load_warnings.push_back(
          {"animation_skipped", "clip '" + name + "' skipped: " + s.message, name, 0.0, false});
      continue;
    }
    rig.animations.push_back(std::move(clip));
  }
  RepairNames(rig);
  if (Status s = ValidateRig(rig); !s.ok()) return Prefixed(s, mesh_name + ": ");
  return rig;
}

Result<Rig> LoadMd5File(const std::string& path) {
  namespace fs = std::filesystem;
  auto read = [](const fs::path& p, std::string& out) {
    std::ifstream f(p, std::ios::binary);
    if (!f) return false;
    out.assign((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    return true;
  };
  std::string text;
  if (!read(path, text)) return NotFound("cannot open '" + path + "'");
  // Every .md5anim beside the mesh is a clip, named by its file stem, in name order.
  std::vector<std::pair<std::string, std::string>> anims;
  std::error_code ec;
  const fs::path dir =
      fs::path(path).parent_path().empty() ? fs::path(".") : fs::path(path).parent_path();
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.path().extension() == ".md5anim") files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  for (const fs::path& f : files) {
    std::string anim;
    if (read(f, anim)) anims.emplace_back(f.stem().string(), std::move(anim));
  }
  return LoadMd5Memory(text, fs::path(path).filename().string(), anims);
}

}  // namespace facespace::formats
