#include "facespace/engine/variants.h"

#include <algorithm>
#include <cmath>

#include "facespace/engine/enum_table.h"

namespace facespace {
inline namespace engine {

namespace {

// SplitMix64: tiny, well mixed, and the same on every machine.
uint64_t Mix(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

struct Rng {
  uint64_t state;
  uint64_t Next() { return Mix(state += 0x9E3779B97F4A7C15ull); }
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }       // [0, 1)
  double Open() { return (static_cast<double>(Next() >> 11) + 0.5) * 0x1.0p-53; }  // (0, 1)
  double Normal() {
    return std::sqrt(-2.0 * std::log(Open())) * std::cos(6.283185307179586 * Uniform());
  }
};

bool IsFixed(const SampleSpec& spec, uint32_t shape) {
  for (const auto& f : spec.fixed) {
    if (f.first == shape) return true;
  }
  return false;
}

// The shapes sampled independently: spec.shapes, or every shape not fixed. With symmetric,
// the second of a partnered pair follows the first and is not sampled itself.
std::vector<uint32_t> VariedShapes(const Rig& rig, const SampleSpec& spec) {
  std::vector<uint32_t> v;
  auto take = [&](uint32_t s) {
    if (IsFixed(spec, s)) return;
    const int p = rig.shapes[s].partner;
    if (spec.symmetric && p >= 0 && static_cast<uint32_t>(p) < s &&
        (spec.shapes.empty() || std::find(spec.shapes.begin(), spec.shapes.end(),
                                          static_cast<uint32_t>(p)) != spec.shapes.end())) {
      return;
    }
    v.push_back(s);
  };
  if (spec.shapes.empty()) {
    for (uint32_t s = 0; s < rig.shapes.size(); ++s) take(s);
  } else {
    for (uint32_t s : spec.shapes) take(s);
  }
  return v;
}

size_t GridDims(const SampleSpec& spec, size_t varied) {
  return spec.points.size() >= 2 ? spec.points.size() - 1 : varied;
}

size_t GridSteps(const SampleSpec& spec, size_t dims) {
  if (spec.count == 0) return 5;
  if (dims == 1) return spec.count;
  return std::max<size_t>(
      2, static_cast<size_t>(std::llround(
             std::pow(static_cast<double>(spec.count), 1.0 / static_cast<double>(dims)))));
}

}  // namespace

namespace {
constexpr EnumName<SampleMethod> kSampleMethods[] = {{SampleMethod::kUniform, "uniform"},
                                                     {SampleMethod::kGaussian, "gaussian"},
                                                     {SampleMethod::kGrid, "grid", "line"},
                                                     {SampleMethod::kConvex, "convex"}};
}  // namespace

bool ParseSampleMethod(const std::string& name, SampleMethod* method) {
  return ParseEnum(kSampleMethods, name, method);
}
const char* SampleMethodName(SampleMethod method) { return EnumEntry(kSampleMethods, method).name; }

Status ValidateSampleSpec(const Rig& rig, const SampleSpec& spec) {
  Status st = InvalidArgument("");
  auto bad = [&](const std::string& pointer, const std::string& msg) {
    st.fields.push_back({pointer, msg});
  };
  const size_t n = rig.shapes.size();
  for (uint32_t s : spec.shapes) {
    if (s >= n) bad("/sample/shapes", "shape index " + std::to_string(s) + " out of range");
  }
  for (const auto& [s, w] : spec.fixed) {
    if (s >= n)
      bad("/sample/fixed", "shape index " + std::to_string(s) + " out of range");
    else if (!std::isfinite(w))
      bad("/sample/fixed/" + rig.shapes[s].name, "must be a finite number");
  }
  if (!spec.center.empty() && spec.center.size() != n)
    bad("/sample/center", "needs one weight per shape");
  for (float c : spec.center) {
    if (!std::isfinite(c)) bad("/sample/center", "must hold finite numbers");
  }
  if (!std::isfinite(spec.spread) || spec.spread < 0.0f)
    bad("/sample/spread", "must be a finite number >= 0");
  for (const auto& p : spec.points) {
    if (p.size() != n) bad("/sample/points", "needs one weight per shape in every point");
    for (float w : p) {
      if (!std::isfinite(w)) bad("/sample/points", "must hold finite numbers");
    }
  }
  const size_t varied = st.fields.empty() ? VariedShapes(rig, spec).size() : 0;
  if (st.fields.empty()) {
    if (spec.method == SampleMethod::kGrid) {
      if (spec.points.size() == 1 || spec.points.size() > 3)
        bad("/sample/points", "a grid takes 2 points (a line) or 3 (a plane)");
      else if (spec.points.empty() && (varied < 1 || varied > 3)) {
        bad("/sample/shapes", "a grid without points spans the ranges of 1 to 3 shapes; " +
                                  std::to_string(varied) + " are varied");
      }
    } else if (spec.method != SampleMethod::kGrid && !spec.points.empty()) {
      bad("/sample/points", "only a grid takes points");
    }
    if (spec.method != SampleMethod::kGrid && spec.count == 0)
      bad("/sample/count", "must be at least 1");
    if (spec.method != SampleMethod::kGrid && varied == 0)
      bad("/sample/shapes", "no shape is left to vary");
  }
  if (st.fields.empty()) return Status::Ok();
  st.message = st.fields.front().pointer + ": " + st.fields.front().message;
  return st;
}

size_t SampleCount(const SampleSpec& spec, size_t shape_count) {
  if (spec.method != SampleMethod::kGrid) return spec.count;
  const size_t dims =
      GridDims(spec, spec.shapes.empty() ? shape_count - spec.fixed.size() : spec.shapes.size());
  if (dims == 0) return 0;
  const size_t steps = GridSteps(spec, dims);
  size_t total = 1;
  for (size_t d = 0; d < dims; ++d) total *= steps;
  return total;
}

void SampleVariant(const Rig& rig, const SampleSpec& spec, size_t index, std::span<float> out) {
  const size_t n = rig.shapes.size();
  const std::vector<uint32_t> varied = VariedShapes(rig, spec);
  for (size_t s = 0; s < n; ++s)
    out[s] = spec.method == SampleMethod::kGaussian && !spec.center.empty() ? spec.center[s] : 0.0f;
  Rng rng{Mix(spec.seed ^ 0x5851F42D4C957F2Dull) ^
          (static_cast<uint64_t>(index) * 0xD1B54A32D192ED03ull)};

  // Which varied shapes move in this variant: all, or `active` of them (partial Fisher-Yates).
  std::vector<uint32_t> moving = varied;
  if (spec.active > 0 && spec.active < moving.size() && spec.method != SampleMethod::kGrid) {
    for (size_t i = 0; i < spec.active; ++i) {
      const size_t j =
          i + static_cast<size_t>(rng.Uniform() * static_cast<double>(moving.size() - i));
      std::swap(moving[i], moving[j]);
    }
    moving.resize(spec.active);
    std::sort(moving.begin(), moving.end());
  }

  switch (spec.method) {
    case SampleMethod::kUniform:
      for (uint32_t s : moving) {
        const Shape& sh = rig.shapes[s];
        out[s] =
            static_cast<float>(sh.min + (static_cast<double>(sh.max) - sh.min) * rng.Uniform());
      }
      break;
    case SampleMethod::kGaussian:
      for (uint32_t s : moving) {
        const Shape& sh = rig.shapes[s];
        const double mean = spec.center.empty() ? sh.default_weight : spec.center[s];
        out[s] = static_cast<float>(std::clamp(mean + spec.spread * rng.Normal(),
                                               static_cast<double>(sh.min),
                                               static_cast<double>(sh.max)));
      }
      break;
    case SampleMethod::kConvex: {
      double total = -std::log(rng.Open());  // The base's share.
      for (uint32_t s : moving) total += (out[s] = static_cast<float>(-std::log(rng.Open())));
      for (uint32_t s : moving) {
        out[s] =
            std::clamp(static_cast<float>(out[s] / total), rig.shapes[s].min, rig.shapes[s].max);
      }
      break;
    }
    case SampleMethod::kGrid: {
      const size_t dims = GridDims(spec, varied.size());
      const size_t steps = GridSteps(spec, dims);
      size_t rest = index;
      double t[3] = {0, 0, 0};
      for (size_t d = 0; d < dims && d < 3; ++d) {
        t[d] = steps > 1 ? static_cast<double>(rest % steps) / static_cast<double>(steps - 1) : 0.0;
        rest /= steps;
      }
      if (spec.points.size() >= 2) {
        for (size_t s = 0; s < n; ++s) {
          double w = spec.points[0][s];
          for (size_t d = 0; d + 1 < spec.points.size(); ++d)
            w += t[d] * (static_cast<double>(spec.points[d + 1][s]) - spec.points[0][s]);
          out[s] = static_cast<float>(w);
        }
      } else {
        for (size_t d = 0; d < varied.size(); ++d) {
          const Shape& sh = rig.shapes[varied[d]];
          out[varied[d]] =
              static_cast<float>(sh.min + t[d] * (static_cast<double>(sh.max) - sh.min));
        }
      }
      break;
    }
  }

  if (spec.symmetric) {
    for (uint32_t s : varied) {
      const int p = rig.shapes[s].partner;
      if (p >= 0 && !IsFixed(spec, static_cast<uint32_t>(p))) out[p] = out[s];
    }
  }
  for (const auto& [s, w] : spec.fixed) out[s] = w;
  if (spec.sum_at_most_one) {
    double cap = 1.0, positive = 0.0;
    for (size_t s = 0; s < n; ++s) {
      if (IsFixed(spec, static_cast<uint32_t>(s)) || out[s] < 0.0f)
        cap -= out[s];
      else
        positive += out[s];
    }
    if (positive > cap) {
      const double k = std::max(cap, 0.0) / positive;
      for (size_t s = 0; s < n; ++s) {
        if (!IsFixed(spec, static_cast<uint32_t>(s)) && out[s] > 0.0f)
          out[s] = static_cast<float>(out[s] * k);
      }
    }
  }
}

}  // namespace engine
}  // namespace facespace
