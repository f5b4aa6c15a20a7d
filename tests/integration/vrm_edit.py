#!/usr/bin/env python3
"""Edits a VRM 1.0 of ours for the tests (standard library only).

  vrm_edit.py binds IN.vrm OUT.vrm     the face material (1) textured with the meta's thumbnail, and two custom
                                       expressions: "tint" (a material colour bind to [1, 0.1, 0.1, 1]) and
                                       "slide" (a texture transform bind, offset [0.25, 0])
  vrm_edit.py hostile IN.vrm DIR       one file per fault in DIR (NAME.vrm), and DIR/faults.json: NAME -> the
                                       member a 422 must name
"""
import json
import os
import struct
import sys


def read(path):
    b = open(path, "rb").read()
    n = struct.unpack_from("<I", b, 12)[0]
    return json.loads(b[20:20 + n]), b[20 + n + 8:]


def write(path, doc, binary):
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(binary), 0x004E4942) + binary
    open(path, "wb").write(struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body)


def binds(src, dst):
    doc, binary = read(src)
    vrm = doc["extensions"]["VRMC_vrm"]
    thumbnail = vrm["meta"]["thumbnailImage"]
    texture = next(i for i, t in enumerate(doc["textures"]) if t["source"] == thumbnail)
    doc["materials"][1]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": texture}
    doc["materials"][1]["pbrMetallicRoughness"]["baseColorFactor"] = [1, 1, 1, 1]
    custom = vrm["expressions"].setdefault("custom", {})
    custom["tint"] = {"materialColorBinds": [{"material": 1, "type": "color", "targetValue": [1, 0.1, 0.1, 1]}]}
    custom["slide"] = {"textureTransformBinds": [{"material": 1, "scale": [1, 1], "offset": [0.25, 0]}]}
    write(dst, doc, binary)


def hostile(src, out):
    doc, binary = read(src)
    os.makedirs(out, exist_ok=True)
    faults = {}

    def case(name, pointer, edit):
        d = json.loads(json.dumps(doc))
        edit(d)
        write(os.path.join(out, name + ".vrm"), d, binary)
        faults[name] = pointer

    ex = "/extensions/VRMC_vrm/expressions/custom/"
    case("colour_material_out_of_range", ex + "blush/materialColorBinds/0/material",
         lambda d: d["extensions"]["VRMC_vrm"]["expressions"]["custom"]["blush"]["materialColorBinds"][0].update(material=9999))
    case("colour_target_not_numbers", ex + "blush/materialColorBinds/0/targetValue",
         lambda d: d["extensions"]["VRMC_vrm"]["expressions"]["custom"]["blush"]["materialColorBinds"][0].update(targetValue="red"))
    case("texture_bind_scale_short", ex + "blush/textureTransformBinds/0/scale",
         lambda d: d["extensions"]["VRMC_vrm"]["expressions"]["custom"]["blush"].update(textureTransformBinds=[{"material": 1, "scale": [1]}]))
    case("morph_bind_index_out_of_range", ex + "jawOpen/morphTargetBinds/0/index",
         lambda d: d["extensions"]["VRMC_vrm"]["expressions"]["custom"]["jawOpen"]["morphTargetBinds"][0].update(index=100000))
    case("is_binary_a_string", "/extensions/VRMC_vrm/expressions/preset/happy/isBinary",
         lambda d: d["extensions"]["VRMC_vrm"]["expressions"]["preset"]["happy"].update(isBinary="yes"))
    case("spring_joint_node_out_of_range", "/extensions/VRMC_springBone/springs/0/joints/0/node",
         lambda d: d["extensions"]["VRMC_springBone"]["springs"][0]["joints"][0].update(node=-3))
    case("spring_collider_group_out_of_range", "/extensions/VRMC_springBone/springs/1/colliderGroups/0",
         lambda d: d["extensions"]["VRMC_springBone"]["springs"][1].update(colliderGroups=[77]))
    case("collider_radius_a_string", "/extensions/VRMC_springBone/colliders/0/shape/capsule/radius",
         lambda d: d["extensions"]["VRMC_springBone"]["colliders"][0]["shape"]["capsule"].update(radius="big"))
    node = next(i for i, n in enumerate(doc["nodes"]) if "VRMC_node_constraint" in n.get("extensions", {}))
    case("constraint_source_out_of_range", f"/nodes/{node}/extensions/VRMC_node_constraint/constraint/rotation/source",
         lambda d: d["nodes"][node]["extensions"]["VRMC_node_constraint"]["constraint"]["rotation"].update(source=len(doc["nodes"]) + 5))
    json.dump(faults, open(os.path.join(out, "faults.json"), "w"), indent=1)


if __name__ == "__main__":
    {"binds": binds, "hostile": hostile}[sys.argv[1]](sys.argv[2], sys.argv[3])
