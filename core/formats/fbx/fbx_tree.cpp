// FBX node trees from binary and ASCII files. See fbx_tree.h.
#include "fbx/fbx_tree.h"

#include <zlib.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>

namespace facespace::formats::fbx {

namespace {

constexpr char kBinaryMagic[] = "Kaydara FBX Binary  ";  // 20 chars, then \0 \x1a \0.
constexpr size_t kHeaderSize = 27;

// ---------------------------------------------------------------------------------------------
// Binary

class BinaryReader {
 public:
  BinaryReader(std::span<const unsigned char> bytes, const Limits& limits)
      : b_(bytes), limits_(limits) {}

  Status Read(Document& doc) {
    doc.binary = true;
    doc.version = U32At(23);
    wide_ = doc.version >= 7500;
    size_t pos = kHeaderSize;
    // Top-level records until the null record; what follows it (the footer) is not ours.
    while (pos < b_.size()) {
      Node node;
      bool end = false;
      if (!ReadNode(pos, 0, node, end)) return InvalidArgument(error_);
      if (end) break;
      doc.roots.push_back(std::move(node));
    }
    return Status::Ok();
  }

 private:
  bool Fail(size_t at, const std::string& what) {
    if (error_.empty()) error_ = "FBX byte " + std::to_string(at) + ": " + what;
    return false;
  }

  uint32_t U32At(size_t at) const {
    uint32_t v = 0;
    std::memcpy(&v, b_.data() + at, 4);
    return v;
  }
  uint64_t U64At(size_t at) const {
    uint64_t v = 0;
    std::memcpy(&v, b_.data() + at, 8);
    return v;
  }
  bool Has(size_t at, size_t n) const { return at <= b_.size() && n <= b_.size() - at; }

  // One node record at `pos`; `end` is set by a null record (the end of a child list).
  bool ReadNode(size_t& pos, size_t depth, Node& node, bool& end) {
    const size_t head = wide_ ? 25 : 13;
    if (!Has(pos, head)) return Fail(pos, "truncated node record");
    const uint64_t end_offset = wide_ ? U64At(pos) : U32At(pos);
    const uint64_t nprops = wide_ ? U64At(pos + 8) : U32At(pos + 4);
    const uint64_t props_len = wide_ ? U64At(pos + 16) : U32At(pos + 8);
    const size_t name_len = b_[pos + head - 1];
    if (end_offset == 0) {
      end = true;
      pos += head;
      return true;
    }
    if (depth >= limits_.max_depth)
      return Fail(pos, "nodes nested deeper than " + std::to_string(limits_.max_depth));
    if (++nodes_ > limits_.max_nodes)
      return Fail(pos, "more than " + std::to_string(limits_.max_nodes) + " nodes");
    const size_t start = pos;
    pos += head;
    if (!Has(pos, name_len)) return Fail(start, "truncated node name");
    node.name.assign(reinterpret_cast<const char*>(b_.data() + pos), name_len);
    pos += name_len;
    if (end_offset > b_.size() || end_offset < pos)
      return Fail(start, "node '" + node.name + "' ends at " + std::to_string(end_offset) +
                             ", outside the file");
    if (props_len > end_offset - pos)
      return Fail(start, "node '" + node.name + "': its properties run past its end");
    if (nprops > props_len)
      return Fail(start, "node '" + node.name + "': " + std::to_string(nprops) + " properties in " +
                             std::to_string(props_len) + " bytes");
    const size_t props_end = pos + static_cast<size_t>(props_len);
    node.props.reserve(static_cast<size_t>(nprops));
    for (uint64_t k = 0; k < nprops; ++k) {
      Prop p;
      if (!ReadProp(pos, props_end, node.name, p)) return false;
      node.props.push_back(std::move(p));
    }
    if (pos != props_end)
      return Fail(pos, "node '" + node.name + "': properties do not fill their declared length");
    while (pos < end_offset) {
      Node child;
      bool child_end = false;
      if (!ReadNode(pos, depth + 1, child, child_end)) return false;
      if (child_end) break;
      node.children.push_back(std::move(child));
    }
    if (pos > end_offset) return Fail(start, "node '" + node.name + "': children run past its end");
    pos = static_cast<size_t>(end_offset);
    return true;
  }

  template <typename T>
  static T Load(const unsigned char* p) {
    T v;
    std::memcpy(&v, p, sizeof(T));
    return v;
  }

  bool ReadProp(size_t& pos, size_t end, const std::string& owner, Prop& p) {
    if (pos >= end) return Fail(pos, "node '" + owner + "': missing property");
    const char type = static_cast<char>(b_[pos++]);
    auto need = [&](size_t n) {
      return n <= end - pos ? true : Fail(pos, "node '" + owner + "': truncated property");
    };
    switch (type) {
      case 'Y':
        if (!need(2)) return false;
        p.kind = Prop::kInt;
        p.i = Load<int16_t>(&b_[pos]);
        pos += 2;
        return true;
      case 'C':
        if (!need(1)) return false;
        p.kind = Prop::kInt;
        p.i = b_[pos] != 0;
        pos += 1;
        return true;
      case 'I':
        if (!need(4)) return false;
        p.kind = Prop::kInt;
        p.i = Load<int32_t>(&b_[pos]);
        pos += 4;
        return true;
      case 'L':
        if (!need(8)) return false;
        p.kind = Prop::kInt;
        p.i = Load<int64_t>(&b_[pos]);
        pos += 8;
        return true;
      case 'F':
        if (!need(4)) return false;
        p.kind = Prop::kNumber;
        p.d = Load<float>(&b_[pos]);
        pos += 4;
        return true;
      case 'D':
        if (!need(8)) return false;
        p.kind = Prop::kNumber;
        p.d = Load<double>(&b_[pos]);
        pos += 8;
        return true;
      case 'S':
      case 'R': {
        if (!need(4)) return false;
        const uint32_t n = Load<uint32_t>(&b_[pos]);
        pos += 4;
        if (!need(n)) return false;
        p.kind = Prop::kString;
        p.s.assign(reinterpret_cast<const char*>(&b_[pos]), n);
        pos += n;
        return true;
      }
      case 'f':
      case 'd':
      case 'l':
      case 'i':
      case 'b': return ReadArray(pos, end, owner, type, p);
      default:
        return Fail(pos - 1, "node '" + owner + "': unknown property type 0x" +
                                 Hex(static_cast<unsigned char>(type)));
    }
  }

  static std::string Hex(unsigned char c) {
    const char* digits = "0123456789abcdef";
    return std::string{digits[c >> 4], digits[c & 15]};
  }

  bool ReadArray(size_t& pos, size_t end, const std::string& owner, char type, Prop& p) {
    if (end - pos < 12) return Fail(pos, "node '" + owner + "': truncated array header");
    const uint32_t count = Load<uint32_t>(&b_[pos]);
    const uint32_t encoding = Load<uint32_t>(&b_[pos + 4]);
    const uint32_t stored = Load<uint32_t>(&b_[pos + 8]);
    pos += 12;
    const size_t elem = (type == 'd' || type == 'l') ? 8 : type == 'b' ? 1 : 4;
    const uint64_t bytes = uint64_t{count} * elem;
    if (stored > end - pos)
      return Fail(pos, "node '" + owner + "': array data runs past its node (" +
                           std::to_string(stored) + " bytes)");
    if (bytes > limits_.max_decoded_bytes - decoded_) {
      return Fail(pos, "node '" + owner + "': arrays decode to more than " +
                           std::to_string(limits_.max_decoded_bytes >> 20) + " MiB");
    }
    decoded_ += static_cast<size_t>(bytes);
    raw_.resize(static_cast<size_t>(bytes));
    const unsigned char* src = &b_[pos];
    if (encoding == 0) {
      if (stored != bytes)
        return Fail(pos, "node '" + owner + "': array of " + std::to_string(count) + " stored in " +
                             std::to_string(stored) + " bytes");
      if (bytes) std::memcpy(raw_.data(), src, static_cast<size_t>(bytes));
    } else if (encoding == 1) {
      if (!Inflate(src, stored, raw_))
        return Fail(pos, "node '" + owner + "': compressed array does not inflate to exactly " +
                             std::to_string(count) + " elements");
    } else {
      return Fail(pos - 8,
                  "node '" + owner + "': unknown array encoding " + std::to_string(encoding));
    }
    pos += stored;
    const unsigned char* r = raw_.data();
    if (type == 'f' || type == 'd') {
      p.kind = Prop::kNumbers;
      p.numbers.resize(count);
      for (uint32_t k = 0; k < count; ++k)
        p.numbers[k] = type == 'f' ? Load<float>(r + 4 * k) : Load<double>(r + 8 * k);
    } else {
      p.kind = Prop::kInts;
      p.ints.resize(count);
      for (uint32_t k = 0; k < count; ++k) {
        p.ints[k] = type == 'l'   ? Load<int64_t>(r + 8 * k)
                    : type == 'i' ? Load<int32_t>(r + 4 * k)
                                  : (r[k] != 0);
      }
    }
    return true;
  }

  // zlib stream -> exactly out.size() bytes (more or fewer is an error: never inflates past).
  static bool Inflate(const unsigned char* src, size_t n, std::vector<unsigned char>& out) {
    z_stream z{};
    if (inflateInit(&z) != Z_OK) return false;
    z.next_in = const_cast<unsigned char*>(src);
    z.avail_in = static_cast<uInt>(n);
    unsigned char spare = 0;
    z.next_out = out.empty() ? &spare : out.data();
    z.avail_out = out.empty() ? 1 : static_cast<uInt>(out.size());
    const int rc = inflate(&z, Z_FINISH);
    const bool ok = rc == Z_STREAM_END && z.total_out == out.size();
    inflateEnd(&z);
    return ok;
  }

  std::span<const unsigned char> b_;
  const Limits& limits_;
  bool wide_ = false;
  size_t nodes_ = 0;
  size_t decoded_ = 0;
  std::vector<unsigned char> raw_;
  std::string error_;
};

// ---------------------------------------------------------------------------------------------
// ASCII: `Name: value, value, ... { children }`; arrays `Name: *N { a: v, v, ... }`; `;` comments.

class AsciiReader {
 public:
  AsciiReader(std::string_view text, const Limits& limits) : s_(text), limits_(limits) {}

  Status Read(Document& doc) {
    doc.binary = false;
    if (!ReadList(0, doc.roots, /*top=*/true)) return InvalidArgument(error_);
    return Status::Ok();
  }

 private:
  bool Fail(const std::string& what) {
    if (error_.empty()) error_ = "FBX line " + std::to_string(line_) + ": " + what;
    return false;
  }

  // Skips blanks (newlines too when `lines`), and comments.
  void Skip(bool lines = true) {
    while (pos_ < s_.size()) {
      const char c = s_[pos_];
      if (c == ';') {
        while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;
      } else if (c == '\n') {
        if (!lines) return;
        ++line_;
        ++pos_;
      } else if (c == ' ' || c == '\t' || c == '\r') {
        ++pos_;
      } else {
        return;
      }
    }
  }

  bool ReadList(size_t depth, std::vector<Node>& out, bool top) {
    for (;;) {
      Skip();
      if (pos_ >= s_.size()) return top ? true : Fail("missing '}'");
      if (s_[pos_] == '}') {
        if (top) return Fail("'}' without an open node");
        ++pos_;
        return true;
      }
      Node node;
      if (!ReadNode(depth, node)) return false;
      out.push_back(std::move(node));
    }
  }

  static bool NameChar(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '|' || c == '-' ||
           c == '.';
  }

  bool ReadNode(size_t depth, Node& node) {
    if (depth >= limits_.max_depth)
      return Fail("nodes nested deeper than " + std::to_string(limits_.max_depth));
    if (++nodes_ > limits_.max_nodes)
      return Fail("more than " + std::to_string(limits_.max_nodes) + " nodes");
    const size_t start = pos_;
    while (pos_ < s_.size() && NameChar(s_[pos_])) ++pos_;
    if (pos_ == start || pos_ >= s_.size() || s_[pos_] != ':') {
      return Fail("expected a node name and ':', got '" +
                  std::string(s_.substr(start, std::min<size_t>(20, s_.size() - start))) + "'");
    }
    node.name.assign(s_.substr(start, pos_ - start));
    ++pos_;
    // Values: comma separated, a trailing comma continues on the next line.
    Skip(false);
    while (pos_ < s_.size() && s_[pos_] != '\n' && s_[pos_] != '{' && s_[pos_] != '}') {
      Prop p;
      if (s_[pos_] == '*') {
        if (!ReadArray(node.name, p)) return false;
        node.props.push_back(std::move(p));
        return true;  // The array's braces closed the node.
      }
      if (!ReadValue(node.name, p)) return false;
      node.props.push_back(std::move(p));
      Skip(false);
      if (pos_ < s_.size() && s_[pos_] == ',') {
        ++pos_;
        Skip(true);
      } else {
        break;
      }
    }
    Skip(false);
    if (pos_ < s_.size() && s_[pos_] == '{') {
      ++pos_;
      return ReadList(depth + 1, node.children, false);
    }
    return true;
  }

  bool ReadValue(const std::string& owner, Prop& p) {
    if (s_[pos_] == '"') {
      const size_t end = s_.find('"', pos_ + 1);
      if (end == std::string_view::npos) return Fail("node '" + owner + "': unterminated string");
      p.kind = Prop::kString;
      p.s.assign(s_.substr(pos_ + 1, end - pos_ - 1));
      for (char c : p.s) line_ += c == '\n';
      pos_ = end + 1;
      return true;
    }
    const size_t start = pos_;
    while (pos_ < s_.size() && s_[pos_] != ',' && s_[pos_] != '\n' && s_[pos_] != '\r' &&
           s_[pos_] != ' ' && s_[pos_] != '\t' && s_[pos_] != '{' && s_[pos_] != '}' &&
           s_[pos_] != ';') {
      ++pos_;
    }
    const std::string tok(s_.substr(start, pos_ - start));
    if (tok.empty()) return Fail("node '" + owner + "': empty value");
    return Number(tok, p)
               ? true
               : (p.kind = Prop::kString, p.s = tok, true);  // Bare words (Y, T, ...) are strings.
  }

  // An integer or a number; false when `tok` is neither.
  static bool Number(const std::string& tok, Prop& p) {
    const char c = tok[0];
    if (!(std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '+' || c == '.'))
      return false;
    char* end = nullptr;
    errno = 0;
    const long long v = std::strtoll(tok.c_str(), &end, 10);
    if (*end == '\0' && errno != ERANGE) {
      p.kind = Prop::kInt;
      p.i = v;
      return true;
    }
    const double d = std::strtod(tok.c_str(), &end);
    if (*end != '\0' || !std::isfinite(d)) return false;
    p.kind = Prop::kNumber;
    p.d = d;
    return true;
  }

  // `*N { a: v, v, ... }`: N values, integers or numbers.
  bool ReadArray(const std::string& owner, Prop& p) {
    ++pos_;
    const size_t start = pos_;
    while (pos_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[pos_]))) ++pos_;
    const std::string count_text(s_.substr(start, pos_ - start));
    if (count_text.empty() || count_text.size() > 10)
      return Fail("node '" + owner + "': bad array count");
    const uint64_t count = std::strtoull(count_text.c_str(), nullptr, 10);
    if (count * 8 > limits_.max_decoded_bytes - decoded_)
      return Fail("node '" + owner + "': arrays hold more than the limit");
    Skip();
    if (pos_ >= s_.size() || s_[pos_] != '{')
      return Fail("node '" + owner + "': expected '{' after the array count");
    ++pos_;
    Skip();
    std::vector<double> nums;
    std::vector<int64_t> ints;
    bool integral = true;
    if (pos_ < s_.size() && s_[pos_] != '}') {
      if (s_.substr(pos_, 2) != "a:")
        return Fail("node '" + owner + "': expected 'a:' in the array");
      pos_ += 2;
      for (;;) {
        Skip();
        Prop v;
        if (pos_ >= s_.size() || !ReadValue(owner, v) || !v.IsScalarNumber())
          return Fail("node '" + owner + "': array values must be numbers");
        if (nums.size() >= count)
          return Fail("node '" + owner + "': more values than the declared " +
                      std::to_string(count));
        nums.push_back(v.AsNumber());
        if (v.kind == Prop::kInt) {
          ints.push_back(v.i);
        } else {
          integral = false;
        }
        Skip();
        if (pos_ < s_.size() && s_[pos_] == ',') {
          ++pos_;
          continue;
        }
        break;
      }
      Skip();
    }
    if (pos_ >= s_.size() || s_[pos_] != '}')
      return Fail("node '" + owner + "': expected '}' closing the array");
    ++pos_;
    if (nums.size() != count)
      return Fail("node '" + owner + "': " + std::to_string(nums.size()) + " values, declared " +
                  std::to_string(count));
    decoded_ += static_cast<size_t>(count) * 8;
    if (integral) {
      p.kind = Prop::kInts;
      p.ints = std::move(ints);
    } else {
      p.kind = Prop::kNumbers;
      p.numbers = std::move(nums);
    }
    return true;
  }

  std::string_view s_;
  const Limits& limits_;
  size_t pos_ = 0;
  size_t line_ = 1;
  size_t nodes_ = 0;
  size_t decoded_ = 0;
  std::string error_;
};

}  // namespace

const Node* Node::Find(std::string_view child) const {
  for (const Node& c : children) {
    if (c.name == child) return &c;
  }
  return nullptr;
}

const Node* Document::Find(std::string_view name) const {
  for (const Node& c : roots) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

bool LooksLikeFbx(std::span<const unsigned char> bytes) {
  if (bytes.size() >= 20 && std::memcmp(bytes.data(), kBinaryMagic, 20) == 0) return true;
  std::string_view head(reinterpret_cast<const char*>(bytes.data()),
                        std::min<size_t>(bytes.size(), 1024));
  size_t i = 0;
  while (i < head.size() && std::isspace(static_cast<unsigned char>(head[i]))) ++i;
  head.remove_prefix(i);
  return head.substr(0, 5) == "; FBX" || head.find("FBXHeaderExtension:") != std::string_view::npos;
}

Result<Document> Parse(std::span<const unsigned char> bytes, const Limits& limits) {
  Document doc;
  if (bytes.size() >= 20 && std::memcmp(bytes.data(), kBinaryMagic, 20) == 0) {
    if (bytes.size() < kHeaderSize) return InvalidArgument("FBX: truncated header");
    BinaryReader r(bytes, limits);
    if (Status s = r.Read(doc); !s.ok()) return s;
  } else {
    AsciiReader r(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                  limits);
    if (Status s = r.Read(doc); !s.ok()) return s;
    if (const Node* h = doc.Find("FBXHeaderExtension")) {
      if (const Node* v = h->Find("FBXVersion"); v && !v->props.empty())
        doc.version = static_cast<uint32_t>(v->props[0].AsInt());
    }
  }
  return doc;
}

std::string ObjectName(std::string_view raw) {
  if (const size_t sep = raw.find(std::string_view("\0\1", 2)); sep != std::string_view::npos)
    return std::string(raw.substr(0, sep));
  if (const size_t sep = raw.find("::"); sep != std::string_view::npos)
    return std::string(raw.substr(sep + 2));
  return std::string(raw);
}

}  // namespace facespace::formats::fbx
