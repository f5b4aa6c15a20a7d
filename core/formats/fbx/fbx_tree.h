// FBX's node tree, binary (6.x-7.x: 32- and 64-bit offsets, zlib-compressed arrays) and ASCII,
// read into one in-memory form. Internal to core: fbx_import.cpp turns the tree into a Rig.
//
// A parser of untrusted bytes: every offset and length is checked against the buffer, nesting
// is capped, compressed arrays must inflate to exactly their declared size, and the total of
// decoded array bytes is capped (zlib bombs).
#pragma once

#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/engine/status.h"

namespace facespace::formats::fbx {

// One property of a node: a scalar (integer, number or string) or an array. Integer and
// number kinds convert to each other on read, so binary and ASCII files read the same.
struct Prop {
  enum Kind : uint8_t { kInt, kNumber, kString, kInts, kNumbers } kind = kInt;
  int64_t i = 0;
  double d = 0.0;
  std::string s;
  std::vector<int64_t> ints;
  std::vector<double> numbers;

  double AsNumber() const { return kind == kInt ? static_cast<double>(i) : d; }
  // A number outside int64's range (or not finite) reads as 0.
  int64_t AsInt() const {
    return kind == kNumber ? (std::fabs(d) < 9.2e18 ? static_cast<int64_t>(d) : 0) : i;
  }
  bool IsScalarNumber() const { return kind == kInt || kind == kNumber; }
  bool IsArray() const { return kind == kInts || kind == kNumbers; }
  size_t ArraySize() const {
    return kind == kInts ? ints.size() : kind == kNumbers ? numbers.size() : 0;
  }
};

struct Node {
  std::string name;
  std::vector<Prop> props;
  std::vector<Node> children;

  // The first child called `child`, or nullptr.
  const Node* Find(std::string_view child) const;
};

struct Document {
  uint32_t version = 0;  // 7400, 7500, ... (ASCII: from FBXHeaderExtension/FBXVersion).
  bool binary = false;
  std::vector<Node> roots;

  const Node* Find(std::string_view name) const;
};

struct Limits {
  size_t max_depth = 64;
  size_t max_nodes = 4'000'000;
  size_t max_decoded_bytes = size_t{512} << 20;  // Sum over every array.
};

// True when the bytes start like a binary FBX ("Kaydara FBX Binary") or an ASCII one (after white
// space, the "; FBX" comment, or an FBXHeaderExtension node in the first kilobyte). The registry's
// test.
bool LooksLikeFbx(std::span<const unsigned char> bytes);

// Reads either kind (told apart by the magic). Errors name the byte offset (binary) or the
// line (ASCII) and the node being read.
Result<Document> Parse(std::span<const unsigned char> bytes, const Limits& limits = {});

// An object's name without its class: "Model::pCube1" (ASCII) and "pCube1\0\1Model" (binary)
// both give "pCube1".
std::string ObjectName(std::string_view raw);

}  // namespace facespace::formats::fbx
