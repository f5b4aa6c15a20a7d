// The manifest's "terms": what the rig's authors allow, in VRM 1.0 meta's words, and "source",
// where they say so (a licence, a README's guideline). Members left out keep VRM's most restrictive
// value.
#include <algorithm>
#include <iterator>

#include "common/vrm_terms.h"
#include "sections.h"

namespace facespace::formats::manifest {

namespace {

template <typename E, size_t N>
Status ReadEnum(const EnumName<E> (&table)[N], const json& v, const std::string& ptr, E* out) {
  if (v.is_string() && ParseEnum(table, v.get<std::string>(), out) &&
      EnumEntry(table, *out).name == v.get<std::string>())
    return Status::Ok();
  return Bad(ptr, "must be one of " + EnumNames(table));
}

}  // namespace

Status ApplyTerms(Rig& rig, const json& v) {
  if (!v.is_object())
    return Bad(
        "/terms",
        "must be an object: VRM 1.0 meta's terms and \"source\", where the authors state them");
  UsageTerms t;
  std::vector<std::string_view> known = {"source", "avatarPermission", "commercialUsage",
                                         "creditNotation", "modification"};
  for (const vrm_terms::Flag& f : vrm_terms::kFlags) known.push_back(f.name);
  for (auto it = v.begin(); it != v.end(); ++it) {
    const std::string ptr = "/terms/" + JsonPointerEscape(it.key());
    if (std::find(known.begin(), known.end(), it.key()) == known.end())
      return Bad(ptr, "unknown member" + DidYouMean(it.key(), known));
    const json& x = it.value();
    Status s = Status::Ok();
    if (it.key() == "source") {
      if (!x.is_string() || x.get<std::string>().empty())
        return Bad(ptr, "must say where the authors state these terms (a URL, a file and section)");
      t.source = x.get<std::string>();
    } else if (it.key() == "avatarPermission") {
      s = ReadEnum(vrm_terms::kAvatar, x, ptr, &t.avatar);
    } else if (it.key() == "commercialUsage") {
      s = ReadEnum(vrm_terms::kCommercial, x, ptr, &t.commercial);
    } else if (it.key() == "modification") {
      s = ReadEnum(vrm_terms::kModification, x, ptr, &t.modification);
    } else if (it.key() == "creditNotation") {
      if (x != "required" && x != "unnecessary")
        return Bad(ptr, "must be \"required\" or \"unnecessary\"");
      t.credit_required = x == "required";
    } else {
      if (!x.is_boolean()) return Bad(ptr, "must be true or false");
      for (const vrm_terms::Flag& f : vrm_terms::kFlags) {
        if (it.key() == f.name) t.*f.member = x.get<bool>();
      }
    }
    if (!s.ok()) return s;
  }
  if (t.source.empty())
    return Bad("/terms/source", "is required: where the rig's authors state these terms");
  rig.terms = std::move(t);
  return Status::Ok();
}

json TermsValue(const UsageTerms& t) {
  json o = vrm_terms::Meta1(t);
  o["source"] = t.source;
  return o;
}

}  // namespace facespace::formats::manifest
