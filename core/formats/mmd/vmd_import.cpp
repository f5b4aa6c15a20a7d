// MikuMikuDance VMD motions as clips of a rig. A VMD names bones and morphs by their Shift-JIS
// names cut to 15 bytes; a motion applies to any model whose names match those bytes.
//
// Bone keys carry a position (an offset from the bone's rest place), a rotation and four cubic
// Bezier curves (x, y, z, rotation) that shape the segment ending at that key. MMD plays at 30
// frames a second and interpolates to 60: a curved segment is sampled at 60 a second (exact there,
// linear between samples), a straight one (MMD's default curve) keeps its two keys, exact
// throughout. Morph keys are linear: the clip keeps them as they are (every key time of any morph,
// all of the mesh's targets at each).
//
// A parser of untrusted bytes: counts are capped by the bytes left, key frames by kMaxFrame.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "facespace/engine/bezier.h"
#include "facespace/formats/io.h"
#include "mmd/mmd.h"

namespace facespace::formats {

namespace {

using namespace mmd;

constexpr int kSamplesPerFrame = 2;
constexpr size_t kMaxSamples = size_t{1}
                               << 22;  // Bone samples in curved segments, all bones: ~112 MiB.
constexpr uint32_t kMaxFrame = 30 * 60 * 60;  // An hour.
// Values no motion has (MMD's unit is 8 cm; morphs run 0..1): beyond them the interpolation between
// two keys could overflow a float, so they are refused.
constexpr float kMaxOffset = 1e6f;
constexpr float kMaxMorphWeight = 1e3f;

struct BoneKey {
  uint32_t frame = 0;
  float pos[3];
  float rot[4];  // x, y, z, w as MMD writes them.
  uint8_t curve[64];
};

struct MorphKey {
  uint32_t frame = 0;
  float weight = 0;
};

// 15-byte name field: the bytes up to the first NUL.
std::string NameBytes(const unsigned char* p) {
  return std::string(reinterpret_cast<const char*>(p),
                     static_cast<size_t>(std::find(p, p + 15, 0) - p));
}

// A model name as a VMD would store it: Shift-JIS, cut to 15 bytes.
std::string VmdKey(const std::string& utf8) {
  std::string s = Utf8ToSjis(utf8);
  if (s.size() > 15) s.resize(15);
  return s;
}

// The y of MMD's curve (0,0), (x1,y1), (x2,y2), (1,1) where its x is u.
float VmdBezier(float x1, float y1, float x2, float y2, float u) {
  if (u <= 0.0f) return 0.0f;
  if (u >= 1.0f) return 1.0f;
  return static_cast<float>(
      BezierYAtX(0.0, x1, x2, 1.0, 0.0, y1, y2, 1.0, u));  // x1, x2 in [0, 1]: x rises.
}

Eigen::Quaternionf Slerp(const float* a, const float* b, float t) {
  const Eigen::Quaternionf qa(a[3], a[0], a[1], a[2]), qb(b[3], b[0], b[1], b[2]);
  return qa.slerp(t, qb);
}

// The value at `frame` of one bone's keys (sorted), converted to glTF's handedness and units.
void BoneAt(const std::vector<BoneKey>& keys, float frame, std::array<float, 3>& pos,
            Eigen::Quaternionf& rot) {
  size_t b = static_cast<size_t>(
      std::upper_bound(keys.begin(), keys.end(), frame,
                       [](float f, const BoneKey& k) { return f < static_cast<float>(k.frame); }) -
      keys.begin());
  float p[3];
  if (b == 0 || b == keys.size()) {
    const BoneKey& k = keys[b == 0 ? 0 : keys.size() - 1];
    std::copy(k.pos, k.pos + 3, p);
    rot = Eigen::Quaternionf(k.rot[3], k.rot[0], k.rot[1], k.rot[2]);
  } else {
    const BoneKey &ka = keys[b - 1], &kb = keys[b];
    const float u =
        (frame - static_cast<float>(ka.frame)) / static_cast<float>(kb.frame - ka.frame);
    for (int c = 0; c < 3; ++c) {
      const float s = VmdBezier(kb.curve[c] / 127.0f, kb.curve[c + 4] / 127.0f,
                                kb.curve[c + 8] / 127.0f, kb.curve[c + 12] / 127.0f, u);
      p[c] = ka.pos[c] + (kb.pos[c] - ka.pos[c]) * s;
    }
    rot = Slerp(ka.rot, kb.rot,
                VmdBezier(kb.curve[3] / 127.0f, kb.curve[7] / 127.0f, kb.curve[11] / 127.0f,
                          kb.curve[15] / 127.0f, u));
  }
  pos = ToGltf(p);
  rot = Eigen::Quaternionf(rot.w(), -rot.x(), -rot.y(), rot.z()).normalized();
}

float MorphAt(const std::vector<MorphKey>& keys, uint32_t frame) {
  const size_t b = static_cast<size_t>(
      std::upper_bound(keys.begin(), keys.end(), frame,
                       [](uint32_t f, const MorphKey& k) { return f < k.frame; }) -
      keys.begin());
  if (b == 0) return keys.front().weight;
  if (b == keys.size()) return keys.back().weight;
  const MorphKey &a = keys[b - 1], &c = keys[b];
  return a.weight + (c.weight - a.weight) * static_cast<float>(frame - a.frame) /
                        static_cast<float>(c.frame - a.frame);
}

// Sorted by frame; of keys on the same frame the last in the file wins.
template <typename Key>
void SortKeys(std::vector<Key>& keys) {
  std::stable_sort(keys.begin(), keys.end(),
                   [](const Key& a, const Key& b) { return a.frame < b.frame; });
  std::vector<Key> out;
  for (const Key& k : keys) {
    if (!out.empty() && out.back().frame == k.frame)
      out.back() = k;
    else
      out.push_back(k);
  }
  keys = std::move(out);
}

// A motion's keys by their names' bytes.
struct VmdKeys {
  std::map<std::string, std::vector<BoneKey>> bones;
  std::map<std::string, std::vector<MorphKey>> morphs;
};

// A bone key after its name: frame, position, rotation (normalised), curves; checked.
Status ReadBoneKey(Bytes& r, const std::string& clip_name, size_t k, BoneKey& key) {
  if (!r.Get(key.frame, "a bone key") || !r.Floats(key.pos, 3, "a bone key") ||
      !r.Floats(key.rot, 4, "a bone key") || !r.Raw(key.curve, 64, "a bone key")) {
    return InvalidArgument(clip_name + ": VMD " + r.error());
  }
  const auto which = [&] {
    return clip_name + ": VMD: bone key " + std::to_string(k);
  };  // Made only for an error.
  if (key.frame > kMaxFrame)
    return InvalidArgument(which() + " at frame " + std::to_string(key.frame) +
                           " (beyond an hour)");
  if (std::any_of(key.pos, key.pos + 3, [](float v) { return std::fabs(v) > kMaxOffset; })) {
    return InvalidArgument(which() + " moves its bone beyond " +
                           std::to_string(static_cast<int>(kMaxOffset)) + " units");
  }
  double n = 0;  // In double: a float's square can overflow.
  for (float q : key.rot) n += static_cast<double>(q) * q;
  n = std::sqrt(n);
  if (!(n > 1e-6)) return InvalidArgument(which() + " has a zero rotation");
  for (float& q : key.rot) q = static_cast<float>(q / n);
  return Status::Ok();
}

// A morph key after its name: frame and weight, checked.
Status ReadMorphKey(Bytes& r, const std::string& clip_name, size_t k, MorphKey& key) {
  if (!r.Get(key.frame, "a morph key") || !r.Floats(&key.weight, 1, "a morph key"))
    return InvalidArgument(clip_name + ": VMD " + r.error());
  const auto which = [&] {
    return clip_name + ": VMD: morph key " + std::to_string(k);
  };  // Made only for an error.
  if (key.frame > kMaxFrame)
    return InvalidArgument(which() + " at frame " + std::to_string(key.frame) +
                           " (beyond an hour)");
  if (std::fabs(key.weight) > kMaxMorphWeight) {
    return InvalidArgument(which() + " has weight " + std::to_string(key.weight) + " (beyond +-" +
                           std::to_string(static_cast<int>(kMaxMorphWeight)) + ")");
  }
  return Status::Ok();
}

// A count, then that many keys of `item` bytes, each a 15-byte name and what read_key reads, by
// name.
template <typename Key>
Status ReadKeyList(Bytes& r, size_t item, const char* what, const std::string& clip_name,
                   Status (*read_key)(Bytes&, const std::string&, size_t, Key&),
                   std::map<std::string, std::vector<Key>>& by_name) {
  size_t count = 0;
  if (!r.CountOf<uint32_t>(item, count, (std::string("the ") + what + " count").c_str()))
    return InvalidArgument(clip_name + ": VMD " + r.error());
  const std::string one =
      std::string("a ") + what;  // The reader's word for a key, made once, not per key.
  for (size_t k = 0; k < count; ++k) {
    unsigned char name[15];
    Key key;
    if (!r.Raw(name, 15, one.c_str())) return InvalidArgument(clip_name + ": VMD " + r.error());
    if (Status s = read_key(r, clip_name, k, key); !s.ok()) return s;
    by_name[NameBytes(name)].push_back(key);
  }
  return Status::Ok();
}

// The header, then the bone and morph keys; camera, light, shadow and IK switches follow: not read.
Status ReadKeys(std::span<const unsigned char> bytes, const std::string& clip_name, VmdKeys& keys) {
  Bytes r(bytes);
  char header[30];
  if (!r.Raw(header, 30, "the header")) return InvalidArgument(clip_name + ": VMD " + r.error());
  const std::string_view magic(header, 25);
  size_t model_bytes = 0;
  if (magic == "Vocaloid Motion Data 0002")
    model_bytes = 20;
  else if (magic == "Vocaloid Motion Data file")
    model_bytes = 10;
  else
    return InvalidArgument(clip_name + ": not a VMD motion (no 'Vocaloid Motion Data' header)");
  if (!r.Skip(model_bytes, "the model name"))
    return InvalidArgument(clip_name + ": VMD " + r.error());
  if (Status s = ReadKeyList(r, 111, "bone key", clip_name, ReadBoneKey, keys.bones); !s.ok())
    return s;
  return ReadKeyList(r, 23, "morph key", clip_name, ReadMorphKey, keys.morphs);
}

// Sample times of a bone's keys (in half frames): every key, and within a curved segment every half
// frame between. A segment whose four curves are straight (MMD's default) is exact with its two
// keys alone. `samples` counts them over every bone, against kMaxSamples.
Status SampleTimes(const std::vector<BoneKey>& keys, const std::string& clip_name, size_t& samples,
                   std::vector<uint32_t>& halves) {
  halves.assign(1, keys.front().frame * kSamplesPerFrame);
  for (size_t k = 1; k < keys.size(); ++k) {
    const uint8_t* c = keys[k].curve;
    bool straight = true;  // (x1, y1) and (x2, y2) on the diagonal, per channel.
    for (int ch = 0; ch < 4; ++ch) straight &= c[ch] == c[ch + 4] && c[ch + 8] == c[ch + 12];
    const uint32_t from =
        straight ? keys[k].frame * kSamplesPerFrame : keys[k - 1].frame * kSamplesPerFrame + 1;
    if (samples + (keys[k].frame * kSamplesPerFrame - from + 1) > kMaxSamples) {
      return InvalidArgument(clip_name + ": VMD: the motion's curved segments need more than " +
                             std::to_string(kMaxSamples) + " samples");
    }
    for (uint32_t h = from; h <= keys[k].frame * kSamplesPerFrame; ++h) halves.push_back(h);
    samples += keys[k].frame * kSamplesPerFrame - from + 1;
  }
  return Status::Ok();
}

// The rig's node or shape a motion's name bytes match; a name matching none goes into `unmatched`
// (as text).
std::map<std::string, int>::const_iterator Matched(const std::map<std::string, int>& of,
                                                   const std::string& key,
                                                   std::vector<std::string>& unmatched) {
  const auto it = of.find(key);
  if (it == of.end())
    unmatched.push_back(SjisToUtf8(reinterpret_cast<const unsigned char*>(key.data()), key.size()));
  return it;
}

// Each keyed bone the rig has as a translation and a rotation channel; names it lacks into
// `unmatched`.
Status AddBoneChannels(const Rig& rig, const std::map<std::string, int>& node_of, VmdKeys& keys,
                       AnimationInfo& clip, std::vector<std::string>& unmatched) {
  size_t samples = 0;  // Bone samples between keys, against kMaxSamples.
  std::vector<uint32_t> halves;
  for (auto& [key, bone_keys] : keys.bones) {
    const auto it = Matched(node_of, key, unmatched);
    if (it == node_of.end()) continue;
    SortKeys(bone_keys);
    if (Status s = SampleTimes(bone_keys, clip.name, samples, halves); !s.ok()) return s;
    const Node& node = rig.nodes[it->second];
    const Eigen::Quaternionf rest(node.rotation[3], node.rotation[0], node.rotation[1],
                                  node.rotation[2]);
    AnimationSampler t, q;
    t.components = 3, q.components = 4;
    for (uint32_t h : halves) {
      const float frame = static_cast<float>(h) / kSamplesPerFrame;
      std::array<float, 3> p;
      Eigen::Quaternionf rot;
      BoneAt(bone_keys, frame, p, rot);
      rot = (rest * rot).normalized();
      const float time = frame / kFramesPerSecond;
      t.times.push_back(time);
      q.times.push_back(time);
      for (int c = 0; c < 3; ++c) t.values.push_back(node.translation[c] + p[c]);
      q.values.insert(q.values.end(), {rot.x(), rot.y(), rot.z(), rot.w()});
    }
    clip.channel_data.push_back(
        {static_cast<int>(clip.sampler_data.size()), it->second, ChannelPath::kTranslation});
    clip.sampler_data.push_back(std::move(t));
    clip.channel_data.push_back(
        {static_cast<int>(clip.sampler_data.size()), it->second, ChannelPath::kRotation});
    clip.sampler_data.push_back(std::move(q));
  }
  return Status::Ok();
}

// Morphs: per shape its keys; then per mesh with targets one weights channel over every key frame.
void AddMorphChannels(const Rig& rig, const std::map<std::string, int>& shape_of, VmdKeys& keys,
                      AnimationInfo& clip, std::vector<std::string>& unmatched) {
  std::map<int, std::vector<MorphKey>> shape_keys;
  std::vector<uint32_t> frames;
  for (auto& [key, morph_keys] : keys.morphs) {
    const auto it = Matched(shape_of, key, unmatched);
    if (it == shape_of.end()) continue;
    SortKeys(morph_keys);
    for (const MorphKey& k : morph_keys) frames.push_back(k.frame);
    std::vector<MorphKey>& to = shape_keys[it->second];
    if (to.empty()) to = morph_keys;  // A name and an alias both keyed: the first wins.
  }
  std::sort(frames.begin(), frames.end());
  frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
  for (size_t mi = 0; mi < rig.meshes.size() && !frames.empty(); ++mi) {
    const Mesh& mesh = rig.meshes[mi];
    int node = -1;
    for (size_t n = 0; n < rig.nodes.size() && node < 0; ++n) {
      if (rig.nodes[n].mesh == static_cast<int>(mi)) node = static_cast<int>(n);
    }
    if (node < 0 || mesh.target_shapes.empty()) continue;
    AnimationSampler w;
    w.components = mesh.target_shapes.size();
    for (uint32_t f : frames) {
      w.times.push_back(static_cast<float>(f) / kFramesPerSecond);
      for (uint32_t s : mesh.target_shapes) {
        const auto k = shape_keys.find(static_cast<int>(s));
        w.values.push_back(k == shape_keys.end() ? 0.0f : MorphAt(k->second, f));
      }
    }
    clip.has_weights = true;
    clip.channel_data.push_back(
        {static_cast<int>(clip.sampler_data.size()), node, ChannelPath::kWeights});
    clip.sampler_data.push_back(std::move(w));
  }
}

}  // namespace

Result<AnimationInfo> LoadVmdMemory(std::span<const unsigned char> bytes, const Rig& rig,
                                    const std::string& clip_name, std::vector<Warning>* warnings) {
  VmdKeys keys;
  if (Status s = ReadKeys(bytes, clip_name, keys); !s.ok()) return s;
  // The rig's names as a VMD writes them (the first of equal keys wins, as in MMD). Shapes by their
  // names, as MMD matches morphs; then by aliases (a converted rig's English names) where no name
  // is so.
  std::map<std::string, int> node_of, shape_of;
  for (size_t n = 0; n < rig.nodes.size(); ++n)
    node_of.emplace(VmdKey(rig.nodes[n].name), static_cast<int>(n));
  for (size_t s = 0; s < rig.shapes.size(); ++s)
    shape_of.emplace(VmdKey(rig.shapes[s].name), static_cast<int>(s));
  for (size_t s = 0; s < rig.shapes.size(); ++s) {
    for (const std::string& a : rig.shapes[s].aliases)
      shape_of.emplace(VmdKey(a), static_cast<int>(s));
  }
  node_of.erase("");
  shape_of.erase("");
  AnimationInfo clip;
  clip.name = clip_name;
  std::vector<std::string> unmatched;
  if (Status s = AddBoneChannels(rig, node_of, keys, clip, unmatched); !s.ok()) return s;
  AddMorphChannels(rig, shape_of, keys, clip, unmatched);
  for (const AnimationSampler& s : clip.sampler_data)
    clip.duration = std::max(clip.duration, s.times.back());
  clip.channels = clip.channel_data.size();
  if (!unmatched.empty() && warnings) {
    std::string list;
    for (size_t k = 0; k < unmatched.size() && k < 12; ++k) list += (k ? ", " : "") + unmatched[k];
    if (unmatched.size() > 12) list += ", ...";
    warnings->push_back({"motion_names_unmatched",
                         "motion '" + clip_name + "': " + std::to_string(unmatched.size()) +
                             " of " + std::to_string(keys.bones.size() + keys.morphs.size()) +
                             " bone and morph names match nothing in the model: " + list,
                         clip_name, static_cast<double>(unmatched.size()), true});
  }
  if (clip.channel_data.empty())
    return InvalidArgument(clip_name +
                           ": VMD: no bone or morph name of the motion is in the model");
  return clip;
}

void AddVmdMotions(Rig& rig, const std::string& model_path) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(model_path).parent_path().empty()
                           ? fs::path(".")
                           : fs::path(model_path).parent_path();
  std::vector<fs::path> files;
  for (const fs::path& d : {dir, dir / "motion"}) {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(d, ec)) {
      std::string ext = e.path().extension().string();
      for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      if (ext == ".vmd" && e.is_regular_file(ec)) files.push_back(e.path());
    }
  }
  std::sort(files.begin(), files.end(),
            [](const fs::path& a, const fs::path& b) { return a.filename() < b.filename(); });
  for (const fs::path& f : files) {
    std::ifstream in(f, std::ios::binary);
    const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)),
                                           std::istreambuf_iterator<char>());
    const std::string name = f.stem().string();
    bool taken = false;
    for (const AnimationInfo& a : rig.animations) taken |= a.name == name;
    if (taken) continue;
    Result<AnimationInfo> clip = LoadVmdMemory(bytes, rig, name, &rig.load_warnings);
    if (!clip.ok()) {
      rig.load_warnings.push_back({"animation_skipped",
                                   "motion '" + name + "' skipped: " + clip.status().message, name,
                                   0.0, false});
      continue;
    }
    rig.animations.push_back(std::move(clip.value()));
  }
}

}  // namespace facespace::formats
