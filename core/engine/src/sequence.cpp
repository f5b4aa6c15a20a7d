#include "facespace/engine/sequence.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "facespace/engine/bezier.h"
#include "facespace/engine/weights.h"

namespace facespace {
inline namespace engine {

float ApplyTransition(const Transition& t, float u) {
  switch (t.kind) {
    case TransitionKind::kStep: return u >= 1.0f ? 1.0f : 0.0f;
    case TransitionKind::kLinear: return u;
    case TransitionKind::kSmoothstep: return u * u * (3.0f - 2.0f * u);
    case TransitionKind::kSmootherstep: return u * u * u * (u * (6.0f * u - 15.0f) + 10.0f);
    case TransitionKind::kEaseIn: return u * u * u;
    case TransitionKind::kEaseOut: {
      const float v = 1.0f - u;
      return 1.0f - v * v * v;
    }
    case TransitionKind::kEaseInOut:
      return u < 0.5f ? 4.0f * u * u * u : 1.0f - std::pow(-2.0f * u + 2.0f, 3.0f) / 2.0f;
    case TransitionKind::kBezier: {
      if (u <= 0.0f) return 0.0f;
      if (u >= 1.0f) return 1.0f;
      // From (0, 0) to (1, 1); x(s) rises for x1, x2 in [0, 1].
      return static_cast<float>(BezierYAtX(0.0, t.x1, t.x2, 1.0, 0.0, t.y1, t.y2, 1.0, u));
    }
  }
  return u;
}

bool ParseTransition(const std::string& text, Transition* out) {
  static const std::pair<const char*, TransitionKind> kNames[] = {
      {"step", TransitionKind::kStep},
      {"linear", TransitionKind::kLinear},
      {"smoothstep", TransitionKind::kSmoothstep},
      {"smootherstep", TransitionKind::kSmootherstep},
      {"ease-in", TransitionKind::kEaseIn},
      {"ease-out", TransitionKind::kEaseOut},
      {"ease-in-out", TransitionKind::kEaseInOut}};
  for (const auto& [name, kind] : kNames) {
    if (text == name) {
      *out = Transition{kind};
      return true;
    }
  }
  Transition t{TransitionKind::kBezier};
  char tail = 0;
  if (std::sscanf(text.c_str(), "cubic-bezier(%f ,%f ,%f ,%f %c", &t.x1, &t.y1, &t.x2, &t.y2,
                  &tail) == 5 &&
      tail == ')' && t.x1 >= 0.0f && t.x1 <= 1.0f && t.x2 >= 0.0f && t.x2 <= 1.0f &&
      std::isfinite(t.y1) && std::isfinite(t.y2)) {
    *out = t;
    return true;
  }
  return false;
}

std::string TransitionName(const Transition& t) {
  switch (t.kind) {
    case TransitionKind::kStep: return "step";
    case TransitionKind::kLinear: return "linear";
    case TransitionKind::kSmoothstep: return "smoothstep";
    case TransitionKind::kSmootherstep: return "smootherstep";
    case TransitionKind::kEaseIn: return "ease-in";
    case TransitionKind::kEaseOut: return "ease-out";
    case TransitionKind::kEaseInOut: return "ease-in-out";
    case TransitionKind::kBezier: {
      char buf[96];
      std::snprintf(buf, sizeof buf, "cubic-bezier(%g, %g, %g, %g)", t.x1, t.y1, t.x2, t.y2);
      return buf;
    }
  }
  return "linear";
}

Status ValidateSequence(const Sequence& s, size_t shape_count) {
  if (s.keys.empty()) return InvalidArgument("a sequence needs at least one key");
  for (size_t k = 0; k < s.keys.size(); ++k) {
    const Keyframe& key = s.keys[k];
    const std::string where = "/keys/" + std::to_string(k);
    Status bad = InvalidArgument("");
    if (!std::isfinite(key.time))
      bad.fields.push_back({where + "/time", "must be a finite number of seconds"});
    else if (k > 0 && !(key.time > s.keys[k - 1].time))
      bad.fields.push_back({where + "/time", "key times must increase"});
    if (key.weights.size() != shape_count)
      bad.fields.push_back({where + "/weights", "needs one weight per shape"});
    if (key.expressions.size() != s.keys.front().expressions.size())
      bad.fields.push_back(
          {where + "/expressions", "every key needs one value per expression, or none does"});
    for (float w : key.weights) {
      if (!std::isfinite(w)) {
        bad.fields.push_back({where + "/weights", "weights must be finite"});
        break;
      }
    }
    if (!bad.fields.empty()) {
      bad.message = bad.fields[0].pointer + ": " + bad.fields[0].message;
      return bad;
    }
  }
  return Status::Ok();
}

namespace {

// The keys' `member` (weights, or expressions) at time t, as SampleSequence describes.
void SampleMember(const Sequence& s, std::vector<float> Keyframe::*member, float t,
                  std::span<float> out, float* f_out) {
  const auto& keys = s.keys;
  if (f_out) *f_out = 0.0f;
  if (keys.size() == 1 || t <= keys.front().time) {
    std::copy((keys.front().*member).begin(), (keys.front().*member).end(), out.begin());
    return;
  }
  if (t >= keys.back().time) {
    std::copy((keys.back().*member).begin(), (keys.back().*member).end(), out.begin());
    if (f_out) *f_out = 1.0f;
    return;
  }
  const size_t c =
      static_cast<size_t>(std::upper_bound(keys.begin(), keys.end(), t,
                                           [](float v, const Keyframe& k) { return v < k.time; }) -
                          keys.begin());
  const size_t b = c - 1;
  const float u = (t - keys[b].time) / (keys[c].time - keys[b].time);
  const float f = ApplyTransition(keys[b].transition.value_or(s.transition), u);
  if (f_out) *f_out = f;
  const auto& wb = keys[b].*member;
  const auto& wc = keys[c].*member;
  if (!s.smooth) {
    for (size_t i = 0; i < out.size(); ++i) out[i] = (1.0f - f) * wb[i] + f * wc[i];
    return;
  }
  // Catmull-Rom through the neighbouring keys (ends repeated), parameterised by f.
  const auto& wa = keys[b > 0 ? b - 1 : b].*member;
  const auto& wd = keys[c + 1 < keys.size() ? c + 1 : c].*member;
  const float f2 = f * f, f3 = f2 * f;
  for (size_t i = 0; i < out.size(); ++i) {
    out[i] = 0.5f * (2.0f * wb[i] + (wc[i] - wa[i]) * f +
                     (2.0f * wa[i] - 5.0f * wb[i] + 4.0f * wc[i] - wd[i]) * f2 +
                     (3.0f * wb[i] - wa[i] - 3.0f * wc[i] + wd[i]) * f3);
  }
}

Gaze SampleGaze(std::span<const GazeKey> track, float t) {
  if (t <= track.front().time) return track.front().gaze;
  if (t >= track.back().time) return track.back().gaze;
  const auto c = std::upper_bound(track.begin(), track.end(), t,
                                  [](float v, const GazeKey& k) { return v < k.time; });
  const GazeKey& a = *std::prev(c);
  const GazeKey& b = *c;
  const float u = (t - a.time) / (b.time - a.time);
  Gaze g = a.gaze;
  for (int i = 0; i < 3; ++i) g.target[i] = (1.0f - u) * a.gaze.target[i] + u * b.gaze.target[i];
  g.yaw = (1.0f - u) * a.gaze.yaw + u * b.gaze.yaw;
  g.pitch = (1.0f - u) * a.gaze.pitch + u * b.gaze.pitch;
  return g;
}

}  // namespace

void SampleSequence(const Sequence& s, float t, std::span<float> out, float* f_out) {
  SampleMember(s, &Keyframe::weights, t, out, f_out);
}

bool SampleFace(const Sequence& s, float t, FaceState& face) {
  const bool expressions = !s.keys.empty() && !s.keys.front().expressions.empty();
  face.expressions.resize(expressions ? s.keys.front().expressions.size() : 0);
  if (expressions) SampleMember(s, &Keyframe::expressions, t, face.expressions, nullptr);
  face.gaze.reset();
  if (!s.gaze.empty()) face.gaze = SampleGaze(s.gaze, t);
  face.blink = BlinkValue(s.blinks, t);
  return expressions || !s.gaze.empty() || !s.blinks.empty();
}

Sequence BakeKey(const Sequence& s, float t) {
  Sequence out = s;
  Keyframe key;
  key.time = t;
  key.weights.resize(s.keys.front().weights.size());
  SampleSequence(s, t, key.weights);
  if (!s.keys.front().expressions.empty()) {
    key.expressions.resize(s.keys.front().expressions.size());
    SampleMember(s, &Keyframe::expressions, t, key.expressions, nullptr);
  }
  auto it = std::lower_bound(out.keys.begin(), out.keys.end(), t,
                             [](const Keyframe& k, float v) { return k.time < v; });
  if (it != out.keys.end() && it->time == t) return out;
  if (it != out.keys.begin()) key.transition = std::prev(it)->transition;
  out.keys.insert(it, key);
  return out;
}

namespace {

// Largest vertex distance between the rig at weights a and at weights b:
// max_v |sum_j (a_j - b_j) d_j(v)|, computed with the blend kernel on a zero base. Without a blend,
// the bound sum_j |a_j - b_j| reach_j (reach: LargestMoves), never below the distance, where it is
// close enough: when all but the largest term add up to `slack` or less (the other weights equal
// but for round-off; ReduceSequence gives 5% of its tolerance) or to a thousandth of the bound.
double MaxVertexDistance(const Rig& rig, std::span<const float> reach, std::span<const float> a,
                         std::span<const float> b, double slack, std::vector<float>& diff,
                         std::vector<float>& tw, std::vector<float>& scratch) {
  diff.resize(a.size());
  double bound = 0.0, dominant = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    diff[i] = a[i] - b[i];
    const double term =
        i < reach.size() ? std::fabs(static_cast<double>(diff[i])) * reach[i] : INFINITY;
    bound += term;
    dominant = std::max(dominant, term);
  }
  if (bound - dominant <= std::max(slack, 1e-3 * bound)) return bound;
  double worst = 0.0;
  for (const Mesh& mesh : rig.meshes) {
    tw.resize(mesh.target_shapes.size());
    bool any = false;
    for (size_t t = 0; t < tw.size(); ++t) any |= (tw[t] = diff[mesh.target_shapes[t]]) != 0.0f;
    if (!any) continue;
    for (int pi : mesh.primitives) {
      const Primitive& p = rig.primitives[pi];
      scratch.assign(p.positions.size(), 0.0f);
      BlendShapeJob job{.base = scratch, .weights = tw, .targets = p.targets, .out = scratch};
      job.Run();
      for (size_t v = 0; v < scratch.size(); v += 3) {
        worst = std::max(worst, std::sqrt(static_cast<double>(scratch[v]) * scratch[v] +
                                          static_cast<double>(scratch[v + 1]) * scratch[v + 1] +
                                          static_cast<double>(scratch[v + 2]) * scratch[v + 2]));
      }
    }
  }
  return worst;
}

}  // namespace

namespace {

// What ReduceSequence compares against: the original sampled at every key and at the quarter points
// between keys (key k's check times are 4k .. 4k+3, the last key's 4(K-1)).
struct ReduceChecks {
  std::vector<float> times;
  std::vector<std::vector<float>> reference;
};

ReduceChecks SampleChecks(const Sequence& s, size_t shapes) {
  ReduceChecks c;
  for (size_t k = 0; k < s.keys.size(); ++k) {
    c.times.push_back(s.keys[k].time);
    if (k + 1 < s.keys.size()) {
      for (int q = 1; q < 4; ++q)
        c.times.push_back(s.keys[k].time + 0.25f * q * (s.keys[k + 1].time - s.keys[k].time));
    }
  }
  c.reference.assign(c.times.size(), std::vector<float>(shapes));
  for (size_t i = 0; i < c.times.size(); ++i) SampleSequence(s, c.times[i], c.reference[i]);
  return c;
}

// Scratch of one reduction, made once.
struct ReduceScratch {
  Sequence window;  // The kept keys around a candidate segment.
  std::vector<float> w, diff, target_weights, blend;
  std::vector<double> errors;
  std::vector<float> reach;  // Each shape's largest move (LargestMoves).
};

// Whether keys `from` .. `to` of `s` may lose every key between them: the sequence with only the
// kept keys (`before`, the two kept before `from`; the original keys after `to`) is sampled at the
// check times the change can move and each compared with the original; true when none is over
// `tolerance`, the errors then in scratch.errors from index `lo`. Linear keys move only between
// `from` and `to`; a smooth (Catmull-Rom) spline's tangents at `from` and `to` take the new
// neighbours, so the segments on either side move too (the one after `to` is checked again, with
// its final neighbour, next round).
bool SegmentFits(const Rig& rig, const Sequence& s, const ReduceChecks& c,
                 std::span<const size_t> before, size_t from, size_t to, float tolerance,
                 ReduceScratch& x, size_t& lo) {
  x.window.keys.clear();
  for (size_t k : before) x.window.keys.push_back(s.keys[k]);
  x.window.keys.push_back(s.keys[from]);
  x.window.keys.push_back(s.keys[to]);
  for (size_t k = to + 1; k < std::min(to + 3, s.keys.size()); ++k)
    x.window.keys.push_back(s.keys[k]);
  const size_t first = s.smooth && !before.empty() ? before.back() : from;
  const size_t last = s.smooth ? std::min(to + 1, s.keys.size() - 1) : to;
  lo = 4 * first + 1;
  x.errors.clear();
  for (size_t i = lo; i < 4 * last; ++i) {
    SampleSequence(x.window, c.times[i], x.w);
    const double e = MaxVertexDistance(rig, x.reach, c.reference[i], x.w, 0.05 * tolerance, x.diff,
                                       x.target_weights, x.blend);
    if (e > tolerance) return false;
    x.errors.push_back(e);
  }
  return true;
}

}  // namespace

// Greedy from the first key: each kept key reaches as far as it can (the farthest next key whose
// segment fits, found by doubling the reach, then halving between the last fit and the first miss),
// so the work is O(K log K) sequence samples rather than a search over every key at every step.
Result<ReduceResult> ReduceSequence(const Rig& rig, const Sequence& s, float tolerance,
                                    const std::stop_token& stop) {
  if (Status st = ValidateSequence(s, rig.shapes.size()); !st.ok()) return st;
  if (!(tolerance >= 0.0f) || !std::isfinite(tolerance))
    return InvalidArgument("tolerance must be a finite number >= 0");
  const ReduceChecks c = SampleChecks(s, rig.shapes.size());
  ReduceScratch x;
  x.window.transition = s.transition;
  x.window.smooth = s.smooth;
  x.w.resize(rig.shapes.size());
  x.reach = LargestMoves(rig, {});
  std::vector<double> errors(c.times.size(), 0.0);
  std::vector<size_t> kept{0};
  const size_t last = s.keys.size() - 1;
  size_t lo = 0;
  while (kept.back() < last) {
    if (stop.stop_requested()) return Cancelled();
    const size_t from = kept.back();
    const size_t n_before =
        std::min<size_t>(2, kept.size() - 1);  // The kept keys before `from` a sample may need.
    const std::span<const size_t> before(kept.data() + kept.size() - 1 - n_before, n_before);
    auto fits = [&](size_t to) {
      return SegmentFits(rig, s, c, before, from, to, tolerance, x, lo);
    };
    size_t good = from + 1, bad = last + 1;
    for (size_t reach = 2; from + reach <= last; reach *= 2) {
      if (!fits(from + reach)) {
        bad = from + reach;
        break;
      }
      good = from + reach;
    }
    if (bad == last + 1 && good < last && fits(last))
      good = last;
    else if (bad == last + 1)
      bad = last;
    while (bad - good > 1) {
      if (stop.stop_requested()) return Cancelled();
      const size_t mid = good + (bad - good) / 2;
      (fits(mid) ? good : bad) = mid;
    }
    fits(good);  // The chosen segment's errors (from + 1 always fits).
    std::copy(x.errors.begin(), x.errors.end(), errors.begin() + static_cast<long>(lo));
    kept.push_back(good);
  }
  ReduceResult r{s, 0.0, s.keys.size() - kept.size()};
  r.sequence.keys.clear();
  for (size_t k : kept) r.sequence.keys.push_back(s.keys[k]);
  for (double e : errors) r.max_error = std::max(r.max_error, e);
  return r;
}

Result<Sequence> SequenceFromAnimation(const Rig& rig, int animation) {
  if (animation < 0 || static_cast<size_t>(animation) >= rig.animations.size())
    return InvalidArgument("no such animation");
  const AnimationInfo& a = rig.animations[animation];
  for (const AnimationChannel& ch : a.channel_data) {
    if (ch.path != ChannelPath::kWeights) continue;
    const AnimationSampler& smp = a.sampler_data[ch.sampler];
    const Mesh& mesh = rig.meshes[rig.nodes[ch.node].mesh];
    Sequence s;
    s.transition.kind =
        smp.interpolation == Interpolation::kStep ? TransitionKind::kStep : TransitionKind::kLinear;
    s.smooth = smp.interpolation == Interpolation::kCubicSpline;
    // kBezier: the keys' values (the curve between them is the clip's, which a clip's sequence
    // plays).
    const size_t c = smp.components, stride = smp.key_stride(), offset = smp.value_offset();
    for (size_t k = 0; k < smp.times.size(); ++k) {
      Keyframe key;
      key.time = smp.times[k];
      key.weights.assign(rig.shapes.size(), 0.0f);
      for (size_t t = 0; t < c && t < mesh.target_shapes.size(); ++t)
        key.weights[mesh.target_shapes[t]] = smp.values[k * stride + offset + t];
      s.keys.push_back(std::move(key));
    }
    return s;
  }
  return InvalidArgument("animation '" + a.name + "' has no morph-weight channel");
}

Result<Sequence> SequenceOfClip(const Rig& rig, int clip) {
  if (clip < 0 || static_cast<size_t>(clip) >= rig.animations.size())
    return InvalidArgument("no such animation");
  const float duration = rig.animations[clip].duration;
  Result<Sequence> s = SequenceFromAnimation(rig, clip);
  if (!s.ok()) {
    Sequence rest;
    rest.keys.push_back({0.0f, std::vector<float>(rig.shapes.size(), 0.0f), std::nullopt, {}});
    s = std::move(rest);
  }
  std::vector<Keyframe>& keys = s->keys;
  if (keys.front().time > 0.0f)
    keys.insert(keys.begin(), Keyframe{0.0f, keys.front().weights, std::nullopt, {}});
  if (keys.back().time < duration)
    keys.push_back(Keyframe{duration, keys.back().weights, std::nullopt, {}});
  s->clip = clip;
  return s;
}

}  // namespace engine
}  // namespace facespace
