#include "negotiate.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>

#include "facespace/engine/weights.h"
#include "problem.h"

namespace facespace::http {

namespace {

std::string_view TrimSpaces(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// The value of the most preferred type in `accept` that `produced` lists; `fallback` for no Accept
// header; nullopt when it names only types we cannot produce.
template <typename T>
std::optional<T> PickFromAccept(const std::string& accept,
                                const std::vector<std::pair<std::string_view, T>>& produced,
                                T fallback) {
  if (accept.empty()) return fallback;
  for (const std::string& type : AcceptedTypes(accept)) {
    for (const auto& [name, value] : produced) {
      if (type == name) return value;
    }
  }
  return std::nullopt;
}

template <typename T>
std::optional<T> Negotiate(const httplib::Request& req, httplib::Response& res,
                           std::optional<T> given,
                           const std::vector<std::pair<std::string_view, T>>& produced, T fallback,
                           const char* available) {
  if (given) return given;
  const std::string accept = req.get_header_value("Accept");
  if (auto picked = PickFromAccept(accept, produced, fallback)) return picked;
  SendProblem(req, res, Problem::kNotAcceptable,
              "cannot produce " + accept.substr(0, 100) + "; available: " + available);
  return std::nullopt;
}

// sf-string (RFC 9651): printable ASCII, with \ and " escaped; other bytes become '?'.
std::string SfString(const std::string& s) {
  std::string out = "\"";
  for (unsigned char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20 || c > 0x7e) {
      out += '?';
    } else {
      out += static_cast<char>(c);
    }
  }
  return out + "\"";
}

// sf-decimal: at most 12 integer and 3 fractional digits.
std::string SfDecimal(double v) {
  if (!std::isfinite(v)) v = 0;
  v = std::max(-999999999999.0, std::min(999999999999.0, v));
  char buf[40];  // "%.3f" by std::to_chars (the same digits, without printf's parsing).
  std::string s(buf, std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed, 3).ptr);
  while (s.size() > 1 && s.back() == '0' && s[s.size() - 2] != '.') s.pop_back();
  return s;
}

}  // namespace

std::string MediaType(std::string_view header) {
  std::string t(TrimSpaces(header.substr(0, header.find(';'))));
  for (char& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return t;
}

std::vector<std::string> AcceptedTypes(std::string_view accept) {
  struct Item {
    std::string type;
    double q;
  };
  std::vector<Item> items;
  size_t start = 0;
  while (start <= accept.size()) {
    size_t end = accept.find(',', start);
    if (end == std::string_view::npos) end = accept.size();
    const std::string_view item = accept.substr(start, end - start);
    start = end + 1;
    std::string type = MediaType(item);
    size_t semi = item.find(';');
    double q = 1;
    while (semi != std::string_view::npos) {
      const size_t next = item.find(';', semi + 1);
      const std::string_view param = TrimSpaces(
          item.substr(semi + 1, next == std::string_view::npos ? next : next - semi - 1));
      if (param.size() > 2 && (param[0] == 'q' || param[0] == 'Q') && param[1] == '=') {
        double v = 1;
        const auto r = std::from_chars(param.data() + 2, param.data() + param.size(), v);
        q = r.ec == std::errc() ? v : 1;
      }
      semi = next;
    }
    if (!type.empty() && q > 0) items.push_back({std::move(type), q});
  }
  std::stable_sort(items.begin(), items.end(),
                   [](const Item& a, const Item& b) { return a.q > b.q; });
  std::vector<std::string> types;
  types.reserve(items.size());
  for (Item& i : items) types.push_back(std::move(i.type));
  return types;
}

namespace {

// What Accept may name for each value of a format enum: its media type (from the enum's one table),
// then the ranges that pick the default.
template <typename T, size_t N, size_t W>
std::vector<std::pair<std::string_view, T>> Produced(
    const T (&values)[N], const char* (*media_type)(T),
    const std::pair<std::string_view, T> (&ranges)[W]) {
  std::vector<std::pair<std::string_view, T>> out;
  for (T v : values) out.emplace_back(media_type(v), v);
  out.insert(out.end(), std::begin(ranges), std::end(ranges));
  return out;
}

template <typename T, size_t N>
std::string Available(const T (&values)[N], const char* (*media_type)(T)) {
  std::string s;
  for (T v : values) s += std::string(s.empty() ? "" : ", ") + media_type(v);
  return s;
}

}  // namespace

std::optional<formats::MeshFormat> NegotiateMesh(const httplib::Request& req,
                                                 httplib::Response& res,
                                                 std::optional<formats::MeshFormat> given) {
  static constexpr formats::MeshFormat kFormats[] = {
      formats::MeshFormat::kGlb, formats::MeshFormat::kObj, formats::MeshFormat::kJson,
      formats::MeshFormat::kF32};
  static constexpr std::pair<std::string_view, formats::MeshFormat> kRanges[] = {
      {"*/*", formats::MeshFormat::kJson},
      {"model/*", formats::MeshFormat::kJson},
      {"application/*", formats::MeshFormat::kJson}};
  static const auto produced = Produced(kFormats, formats::MeshFormatMimeType, kRanges);
  static const std::string available = Available(kFormats, formats::MeshFormatMimeType);
  return Negotiate(req, res, given, produced, formats::MeshFormat::kJson, available.c_str());
}

std::optional<picture::ImageFormat> NegotiateImage(const httplib::Request& req,
                                                   httplib::Response& res,
                                                   std::optional<picture::ImageFormat> given) {
  using picture::ImageFormat;
  static constexpr ImageFormat kFormats[] = {ImageFormat::kPng, ImageFormat::kJpeg,
                                             ImageFormat::kExr, ImageFormat::kTiff,
                                             ImageFormat::kWebp};
  static constexpr std::pair<std::string_view, ImageFormat> kRanges[] = {
      {"image/*", ImageFormat::kPng},
      {"*/*", ImageFormat::kPng},
      {"image/aces", ImageFormat::kExr}};
  static const auto produced = Produced(kFormats, picture::ImageFormatMimeType, kRanges);
  static const std::string available = Available(kFormats, picture::ImageFormatMimeType);
  return Negotiate(req, res, given, produced, ImageFormat::kPng, available.c_str());
}

bool AcceptsJsonBody(const httplib::Request& req, httplib::Response& res) {
  const std::string ct = MediaType(req.get_header_value("Content-Type"));
  if (ct.empty() || ct == "application/json") return true;
  SendProblem(req, res, Problem::kUnsupportedMediaType,
              "the body must be application/json, not " + ct);
  return false;
}

std::string WarningsHeader(std::span<const Warning> warnings) {
  // Each code and shape once (a sequence's frames repeat theirs: the body lists every one), and at
  // most kMaxWarningsHeader bytes, then "more;count=N": clients and proxies cap a header's size.
  constexpr size_t kMaxWarningsHeader = 4096;
  std::string h;
  std::vector<std::pair<std::string_view, std::string_view>> said;
  size_t more = 0;
  for (const Warning& w : warnings) {
    if (std::find(said.begin(), said.end(),
                  std::pair<std::string_view, std::string_view>(w.code, w.shape)) != said.end())
      continue;
    std::string item = w.code;
    if (!w.shape.empty()) item += ";shape=" + SfString(w.shape);
    if (w.has_value) item += ";value=" + SfDecimal(w.value);
    if (h.size() + item.size() + 2 > kMaxWarningsHeader) {
      ++more;
      continue;
    }
    said.emplace_back(w.code, w.shape);
    if (!h.empty()) h += ", ";
    h += item;
  }
  if (more > 0) h += ", more;count=" + std::to_string(more);
  return h;
}

void SetWeightHeaders(httplib::Response& res, double sum, std::span<const Warning> warnings) {
  res.set_header("Facespace-Weight-Sum", FormatNumber(sum));
  if (!warnings.empty()) res.set_header("Facespace-Warnings", WarningsHeader(warnings));
}

}  // namespace facespace::http
