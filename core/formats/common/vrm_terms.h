// A rig's usage terms (core's UsageTerms) as VRM 1.0's meta says them and as VRM 0.x's meta says
// them: one table per closed set, read by the manifest ("terms", in 1.0's words), the VRM importer
// and both VRM writers.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "facespace/engine/enum_table.h"
#include "facespace/engine/rig.h"

namespace facespace::formats::vrm_terms {

using Avatar = UsageTerms::Avatar;
using Commercial = UsageTerms::Commercial;
using Modification = UsageTerms::Modification;

// 1.0's names (the canonical ones) with 0.x's as aliases where 0.x has the value.
inline constexpr EnumName<Avatar> kAvatar[] = {
    {Avatar::kOnlyAuthor, "onlyAuthor", "OnlyAuthor"},
    {Avatar::kOnlySeparatelyLicensedPerson, "onlySeparatelyLicensedPerson",
     "ExplicitlyLicensedPerson"},
    {Avatar::kEveryone, "everyone", "Everyone"}};
inline constexpr EnumName<Commercial> kCommercial[] = {
    {Commercial::kPersonalNonProfit, "personalNonProfit", "Disallow"},
    {Commercial::kPersonalProfit, "personalProfit"},
    {Commercial::kCorporation, "corporation", "Allow"}};
inline constexpr EnumName<Modification> kModification[] = {
    {Modification::kProhibited, "prohibited"},
    {Modification::kAllowModification, "allowModification"},
    {Modification::kAllowModificationRedistribution, "allowModificationRedistribution"}};

// The boolean members of 1.0's meta, each with its place in UsageTerms.
struct Flag {
  const char* name;
  bool UsageTerms::*member;
};
inline constexpr Flag kFlags[] = {
    {"allowExcessivelyViolentUsage", &UsageTerms::violent},
    {"allowExcessivelySexualUsage", &UsageTerms::sexual},
    {"allowPoliticalOrReligiousUsage", &UsageTerms::political_or_religious},
    {"allowAntisocialOrHateUsage", &UsageTerms::antisocial_or_hate},
    {"allowRedistribution", &UsageTerms::redistribution}};

// 1.0's meta members for `t` (the caller adds name, authors and licences).
inline nlohmann::ordered_json Meta1(const UsageTerms& t) {
  nlohmann::ordered_json m;
  m["avatarPermission"] = EnumEntry(kAvatar, t.avatar).name;
  m["commercialUsage"] = EnumEntry(kCommercial, t.commercial).name;
  for (const Flag& f : kFlags) m[f.name] = t.*f.member;
  m["creditNotation"] = t.credit_required ? "required" : "unnecessary";
  m["modification"] = EnumEntry(kModification, t.modification).name;
  return m;
}

// 0.x's: allowedUserName, violentUssageName, sexualUssageName, commercialUssageName (sic),
// "Allow"/"Disallow". 0.x has no political, hate, credit or redistribution members: its licenseName
// says the rest.
inline nlohmann::ordered_json Meta0(const UsageTerms& t) {
  auto allow = [](bool b) { return b ? "Allow" : "Disallow"; };
  return {{"allowedUserName", EnumEntry(kAvatar, t.avatar).alias},
          {"violentUssageName", allow(t.violent)},
          {"sexualUssageName", allow(t.sexual)},
          {"commercialUssageName", allow(t.commercial == Commercial::kCorporation)}};
}

}  // namespace facespace::formats::vrm_terms
