// The manifest's sections about the shapes themselves: materials' colours, derived (mirrored or
// masked) shapes, groups, and each shape's range, default, group, aliases and partner.
#include <algorithm>
#include <cmath>

#include "facespace/engine/shape_tools.h"
#include "facespace/formats/io.h"
#include "sections.h"

namespace facespace::formats::manifest {

namespace {

// One material's base colour (RGBA) and stand-in: for a rig whose textures are not at hand (an MMD
// model's blush is a red texture on a see-through material). A name the rig lacks warns.
Status ApplyMaterial(Rig& rig, const std::string& key, const json& item, const std::string& ptr) {
  auto found = std::find_if(rig.materials.begin(), rig.materials.end(),
                            [&](const Material& x) { return x.name == key; });
  const json& c = item.is_object() && item.contains("base_color") ? item["base_color"] : json();
  const json& stand_in =
      item.is_object() && item.contains("stand_in") ? item["stand_in"] : json("none");
  if (!item.is_object() || item.size() != 1u + item.contains("stand_in") || !c.is_array() ||
      c.size() != 4 || !std::all_of(c.begin(), c.end(), [](const json& x) {
        return x.is_number() && x.get<double>() >= 0 && x.get<double>() <= 1;
      })) {
    return Bad(
        ptr, "must be {\"base_color\": [r, g, b, a]}, each in [0, 1], and optionally \"stand_in\"");
  }
  if (stand_in != "none" && stand_in != "soft")
    return Bad(ptr + "/stand_in", "must be \"none\" or \"soft\"");
  if (found == rig.materials.end()) {
    rig.load_warnings.push_back({"manifest_unknown_material",
                                 "manifest: " + ptr + " names no material of the rig",
                                 key.substr(0, 60), 0.0, false});
    return Status::Ok();
  }
  for (int k = 0; k < 4; ++k) found->base_color_factor[k] = c[k].get<float>();
  found->stand_in = stand_in == "soft" ? StandIn::kSoft : StandIn::kNone;
  return Status::Ok();
}

// One new shape: mirrored across an axis and/or masked to a side or vertices, from another.
Status ApplyDerivedShape(Rig& rig, const std::string& key, const json& o, const std::string& ptr) {
  if (!o.is_object() || !o.contains("from") || !o["from"].is_string())
    return Bad(ptr, "must be an object with \"from\": a shape name");
  DeriveOptions d;
  auto axis_of = [](const std::string& a) {
    return a == "x" ? 0 : a == "y" ? 1 : a == "z" ? 2 : -1;
  };
  if (o.contains("mirror")) {
    if (!o["mirror"].is_string() || axis_of(o["mirror"].get<std::string>()) < 0)
      return Bad(ptr + "/mirror",
                 "must be \"x\", \"y\" or \"z\" (the axis across which to reflect)");
    d.mirror = true;
    d.axis = axis_of(o["mirror"].get<std::string>());
  }
  if (o.contains("tolerance")) {
    if (!o["tolerance"].is_number() || o["tolerance"].get<double>() <= 0)
      return Bad(ptr + "/tolerance", "must be a positive number");
    d.tolerance = o["tolerance"].get<float>();
  }
  if (o.contains("mask")) {
    const json& m = o["mask"];
    if (!m.is_object())
      return Bad(ptr + "/mask", "must be an object {\"side\", \"falloff\", \"vertices\"}");
    d.masked = true;
    if (m.contains("side")) {
      const std::string side = m["side"].is_string() ? m["side"].get<std::string>() : "";
      if (side.size() != 2 || (side[0] != '+' && side[0] != '-') || axis_of(side.substr(1)) < 0) {
        return Bad(ptr + "/mask/side", "must be \"+x\", \"-x\", \"+y\", \"-y\", \"+z\" or \"-z\"");
      }
      d.mask.side = side[0] == '+' ? 1 : -1;
      d.mask.axis = axis_of(side.substr(1));
    }
    if (m.contains("falloff")) {
      if (!m["falloff"].is_number() || m["falloff"].get<double>() < 0)
        return Bad(ptr + "/mask/falloff", "must be a number >= 0 (mesh units)");
      d.mask.falloff = m["falloff"].get<float>();
    }
    if (m.contains("vertices")) {
      if (!m["vertices"].is_array())
        return Bad(ptr + "/mask/vertices", "must be an array of vertex indices");
      for (const json& v : m["vertices"]) {
        if (!v.is_number_unsigned())
          return Bad(ptr + "/mask/vertices", "must be an array of vertex indices");
        d.mask.vertices.push_back(v.get<uint32_t>());
      }
    }
  }
  if (!d.mirror && !d.masked) return Bad(ptr, "needs \"mirror\" or \"mask\" (or both)");
  auto r = DeriveShape(rig, key, o["from"].get<std::string>(), d);
  if (!r.ok()) return Bad(ptr, r.status().message);
  if (r->unmatched > 0) {
    rig.load_warnings.push_back({"mirror_unmatched",
                                 std::to_string(r->unmatched) + " moved vertices of '" +
                                     o["from"].get<std::string>() + "' have no mirror image; '" +
                                     key + "' leaves them still",
                                 key, static_cast<double>(r->unmatched), true});
  }
  return Status::Ok();
}

// One group's shapes; shapes the rig lacks warn.
Status ApplyGroup(Rig& rig, const std::string& key, const json& item, const std::string& ptr) {
  if (!item.is_array()) return Bad(ptr, "must be an array of shape names");
  for (const json& name : item) {
    if (!name.is_string()) return Bad(ptr, "must hold strings");
    const int s = FindShape(rig, name.get<std::string>());
    if (s < 0) {
      rig.load_warnings.push_back({"manifest_unknown_shape",
                                   "manifest names unknown shape '" + name.get<std::string>() + "'",
                                   name.get<std::string>(), 0.0, false});
      continue;
    }
    rig.shapes[s].group = key;
  }
  return Status::Ok();
}

// One shape's range, default, group, aliases and partner; a shape the rig lacks warns.
Status ApplyShape(Rig& rig, const std::string& key, const json& o, const std::string& ptr) {
  if (!o.is_object()) return Bad(ptr, "must be an object");
  const int s = FindShape(rig, key);
  if (s < 0) {
    rig.load_warnings.push_back(
        {"manifest_unknown_shape", "manifest names unknown shape '" + key + "'", key, 0.0, false});
    return Status::Ok();
  }
  Shape& shape = rig.shapes[s];
  for (const char* bound : {"min", "max", "default"}) {
    if (!o.contains(bound)) continue;
    if (!o[bound].is_number()) return Bad(ptr + "/" + bound, "must be a number");
    const float v = o[bound].get<float>();
    (std::string(bound) == "min"   ? shape.min
     : std::string(bound) == "max" ? shape.max
                                   : shape.default_weight) = v;
  }
  if (shape.min > shape.max) return Bad(ptr, "min is greater than max");
  if (o.contains("group")) {
    if (!o["group"].is_string()) return Bad(ptr + "/group", "must be a string");
    shape.group = o["group"].get<std::string>();
  }
  if (o.contains("aliases")) {
    if (!o["aliases"].is_array()) return Bad(ptr + "/aliases", "must be an array of strings");
    for (const json& a : o["aliases"]) {
      if (!a.is_string()) return Bad(ptr + "/aliases", "must be an array of strings");
      const int other = FindShape(rig, a.get<std::string>());
      if (other >= 0 && other != s)
        return Bad(ptr + "/aliases", "'" + a.get<std::string>() + "' already names another shape");
      shape.aliases.push_back(a.get<std::string>());
    }
  }
  if (o.contains("partner")) {
    if (o["partner"].is_null()) {
      if (shape.partner >= 0) rig.shapes[shape.partner].partner = -1;
      shape.partner = -1;
      return Status::Ok();
    }
    if (!o["partner"].is_string()) return Bad(ptr + "/partner", "must be a shape name or null");
    const int p = FindShape(rig, o["partner"].get<std::string>());
    if (p < 0 || p == s)
      return Bad(ptr + "/partner",
                 "unknown partner shape '" + o["partner"].get<std::string>() + "'");
    if (shape.partner >= 0) rig.shapes[shape.partner].partner = -1;
    if (rig.shapes[p].partner >= 0) rig.shapes[rig.shapes[p].partner].partner = -1;
    shape.partner = p;
    rig.shapes[p].partner = s;
  }
  return Status::Ok();
}

}  // namespace

// "materials": a material's base colour by name.
Status ApplyMaterials(Rig& rig, const json& m) {
  // A material's base colour (RGBA) by name: for a rig whose textures are not at hand (an MMD
  // model's blush is a red texture on a see-through material).
  return ForEachMember(m, "/materials",
                       "must be an object of material name -> {\"base_color\": [r, g, b, a], "
                       "\"stand_in\": \"soft\"}",
                       rig, ApplyMaterial);
}
// "derived": new shapes mirrored or masked from others.
Status ApplyDerived(Rig& rig, const json& section) {
  // New shapes first, so that the rest of the manifest can describe them too.
  return ForEachMember(section, "/derived",
                       "must be an object of new shape -> {\"from\", \"mirror\", \"mask\"}", rig,
                       ApplyDerivedShape);
}
// "groups": group -> [shape names]; unknown shapes warn.
Status ApplyGroups(Rig& rig, const json& section) {
  return ForEachMember(section, "/groups", "must be an object of group -> [shape names]", rig,
                       ApplyGroup);
}
// "shapes": name -> {min, max, default, group, aliases, partner}; unknown shapes warn.
Status ApplyShapes(Rig& rig, const json& section) {
  return ForEachMember(section, "/shapes", "must be an object of shape name -> properties", rig,
                       ApplyShape);
}

}  // namespace facespace::formats::manifest
