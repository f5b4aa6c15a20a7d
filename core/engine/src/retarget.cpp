// Retarget (retarget.h): the asked weights as a point of the shared space, then the rig's columns
// fitted to it by coordinate descent on the bounded least-squares problem, with a small price per
// unit of weight on the columns that are not the vocabulary's own words (a lasso's).
#include "facespace/engine/retarget.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "facespace/engine/face.h"

namespace facespace {
inline namespace engine {

namespace {

constexpr float kIndirectCost = 0.01f;  // A table's combination against a name's own column.
constexpr float kUnexpressed = 0.05f;   // Of a full shape: less is shown.
constexpr int kMaxSweeps = 200;
constexpr size_t kNamedAtMost = 8;

using Point = std::array<float, kArkitAxes>;

struct Column {
  uint32_t target;  // Shape, or expression.
  bool expression;
  float hi;
  float cost;  // A unit of its weight's price: 0 for the vocabulary's own names.
  std::span<const AxisTerm> terms;
};

std::span<const AxisTerm> PlaceOfShape(const Shape& s) {
  auto terms = Place(Vocabulary::kOwn, s.name);
  for (size_t a = 0; terms.empty() && a < s.aliases.size(); ++a)
    terms = Place(Vocabulary::kOwn, s.aliases[a]);
  return terms;
}

// Whether the rig's shape `name` is the vocabulary's own word for what it does.
bool OwnWord(const RetargetSource& from, const Shape& s) {
  switch (from.vocabulary) {
    case Vocabulary::kArkit: return !Place(Vocabulary::kArkit, s.name).empty();
    case Vocabulary::kMmd: return !Place(Vocabulary::kMmd, s.name).empty();
    case Vocabulary::kRig: return from.rig && FindShape(*from.rig, s.name) >= 0;
    default: return false;
  }
}

void ShapeColumns(const Rig& rig, const RetargetSource& from, std::vector<Column>& columns) {
  for (uint32_t k = 0; k < rig.shapes.size(); ++k) {
    const Shape& s = rig.shapes[k];
    if (s.driven || !(s.max > 0.0f)) continue;
    const auto terms = PlaceOfShape(s);
    if (terms.empty()) continue;
    columns.push_back({k, false, s.max, OwnWord(from, s) ? 0.0f : kIndirectCost, terms});
  }
}

// The rig's own VRM preset expressions (a VRM's, a manifest's), whose shapes sit nowhere: what
// makes an ARKit stream move a VRM whose shapes have names of its author's own.
void ExpressionColumns(const Rig& rig, const RetargetSource& from, std::vector<Column>& columns) {
  for (uint32_t e = 0; e < rig.expressions.size(); ++e) {
    const Expression& x = rig.expressions[e];
    if (x.derived || !IsExpressionPreset(x.name)) continue;
    const bool placed = std::any_of(x.binds.begin(), x.binds.end(), [&](const auto& b) {
      return !PlaceOfShape(rig.shapes[b.first]).empty();
    });
    const auto terms = Place(Vocabulary::kVrm, x.name);
    if (placed || terms.empty()) continue;
    const float cost = from.vocabulary == Vocabulary::kVrm ? 0.0f : kIndirectCost;
    columns.push_back({e, true, 1.0f, cost, terms});
  }
}

void Add(std::span<const AxisTerm> terms, float value, Point& p) {
  for (const AxisTerm& t : terms) p[t.axis] += value * t.amount;
}

// Coordinate descent from `w` with the residual kept: each step minimises over one column
// |residual|^2 + cost x weight (priced), or, over the columns in use, the residual alone.
void Solve(std::span<const Column> columns, bool priced, Point& residual, std::span<float> w) {
  for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
    float moved = 0.0f;
    for (size_t k = 0; k < columns.size(); ++k) {
      const Column& c = columns[k];
      if (!priced && w[k] == 0.0f) continue;
      float dot = 0.0f, norm = 0.0f;
      for (const AxisTerm& t : c.terms) {
        dot += t.amount * residual[t.axis];
        norm += t.amount * t.amount;
      }
      const float price = priced ? 0.5f * c.cost : 0.0f;
      const float next = std::clamp(w[k] + (dot - price) / norm, 0.0f, c.hi);
      if (next == w[k]) continue;
      Add(c.terms, w[k] - next, residual);
      moved = std::max(moved, std::abs(next - w[k]));
      w[k] = next;
    }
    if (moved < 1e-6f) break;
  }
}

// What the request asks, in the shared space; a kRig source's shapes that sit nowhere go to this
// rig's shape of their name (`passed`) or are named as not shown (`unplaced`).
struct Asked {
  Point point{};
  std::vector<std::pair<std::string, float>> passed, unplaced;
};

Status ReadNamed(const RetargetSource& from, std::span<const WeightEntry> entries, Asked& asked) {
  Status status = InvalidArgument("");
  for (const WeightEntry& e : entries) {
    if (e.name.empty()) {
      status.AddField(e.pointer, from.label + " weights are by name, not by index");
      continue;
    }
    if (!std::isfinite(e.value) || std::fabs(e.value) > 3.0e38) {
      status.AddField(e.pointer, "weight of '" + e.name + "' must be a finite number");
      continue;
    }
    const auto terms = Place(from.vocabulary, e.name);
    if (terms.empty() && !(from.vocabulary == Vocabulary::kVrm && IsExpressionPreset(e.name))) {
      status.AddField(e.pointer, [&] {
        const auto names = VocabularyNames(from.vocabulary);
        return "'" + e.name + "' is no " + from.label + " name" + DidYouMean(e.name, names);
      });
      continue;
    }
    Add(terms, static_cast<float>(e.value), asked.point);
  }
  if (status.fields.empty()) return Status::Ok();
  status.message = status.fields.front().message;
  if (status.field_count() > 1)
    status.message += " (and " + std::to_string(status.field_count() - 1) + " more)";
  return status;
}

Status ReadRig(const Rig& rig, const Rig& source, std::span<const WeightEntry> entries,
               Asked& asked) {
  auto weights = ResolveWeights(source, entries);
  if (!weights.ok()) return weights.status();
  for (size_t k = 0; k < source.shapes.size(); ++k) {
    const float w = weights.value()[k];
    if (w == 0.0f) continue;
    const Shape& s = source.shapes[k];
    const auto terms = PlaceOfShape(s);
    if (!terms.empty())
      Add(terms, w, asked.point);
    else
      (FindShape(rig, s.name) >= 0 ? asked.passed : asked.unplaced).emplace_back(s.name, w);
  }
  return Status::Ok();
}

// "this rig cannot show (of the arkit weights) jawLeft 0.8 (shows 0), ..."
void WarnUnexpressed(const RetargetSource& from, const Point& asked, const Point& residual,
                     const Asked& a, std::vector<Warning>& warnings) {
  std::vector<std::string> items;
  for (int i = 0; i < kArkitAxes; ++i) {
    if (std::abs(residual[i]) <= kUnexpressed) continue;
    items.push_back(std::string(kArkitNames[i]) + " " + FormatNumber(asked[i]) + " (shows " +
                    FormatNumber(asked[i] - residual[i]) + ")");
  }
  for (const auto& [name, w] : a.unplaced) items.push_back(name + " " + FormatNumber(w));
  if (items.empty()) return;
  std::string list;
  for (size_t i = 0; i < std::min(items.size(), kNamedAtMost); ++i)
    list += (i ? ", " : "") + items[i];
  if (items.size() > kNamedAtMost)
    list += " and " + std::to_string(items.size() - kNamedAtMost) + " more";
  warnings.push_back({"vocabulary_unexpressed",
                      "this rig cannot show all of the " + from.label + " weights: " + list,
                      items.front().substr(0, items.front().find(' ')),
                      static_cast<double>(items.size()), true});
}

}  // namespace

Status Retarget(const Rig& rig, const RetargetSource& from, std::span<const WeightEntry> entries,
                Retargeted& out, std::vector<Warning>& warnings) {
  out.weights.clear();
  out.expressions.clear();
  Asked asked;
  const Status read = from.vocabulary == Vocabulary::kRig
                          ? (from.rig ? ReadRig(rig, *from.rig, entries, asked)
                                      : InvalidArgument("no rig to read the weights by"))
                          : ReadNamed(from, entries, asked);
  if (!read.ok()) return read;
  std::vector<Column> columns;
  ShapeColumns(rig, from, columns);
  ExpressionColumns(rig, from, columns);
  // The own names first, so a sweep from 0 gives them what they show. Priced, what the own names
  // show is not asked of the tables' combinations, and of several combinations that would do alike
  // (Uka's まばたき, とじ目 and two winks each) one takes it, not a share each; then unpriced from
  // there over the columns in use, so what is shown is what was asked (priced, 0.995 of it).
  std::stable_sort(columns.begin(), columns.end(),
                   [](const Column& a, const Column& b) { return a.cost < b.cost; });
  Point residual = asked.point;
  std::vector<float> w(columns.size(), 0.0f);
  Solve(columns, true, residual, w);
  Solve(columns, false, residual, w);
  for (size_t k = 0; k < columns.size(); ++k) {
    if (w[k] <= 1e-4f) continue;  // Less moves nothing one could see.
    const Column& c = columns[k];
    const std::string& name =
        c.expression ? rig.expressions[c.target].name : rig.shapes[c.target].name;
    (c.expression ? out.expressions : out.weights).push_back({name, -1, w[k], "/weights"});
  }
  for (const auto& [name, value] : asked.passed)
    out.weights.push_back({name, -1, value, "/weights"});
  WarnUnexpressed(from, asked.point, residual, asked, warnings);
  return Status::Ok();
}

std::vector<std::span<const AxisTerm>> ShapePlaces(const Rig& rig) {
  std::vector<std::span<const AxisTerm>> places;
  places.reserve(rig.shapes.size());
  for (const Shape& s : rig.shapes) places.push_back(PlaceOfShape(s));
  return places;
}

void ArkitOfWeights(std::span<const std::span<const AxisTerm>> places,
                    std::span<const float> weights, std::span<float, kArkitAxes> out) {
  Point p{};
  const size_t n = std::min(places.size(), weights.size());
  for (size_t k = 0; k < n; ++k) {
    if (weights[k] != 0.0f) Add(places[k], weights[k], p);
  }
  for (int i = 0; i < kArkitAxes; ++i) out[i] = std::clamp(p[i], 0.0f, 1.0f);
}

void PresetsOfArkit(std::span<const float, kArkitAxes> arkit, std::span<float> out) {
  constexpr size_t kPresets = std::size(kExpressionPresets);
  // The presets' places, looked up (hashed) once: this runs a frame.
  struct Columns {
    std::array<Column, kPresets> column;
    size_t n = 0;
  };
  static const Columns columns = [] {
    Columns c;
    for (uint32_t k = 0; k < kPresets; ++k) {
      const auto terms = Place(Vocabulary::kVrm, kExpressionPresets[k]);
      if (!terms.empty()) c.column[c.n++] = {k, true, 1.0f, kIndirectCost, terms};
    }
    return c;
  }();
  Point residual;
  std::copy(arkit.begin(), arkit.end(), residual.begin());
  std::array<float, kPresets> w{};
  const std::span<const Column> used(columns.column.data(), columns.n);
  Solve(used, true, residual, std::span<float>(w.data(), columns.n));
  Solve(used, false, residual, std::span<float>(w.data(), columns.n));
  std::fill(out.begin(), out.end(), 0.0f);
  for (size_t k = 0; k < columns.n; ++k) {
    if (used[k].target < out.size()) out[used[k].target] = w[k] > 1e-4f ? w[k] : 0.0f;
  }
}

}  // namespace engine
}  // namespace facespace
