#include "facespace/net/framing.h"

#include <algorithm>
#include <cctype>

namespace facespace::net {

namespace {

bool IsTokenChar(unsigned char c) {
  // RFC 9110 tchar.
  if (c >= '0' && c <= '9') return true;
  if ((c | 0x20) >= 'a' && (c | 0x20) <= 'z') return true;
  return std::string_view("!#$%&'*+-.^_`|~").find(static_cast<char>(c)) != std::string_view::npos;
}

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

Framing Fail(FramingError& error, int status, std::string detail) {
  error.status = status;
  error.detail = std::move(detail);
  return Framing::kError;
}

// 8192 as "8,192", as the server's other messages write sizes.
std::string Thousands(size_t n) {
  std::string s = std::to_string(n);
  for (size_t i = s.size(); i > 3; i -= 3) s.insert(i - 3, ",");
  return s;
}

bool AllDigits(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

}  // namespace

bool EqualsIgnoreCase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           const auto lower = [](char c) {
             return c >= 'A' && c <= 'Z' ? static_cast<char>(c + 32) : c;
           };
           return lower(x) == lower(y);
         });
}

namespace {

// The request line (method SP request-target SP HTTP-version) into `head`.
Framing ParseRequestLine(std::string_view line, RequestHead& head, FramingError& error) {
  const size_t sp1 = line.find(' ');
  const size_t sp2 = sp1 == std::string_view::npos ? sp1 : line.find(' ', sp1 + 1);
  if (sp2 == std::string_view::npos || line.find(' ', sp2 + 1) != std::string_view::npos) {
    return Fail(error, 400, "the request line must be METHOD TARGET HTTP/1.1");
  }
  const std::string_view method = line.substr(0, sp1), target = line.substr(sp1 + 1, sp2 - sp1 - 1),
                         version = line.substr(sp2 + 1);
  if (method.empty() || !std::all_of(method.begin(), method.end(), [](char c) {
        return IsTokenChar(static_cast<unsigned char>(c));
      })) {
    return Fail(error, 400, "the request method is not a token");
  }
  if (target.empty() || std::any_of(target.begin(), target.end(), [](char c) {
        const auto u = static_cast<unsigned char>(c);
        return u <= 0x20 || u == 0x7f;
      })) {
    return Fail(error, 400, "the request target is empty or holds control characters");
  }
  for (size_t i = target.find('%'); i != std::string_view::npos; i = target.find('%', i + 1)) {
    // Percent-encoding is % and two hex digits (RFC 3986); cpp-httplib also decodes %uXXXX.
    if (i + 1 < target.size() && (target[i + 1] == 'u' || target[i + 1] == 'U')) {
      return Fail(error, 400, "the request target holds a %u escape; percent-encode bytes as %XX");
    }
  }
  if (version != "HTTP/1.1" && version != "HTTP/1.0")
    return Fail(error, 505, "this server speaks HTTP/1.1 (and 1.0)");
  head.method = std::string(method);
  head.target = std::string(target);
  return Framing::kComplete;
}

}  // namespace

Framing ParseHead(std::string_view buf, size_t& scan, const HeadLimits& limits, RequestHead& head,
                  FramingError& error) {
  // Empty lines before the request line are skipped (RFC 9112 2.2).
  size_t start = 0;
  while (start + 1 < buf.size() && buf[start] == '\r' && buf[start + 1] == '\n') start += 2;
  const size_t from = std::max(start, scan >= 3 ? scan - 3 : 0);
  const size_t blank = buf.find("\r\n\r\n", from);
  if (blank == std::string_view::npos) {
    scan = buf.size();
    const size_t first_line = buf.find("\r\n", start);
    if ((first_line == std::string_view::npos ? buf.size() : first_line) - start >
        limits.max_line) {
      return Fail(error, 414,
                  "the request line is over " + Thousands(limits.max_line) +
                      " bytes: send long weight lists as a POST body");
    }
    if (buf.size() - start > limits.max_head) {
      return Fail(error, 431,
                  "the request line and headers are over " + Thousands(limits.max_head) + " bytes");
    }
    return Framing::kNeedMore;
  }
  head = RequestHead{};
  head.start = start;
  head.end = blank + 4;
  if (head.end - start > limits.max_head) {
    return Fail(error, 431,
                "the request line and headers are over " + Thousands(limits.max_head) + " bytes");
  }

  // The request line: method SP request-target SP HTTP-version.
  const size_t line_end = buf.find("\r\n", start);
  const std::string_view line = buf.substr(start, line_end - start);
  if (line.size() > limits.max_line) {
    return Fail(error, 414,
                "the request line is over " + Thousands(limits.max_line) +
                    " bytes: send long weight lists as a POST body");
  }
  if (ParseRequestLine(line, head, error) == Framing::kError) return Framing::kError;

  // Header fields.
  bool has_length = false, has_encoding = false;
  std::string encoding;
  size_t fields = 0;
  for (size_t pos = line_end + 2; pos < blank + 2;) {
    const size_t eol = buf.find("\r\n", pos);
    const std::string_view field = buf.substr(pos, eol - pos);
    pos = eol + 2;
    if (++fields > limits.max_headers)
      return Fail(error, 431, "more than " + std::to_string(limits.max_headers) + " header fields");
    if (field.find('\n') != std::string_view::npos || field.find('\r') != std::string_view::npos) {
      return Fail(error, 400, "a header line holds a bare CR or LF");
    }
    if (field.front() == ' ' || field.front() == '\t')
      return Fail(error, 400, "folded header lines (obs-fold) are not accepted");
    const size_t colon = field.find(':');
    if (colon == std::string_view::npos || colon == 0)
      return Fail(error, 400, "a header line has no field name");
    const std::string_view name = field.substr(0, colon);
    if (!std::all_of(name.begin(), name.end(),
                     [](char c) { return IsTokenChar(static_cast<unsigned char>(c)); })) {
      return Fail(error, 400,
                  "a header field name holds a space or another character a name cannot");
    }
    const std::string_view value = Trim(field.substr(colon + 1));
    // RFC 9110 5.5: a field value holds no NUL or other control character but HTAB (a NUL cut a
    // value short in any C string that read it after us).
    if (std::any_of(value.begin(), value.end(), [](char c) {
          return (static_cast<unsigned char>(c) < 0x20 && c != '\t') || c == 0x7f;
        })) {
      return Fail(error, 400,
                  "the value of header field '" + std::string(name.substr(0, 40)) +
                      "' holds a NUL or another control character");
    }
    if (EqualsIgnoreCase(name, "Content-Length")) {
      if (!AllDigits(value) || value.size() > 19)
        return Fail(error, 400, "Content-Length must be a number of bytes");
      const size_t n = std::stoull(std::string(value));
      if (has_length && n != head.content_length)
        return Fail(error, 400, "two different Content-Length fields");
      head.content_length = n;
      has_length = true;
    } else if (EqualsIgnoreCase(name, "Transfer-Encoding")) {
      encoding += (has_encoding ? "," : "") + std::string(value);
      has_encoding = true;
    } else if (EqualsIgnoreCase(name, "Expect")) {
      if (EqualsIgnoreCase(value, "100-continue")) head.expect_continue = true;
    }
  }
  if (has_encoding) {
    // RFC 9112 6.1 and 6.3: a message with both is an attack (request smuggling) or a broken
    // client.
    if (has_length)
      return Fail(error, 400,
                  "a request with both Transfer-Encoding and Content-Length is refused");
    if (!EqualsIgnoreCase(Trim(encoding), "chunked")) {
      return Fail(error, 501,
                  "Transfer-Encoding '" + encoding.substr(0, 40) +
                      "' is not supported: send chunked, or a Content-Length");
    }
    head.chunked = true;
  }
  return Framing::kComplete;
}

namespace {

// The end (its CRLF) of the line of a chunked body that starts at `pos`; kNeedMore while it has not
// all come, a refusal with `status` once it is over `max` bytes (4 KB).
Framing LineEnd(std::string_view buf, size_t pos, size_t max, int status, const char* what,
                FramingError& error, size_t& eol) {
  eol = buf.find("\r\n", pos);
  if (eol != std::string_view::npos) return Framing::kComplete;
  if (buf.size() - pos > max) return Fail(error, status, std::string(what) + " is over 4 KB");
  return Framing::kNeedMore;
}

}  // namespace

Framing ParseChunked(std::string_view buf, ChunkedState& s, size_t max_body, FramingError& error) {
  constexpr size_t kMaxLine = 4096;  // A chunk-size line with its extensions, or a trailer field.
  using Step = ChunkedState::Step;
  while (true) {
    switch (s.step) {
      case Step::kSize: {
        size_t eol = 0;
        if (Framing f = LineEnd(buf, s.pos, kMaxLine, 400, "a chunk-size line", error, eol);
            f != Framing::kComplete)
          return f;
        const std::string_view line = buf.substr(s.pos, eol - s.pos);
        size_t digits = 0, size = 0;
        while (digits < line.size() && std::isxdigit(static_cast<unsigned char>(line[digits]))) {
          if (digits == 15)
            return Fail(error, 413, "a chunk is larger than any body this server takes");
          const char c = line[digits++];
          size = size * 16 + static_cast<size_t>(c <= '9' ? c - '0' : (c | 0x20) - 'a' + 10);
        }
        const std::string_view rest = Trim(line.substr(digits));
        if (digits == 0 || (!rest.empty() && rest.front() != ';') ||
            line.find('\n') != std::string_view::npos) {
          return Fail(error, 400, "a chunk must start with its size in hexadecimal and CRLF");
        }
        s.pos = eol + 2;
        if (size == 0) {
          s.step = Step::kTrailer;
          break;
        }
        s.total += size;
        if (s.total > max_body) {
          return Fail(error, 413,
                      "the chunked body is over the server's limit of " + std::to_string(max_body) +
                          " bytes (--max-body)");
        }
        s.remaining = size;
        s.step = Step::kData;
        break;
      }
      case Step::kData: {
        const size_t take = std::min(buf.size() - s.pos, s.remaining);
        s.pos += take;
        s.remaining -= take;
        if (s.remaining > 0) return Framing::kNeedMore;
        s.step = Step::kDataEnd;
        break;
      }
      case Step::kDataEnd:
        if (buf.size() - s.pos < 2) return Framing::kNeedMore;
        if (buf[s.pos] != '\r' || buf[s.pos + 1] != '\n')
          return Fail(error, 400, "a chunk's data must end with CRLF");
        s.pos += 2;
        s.step = Step::kSize;
        break;
      case Step::kTrailer: {
        size_t eol = 0;
        if (Framing f = LineEnd(buf, s.pos, kMaxLine, 431, "a trailer field", error, eol);
            f != Framing::kComplete)
          return f;
        const bool last = eol == s.pos;
        s.pos = eol + 2;
        if (last) return Framing::kComplete;
        break;
      }
    }
  }
}

std::string Dechunked(std::string_view request, const RequestHead& head) {
  std::string body;
  for (size_t pos = head.end;;) {  // The chunks are known good: their sizes, data and CRLFs.
    const size_t eol = request.find("\r\n", pos);
    const size_t size = std::stoull(std::string(request.substr(pos, eol - pos)), nullptr, 16);
    if (size == 0) break;
    body.append(request.substr(eol + 2, size));
    pos = eol + 2 + size + 2;
  }
  const size_t line_end = request.find("\r\n", head.start);
  std::string out(request.substr(head.start, line_end + 2 - head.start));
  for (size_t pos = line_end + 2; pos < head.end - 2;) {
    const size_t eol = request.find("\r\n", pos);
    const std::string_view field = request.substr(pos, eol + 2 - pos);
    const size_t colon = field.find(':');
    if (!EqualsIgnoreCase(field.substr(0, colon), "Transfer-Encoding")) out += field;
    pos = eol + 2;
  }
  out += "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n";
  out += body;
  return out;
}

}  // namespace facespace::net
