// MapLandmarks and SolveFrames (capture.h): the landmarks' places on the rig, then per frame a
// similarity taken out, a bounded least-squares solve over the shapes' moves, a One Euro filter.
#include "facespace/derive/capture.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "facespace/engine/retarget.h"
#include "internal.h"

namespace facespace::derive {

namespace {

constexpr double kMovesNothing = 1e-4;  // Of the diagonal: a shape's move at a landmark unseen.
constexpr double kStable = 0.1;         // Of the largest move: a landmark for the rigid fit.
constexpr double kRidge = 1e-3;         // Of each shape's own term in the normal matrix.
constexpr int kSweeps = 60;
constexpr int kRounds = 3;  // Of the head's fit and the face's, per frame.
// The gaps' rows weigh this much (squared) against a landmark's: about a lid's landmarks' count.
constexpr double kGapWeight = 50;
constexpr uint32_t kGaps[][2] = {{159, 145}, {386, 374}, {13, 14}};
// MediaPipe's lids over a shut eye keep about a third of their open gap (FaceCap's renders, eyes
// shut, through the page's tracker: 42% and 31%; half shut, 75% and 88%): a lid's closing is read
// as its share of the two thirds it can close.
constexpr double kLidShutShare = 0.35;

Vec3 At(const Spot& s, std::span<const Vec3> values) {
  return s.weights[0] * values[s.triangle[0]] + s.weights[1] * values[s.triangle[1]] +
         s.weights[2] * values[s.triangle[2]];
}

// The shapes a face's expression is made of: those a vocabulary names, else all.
std::vector<uint32_t> Candidates(const Rig& rig) {
  std::vector<uint32_t> named, all;
  for (uint32_t k = 0; k < rig.shapes.size(); ++k) {
    const Shape& s = rig.shapes[k];
    if (s.driven || !(s.max > 0.0f)) continue;
    all.push_back(k);
    if (!Place(Vocabulary::kOwn, s.name).empty()) named.push_back(k);
  }
  return named.empty() ? all : named;
}

// Per landmark, its weight in the rigid fit: 1 where no shape moves it much, else nearly none.
std::vector<float> RigidWeights(const LandmarkRig& m, size_t n) {
  std::vector<double> most(n, 0.0);
  for (size_t k = 0; k < m.shapes.size(); ++k) {
    for (size_t i = 0; i < n; ++i)
      most[i] =
          std::max(most[i], Eigen::Map<const Eigen::Vector3d>(&m.moves[(k * n + i) * 3]).norm());
  }
  const double top = *std::max_element(most.begin(), most.end());
  std::vector<float> w(n, 0.0f);
  for (size_t i = 0; i < n; ++i) w[i] = m.found[i] ? (most[i] <= kStable * top ? 1.0f : 0.02f) : 0;
  return w;
}

}  // namespace

Result<LandmarkRig> MapLandmarks(const Rig& rig, const Rig& canonical, const Options& options) {
  Report report;
  auto landed = LandOnTarget(rig, canonical, options, report);
  if (!landed.ok()) return landed.status();
  const Landed& l = landed.value();
  const size_t n = kMediaPipeFace;
  LandmarkRig m;
  m.rig_shapes = rig.shapes.size();
  m.diag = l.diag;
  m.found.assign(n, 0);
  m.rest.assign(3 * n, 0.0f);
  for (size_t i = 0; i < n && i < l.spots.size(); ++i) {
    if (!l.spots[i].found) continue;
    m.found[i] = 1;
    const Vec3 p = At(l.spots[i], l.surface.points);
    for (int c = 0; c < 3; ++c) m.rest[3 * i + c] = static_cast<float>(p[c]);
  }
  const auto linear = LinearParts(rig);
  std::vector<Vec3> d;
  for (uint32_t k : Candidates(rig)) {
    if (options.stop.stop_requested()) return Cancelled();
    ShapeDisplacement(rig, l.surface, linear, k, d);
    std::vector<double> move(3 * n, 0.0);
    double most = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!m.found[i]) continue;
      const Vec3 v = At(l.spots[i], d);
      most = std::max(most, v.norm());
      for (int c = 0; c < 3; ++c) move[3 * i + c] = v[c];
    }
    if (most <= kMovesNothing * l.diag) continue;
    m.shapes.push_back(k);
    m.upper.push_back(rig.shapes[k].max);
    m.moves.insert(m.moves.end(), move.begin(), move.end());
  }
  if (m.shapes.empty())
    return WithReason(FailedPrecondition("no shape of the rig moves the face's landmarks"),
                      "no-expressions");
  m.rigid = RigidWeights(m, n);
  const size_t k = m.shapes.size();
  Eigen::Map<const Eigen::MatrixXd> moves(m.moves.data(), 3 * n, static_cast<Eigen::Index>(k));
  Eigen::MatrixXd a = moves.transpose() * moves;
  for (const auto& [ia, ib] : kGaps) {
    if (!m.found[ia] || !m.found[ib]) continue;
    const Vec3 gap = Vec3(m.rest[3 * ib], m.rest[3 * ib + 1], m.rest[3 * ib + 2]) -
                     Vec3(m.rest[3 * ia], m.rest[3 * ia + 1], m.rest[3 * ia + 2]);
    if (gap.norm() <= kMovesNothing * m.diag) continue;
    LandmarkRig::Gap g{ia, ib, gap.norm(), std::vector<double>(k)};
    Eigen::Map<Eigen::VectorXd> row(g.widen.data(), static_cast<Eigen::Index>(k));
    for (size_t j = 0; j < k; ++j)
      row[j] = gap.normalized().dot(moves.block<3, 1>(3 * ib, j) - moves.block<3, 1>(3 * ia, j));
    a += kGapWeight * row * row.transpose();
    m.gaps.push_back(std::move(g));
  }
  m.normal.assign(a.data(), a.data() + a.size());
  return m;
}

namespace {

// The One Euro filter of one value (Casiez, Roussel, Vogel 2012).
struct OneEuro {
  float value = 0, speed = 0;
  bool started = false;
  static float Alpha(float cutoff, float dt) {
    const float tau = 1.0f / (2.0f * 3.14159265f * cutoff);
    return 1.0f / (1.0f + tau / dt);
  }
  float Step(float x, float dt, float min_cutoff, float beta) {
    if (!started) {
      started = true;
      return value = x;
    }
    const float a_d = Alpha(1.0f, dt);
    speed += a_d * ((x - value) / dt - speed);
    const float a = Alpha(min_cutoff + beta * std::abs(speed), dt);
    return value += a * (x - value);
  }
};

// A frame's points as the rig's frame sees them (y up, +z towards the camera).
Status ReadFrame(std::span<const float> f, size_t index, std::vector<Vec3>& points) {
  if (f.size() != 3 * kMediaPipeFace && f.size() != 3 * kMediaPipeIrises)
    return InvalidField(
        "/frames/" + std::to_string(index),
        "has " + std::to_string(f.size() / 3) + " points; MediaPipe gives 468 or 478");
  points.resize(kMediaPipeFace);
  for (size_t i = 0; i < kMediaPipeFace; ++i) {
    if (!std::isfinite(f[3 * i]) || !std::isfinite(f[3 * i + 1]) || !std::isfinite(f[3 * i + 2]))
      return InvalidField("/frames/" + std::to_string(index) + "/" + std::to_string(i),
                          "must be three finite numbers");
    points[i] = Vec3(f[3 * i], -f[3 * i + 1], -f[3 * i + 2]);
  }
  return Status::Ok();
}

// The frame's moves from the rig's neutral in the rig's frame, the head's motion taken out: a
// similarity from the rig's neutral plus `offset` (what the face is thought to do, per landmark)
// onto the points, over the rigid landmarks, or over all of them when the offset models the face.
// A frame's scratch, kept by its tracker: a frame allocates nothing once they have grown.
struct Scratch {
  std::vector<Vec3> from, to, offset;
  std::vector<double> weights;
  Eigen::VectorXd x, face, rhs;
};

Similarity Unposed(const LandmarkRig& m, std::span<const Vec3> points, std::span<const Vec3> offset,
                   bool all, Scratch& t, std::vector<Vec3>& out) {
  t.from.clear();
  t.to.clear();
  t.weights.clear();
  for (size_t i = 0; i < kMediaPipeFace; ++i) {
    if (!m.found[i]) continue;
    t.from.push_back(Vec3(m.rest[3 * i], m.rest[3 * i + 1], m.rest[3 * i + 2]) + offset[i]);
    t.to.push_back(points[i]);
    t.weights.push_back(all ? 1.0 : m.rigid[i]);
  }
  const Similarity s = FitSimilarity(t.from, t.to, t.weights);
  out.assign(kMediaPipeFace, Vec3::Zero());
  for (size_t i = 0; i < kMediaPipeFace; ++i) {
    if (!m.found[i]) continue;
    const Vec3 back = s.rotation.transpose() * (points[i] - s.translation) / s.scale;
    out[i] = back - Vec3(m.rest[3 * i], m.rest[3 * i + 1], m.rest[3 * i + 2]);
  }
  return s;
}

// Bounded least squares on the normal equations, by projected coordinate descent from `w`.
void SolveBounded(const LandmarkRig& m, const Eigen::VectorXd& b, double ridge,
                  std::vector<float>& w, Eigen::VectorXd& x) {
  const size_t k = m.shapes.size();
  Eigen::Map<const Eigen::MatrixXd> a(m.normal.data(), static_cast<Eigen::Index>(k),
                                      static_cast<Eigen::Index>(k));
  x.resize(static_cast<Eigen::Index>(k));
  for (size_t j = 0; j < k; ++j) x[j] = w[j];
  for (int sweep = 0; sweep < kSweeps; ++sweep) {
    double moved = 0;
    for (Eigen::Index j = 0; j < static_cast<Eigen::Index>(k); ++j) {
      const double damp = ridge * a(j, j);  // Each shape's own scale: a lid's as a jaw's.
      const double g = b[j] - a.col(j).dot(x) - damp * x[j];
      const double next = std::clamp(x[j] + g / (a(j, j) + damp), 0.0, double(m.upper[j]));
      moved = std::max(moved, std::abs(next - x[j]));
      x[j] = next;
    }
    if (moved < 1e-5) break;
  }
  for (size_t j = 0; j < k; ++j) w[j] = static_cast<float>(x[j]);
}

}  // namespace

struct FaceTracker::State {
  const LandmarkRig& m;
  CaptureOptions o;
  Eigen::Map<const Eigen::MatrixXd> moves;
  bool has_neutral = false;
  Similarity neutral;
  std::vector<Vec3> points, at_rest, now, rest_gap, rig_gap;
  std::vector<float> w;
  std::vector<OneEuro> filters;
  Eigen::VectorXd target;
  size_t found = 0;
  Scratch t;

  State(const LandmarkRig& map, const CaptureOptions& options)
      : m(map),
        o(options),
        moves(map.moves.data(), 3 * kMediaPipeFace, static_cast<Eigen::Index>(map.shapes.size())),
        w(map.shapes.size(), 0.0f),
        filters(map.shapes.size()),
        target(3 * kMediaPipeFace),
        found(static_cast<size_t>(std::count(map.found.begin(), map.found.end(), 1))) {}

  // The right-hand side of the normal equations for the frame's moves `now`: the landmarks' and
  // the gaps' (the performer's gap's change along it, as a share of their gap, on the rig's).
  const Eigen::VectorXd& Rhs() {
    const size_t k = m.shapes.size();
    for (size_t i = 0; i < kMediaPipeFace; ++i)
      target.segment<3>(3 * i) = m.found[i] ? Vec3(now[i] - at_rest[i]) : Vec3::Zero();
    Eigen::VectorXd& b = t.rhs;
    b.noalias() = moves.transpose() * target;
    for (size_t g = 0; g < m.gaps.size(); ++g) {
      const LandmarkRig::Gap& gap = m.gaps[g];
      const Vec3 change = rig_gap[g] + now[gap.b] - now[gap.a] - rest_gap[g];
      const double rest = std::max(rest_gap[g].norm(), 1e-12);
      double share = change.dot(rest_gap[g]) / (rest * rest);
      const bool lid = gap.a == kGaps[0][0] || gap.a == kGaps[1][0];
      if (lid && share < 0) share = std::max(-1.0, share / (1.0 - kLidShutShare));
      b += kGapWeight * (gap.length * share) *
           Eigen::Map<const Eigen::VectorXd>(gap.widen.data(), static_cast<Eigen::Index>(k));
    }
    return b;
  }
};

FaceTracker::FaceTracker(const LandmarkRig& map, const CaptureOptions& options)
    : state_(std::make_unique<State>(map, options)) {}
FaceTracker::~FaceTracker() = default;
FaceTracker::FaceTracker(FaceTracker&&) noexcept = default;
bool FaceTracker::has_neutral() const { return state_->has_neutral; }

Status FaceTracker::SetNeutral(std::span<const float> frame, size_t index) {
  State& s = *state_;
  if (Status st = ReadFrame(frame, index, s.points); !st.ok()) return st;
  s.neutral = Unposed(s.m, s.points, std::vector<Vec3>(kMediaPipeFace, Vec3::Zero()), false, s.t,
                      s.at_rest);
  // The performer's own gaps at rest, in the rig's frame (a frame's gap is its moves' difference
  // plus the rig's gap).
  s.rest_gap.clear();
  s.rig_gap.clear();
  for (const LandmarkRig::Gap& g : s.m.gaps) {
    s.rig_gap.push_back(Vec3(s.m.rest[3 * g.b], s.m.rest[3 * g.b + 1], s.m.rest[3 * g.b + 2]) -
                        Vec3(s.m.rest[3 * g.a], s.m.rest[3 * g.a + 1], s.m.rest[3 * g.a + 2]));
    s.rest_gap.push_back(s.rig_gap.back() + s.at_rest[g.b] - s.at_rest[g.a]);
  }
  s.has_neutral = true;
  return Status::Ok();
}

Status FaceTracker::Step(std::span<const float> frame, size_t index, Frame& out, float seconds) {
  State& s = *state_;
  const size_t k = s.m.shapes.size();
  if (!s.has_neutral) return FailedPrecondition("no neutral frame yet");
  if (Status st = ReadFrame(frame, index, s.points); !st.ok()) return st;
  // The head's motion and the face's, in turn: the first fit on the rigid landmarks, then on all
  // of them with the face solved so far.
  Similarity pose;
  Scratch& t = s.t;  // Kept: a frame allocates nothing once it has grown.
  t.offset.assign(s.at_rest.begin(), s.at_rest.end());
  t.face.resize(3 * kMediaPipeFace);
  for (int round = 0; round < kRounds; ++round) {
    pose = Unposed(s.m, s.points, t.offset, round > 0, t, s.now);
    SolveBounded(s.m, s.Rhs(), kRidge, s.w, t.x);
    t.face.noalias() = s.moves * t.x;
    for (size_t i = 0; i < kMediaPipeFace; ++i)
      t.offset[i] = s.at_rest[i] + t.face.segment<3>(3 * i);
  }
  out.residual = static_cast<float>((t.face - s.target).norm() /
                                    std::sqrt(double(std::max<size_t>(s.found, 1))) / s.m.diag);
  out.weights.assign(s.m.rig_shapes, 0.0f);
  const float dt = seconds > 0 ? seconds : 1.0f / std::max(s.o.fps, 1e-3f);
  for (size_t j = 0; j < k; ++j)
    out.weights[s.m.shapes[j]] =
        std::clamp(s.filters[j].Step(s.w[j], dt, s.o.min_cutoff, s.o.beta), 0.0f, s.m.upper[j]);
  const Eigen::Quaterniond q(Eigen::Matrix3d(s.neutral.rotation.transpose() * pose.rotation));
  out.head = {float(q.x()), float(q.y()), float(q.z()), float(q.w())};
  return Status::Ok();
}

Result<Captured> SolveFrames(const LandmarkRig& m, std::span<const std::vector<float>> frames,
                             const CaptureOptions& o) {
  const double cpu0 = CpuSeconds();
  if (frames.empty()) return InvalidField("/frames", "needs at least one frame");
  if (o.neutral >= frames.size())
    return InvalidField("/neutral", "is frame " + std::to_string(o.neutral) + " of " +
                                        std::to_string(frames.size()) + " (from 0)");
  FaceTracker tracker(m, o);
  if (Status s = tracker.SetNeutral(frames[o.neutral], o.neutral); !s.ok()) return s;
  Captured out;
  FaceTracker::Frame frame;
  for (size_t f = 0; f < frames.size(); ++f) {
    if (o.stop.stop_requested()) return Cancelled();
    if (Status s = tracker.Step(frames[f], f, frame); !s.ok()) return s;
    out.weights.push_back(frame.weights);
    out.head.push_back(frame.head);
    out.residual.push_back(frame.residual);
  }
  out.solve_seconds = CpuSeconds() - cpu0;
  return out;
}

}  // namespace facespace::derive
