// A request body's JSON object, read under its limits with every member's place known
// (json_body.h).
#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <unordered_set>
#include <vector>

#include "json_body.h"

namespace facespace::evaluator::body {

// nlohmann's DOM builder under a SAX reader that tracks where it is (for JSON Pointers), refuses a
// member given twice in any object (JSON parsers keep the last, or the first: the client's intent
// is unknown), and stops at the body's limits. Linear in the body: the callback parser this
// replaces scanned the parent again at every object's end, so 100,000 empty objects took seconds.
namespace {

class CheckedDom {
 public:
  CheckedDom(json& root, BodyLimits limits) : dom_(root, false), limits_(limits) {}

  bool null() { return Value() && dom_.null(); }
  bool boolean(bool v) { return Value() && dom_.boolean(v); }
  bool number_integer(json::number_integer_t v) { return Value() && dom_.number_integer(v); }
  bool number_unsigned(json::number_unsigned_t v) { return Value() && dom_.number_unsigned(v); }
  bool number_float(json::number_float_t v, const std::string& s) {
    return Value() && dom_.number_float(v, s);
  }
  bool string(std::string& v) { return Value() && dom_.string(v); }
  bool binary(json::binary_t& v) { return Value() && dom_.binary(v); }
  bool start_object(size_t n) { return Open(false) && dom_.start_object(n); }
  bool start_array(size_t n) { return Open(true) && dom_.start_array(n); }
  bool end_object() { return Close() && dom_.end_object(); }
  bool end_array() { return Close() && dom_.end_array(); }
  bool key(std::string& k) {
    Level& level = levels_.back();
    level.key = k;
    if (!level.keys.insert(k).second) {
      duplicate_ = Pointer();
      return false;
    }
    return dom_.key(k);
  }
  bool parse_error(size_t position, const std::string& token,
                   const nlohmann::detail::exception& e) {
    malformed_ = true;
    error_at_ = position;
    error_token_ = token;
    return dom_.parse_error(position, token, e);
  }

  bool malformed() const { return malformed_; }
  // Where the parser stopped, as "line L, column C" of `body` (1-based), and the text it stopped
  // at.
  std::string ErrorPlace(std::string_view body) const {
    const size_t at = std::min(error_at_ ? error_at_ - 1 : 0, body.size());
    size_t line = 1, column = 1;
    for (size_t i = 0; i < at; ++i) {
      if (body[i] == '\n')
        ++line, column = 1;
      else
        ++column;
    }
    std::string near = error_token_.substr(0, 20);
    for (char& c : near)
      if (static_cast<unsigned char>(c) < 0x20) c = ' ';
    return "line " + std::to_string(line) + ", column " + std::to_string(column) +
           (near.empty() ? "" : " (at '" + near + "')");
  }
  const std::string& duplicate() const { return duplicate_; }
  const std::string& over() const { return over_; }  // Which limit was passed, and where.

 private:
  struct Level {
    bool array = false;
    size_t index = 0;
    std::string key;
    std::unordered_set<std::string> keys;
  };

  std::string Pointer() const {
    std::string p;
    for (const Level& l : levels_)
      p += "/" + (l.array ? std::to_string(l.index) : JsonPointerEscape(l.key));
    return p;
  }
  bool Count() {
    if (++values_ <= limits_.values) return true;
    over_ = "more than " + std::to_string(limits_.values) +
            " JSON values (numbers, strings, arrays, objects) at " +
            (levels_.empty() ? "/" : Pointer()) + "; this route takes at most that many";
    return false;
  }
  bool Value() {  // A scalar ended: the next one of its array.
    if (!Count()) return false;
    if (!levels_.empty() && levels_.back().array) ++levels_.back().index;
    return true;
  }
  bool Open(bool array) {
    if (!Count()) return false;
    if (levels_.size() >= limits_.depth) {
      over_ = "nested deeper than " + std::to_string(limits_.depth) + " levels at " + Pointer();
      return false;
    }
    levels_.push_back({array, 0, {}, {}});
    return true;
  }
  bool Close() {
    levels_.pop_back();
    if (!levels_.empty() && levels_.back().array) ++levels_.back().index;
    return true;
  }

  nlohmann::detail::json_sax_dom_parser<json> dom_;
  BodyLimits limits_;
  std::vector<Level> levels_;
  size_t values_ = 0;
  bool malformed_ = false;
  size_t error_at_ = 0;
  std::string error_token_;
  std::string duplicate_, over_;
};

}  // namespace

// A JSON object within `limits`, named by JSON Pointers when it is not one.
Result<json> ParseObject(std::string_view body, BodyLimits limits) {
  if (body.find_first_not_of(" \t\r\n") == std::string_view::npos) {
    return WithReason(
        InvalidArgument(std::string(kMalformed) + ": the body is empty; send a JSON object"),
        kMalformedJson);
  }
  json j;
  CheckedDom sax(j, limits);
  const bool parsed = json::sax_parse(body, &sax);
  if (!sax.over().empty())
    return WithReason(ResourceExhausted("the body has " + sax.over()), "body-too-complex");
  if (!sax.duplicate().empty())
    return FieldStatus(sax.duplicate(), "is given more than once; give each member once");
  if (!parsed || sax.malformed()) {
    return WithReason(InvalidArgument(std::string(kMalformed) + ": the body is not valid JSON at " +
                                      sax.ErrorPlace(body)),
                      kMalformedJson);
  }
  if (!j.is_object())
    return FieldStatus("", std::string("the body must be a JSON object, not ") + j.type_name());
  return j;
}

}  // namespace facespace::evaluator::body
