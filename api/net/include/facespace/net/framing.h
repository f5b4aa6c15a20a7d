// Where one HTTP/1.1 request ends in the bytes a client sent (RFC 9112): its head, then a body by
// Content-Length or by chunks. Pure functions over the bytes received so far, so the connection
// front can call them again as more arrive; each keeps its position, so a client sending one byte
// at a time costs linear time. Strict where cpp-httplib 0.11.4 is lax: a chunk without its CRLF,
// Transfer-Encoding beside Content-Length, a Content-Length that is not digits, "%u" escapes.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace facespace::net {

enum class Framing { kNeedMore, kComplete, kError };

struct FramingError {
  int status = 400;
  std::string detail;
};

struct RequestHead {
  size_t start = 0;  // Where the request line starts (empty lines before it are skipped).
  size_t end = 0;    // Just past the blank line that ends the head.
  std::string method;
  std::string target;  // As sent: path and query, not decoded.
  bool chunked = false;
  size_t content_length = 0;
  bool expect_continue = false;
  bool has_body() const { return chunked || content_length > 0; }
};

struct HeadLimits {
  size_t max_head = 64 * 1024;  // Request line and headers together.
  size_t max_line = 8192;       // The request line (longer: 414).
  size_t max_headers = 100;
};

// Looks for a whole head in `buf`; `scan` is where the previous call stopped looking (start at 0).
Framing ParseHead(std::string_view buf, size_t& scan, const HeadLimits& limits, RequestHead& head,
                  FramingError& error);

// A chunked body from buf[pos...]: call again with the same state as bytes arrive.
struct ChunkedState {
  enum class Step { kSize, kData, kDataEnd, kTrailer } step = Step::kSize;
  size_t pos = 0;        // Next byte to read, in the connection's buffer.
  size_t remaining = 0;  // Of the current chunk's data.
  size_t total = 0;      // Data bytes so far.
};
Framing ParseChunked(std::string_view buf, ChunkedState& state, size_t max_body,
                     FramingError& error);

// A whole chunked request (`request` up to the end ParseChunked found) as the same request with
// its body whole: Transfer-Encoding dropped, Content-Length added, the chunks' data joined and the
// trailer fields dropped (cpp-httplib 0.11.4 reads no trailer, and is lax about chunks).
std::string Dechunked(std::string_view request, const RequestHead& head);

// Case-insensitive ASCII comparison, for header names and tokens.
bool EqualsIgnoreCase(std::string_view a, std::string_view b);

}  // namespace facespace::net
