// The connection front's framing (api/net/include/facespace/net/framing.h): where a request ends,
// what is refused.
#include "facespace/net/framing.h"

#include <gtest/gtest.h>

#include <string>

namespace facespace::net {
namespace framing_test {  // Named: the target is a unity build, its files share one unit.

struct Parsed {
  Framing f;
  net::RequestHead head;
  net::FramingError error;
};

// One call on the whole bytes.
Parsed Head(const std::string& bytes) {
  Parsed p;
  size_t scan = 0;
  p.f = ParseHead(bytes, scan, HeadLimits{}, p.head, p.error);
  return p;
}

TEST(Framing, AHeadFoundByteByByteIsTheHeadFoundAtOnce) {
  const std::string req =
      "\r\nPOST /v1/rigs/facecap/mesh?x=1 HTTP/1.1\r\nHost: x\r\nContent-Length:  12 \r\nExpect: "
      "100-Continue\r\n\r\n{\"weights\":{}}";
  std::string buf;
  size_t scan = 0;
  net::RequestHead head;
  net::FramingError error;
  Framing f = Framing::kNeedMore;
  size_t calls = 0;
  for (char c : req) {
    buf += c;
    ++calls;
    f = ParseHead(buf, scan, HeadLimits{}, head, error);
    if (f != Framing::kNeedMore) break;
  }
  ASSERT_EQ(f, Framing::kComplete);
  EXPECT_EQ(calls, req.find("\r\n\r\n") + 4);  // Complete at the blank line, not before or after.
  EXPECT_EQ(head.start, 2u);                   // The empty line before the request line is skipped.
  EXPECT_EQ(head.end, calls);
  EXPECT_EQ(head.method, "POST");
  EXPECT_EQ(head.target, "/v1/rigs/facecap/mesh?x=1");
  EXPECT_EQ(head.content_length, 12u);
  EXPECT_FALSE(head.chunked);
  EXPECT_TRUE(head.expect_continue);
  const Parsed once = Head(req);
  EXPECT_EQ(once.head.end, head.end);
  EXPECT_EQ(once.head.content_length, head.content_length);
}

TEST(Framing, RefusesWhatCppHttplibAccepted) {
  const std::string post = "POST /v1/rigs/facecap/check HTTP/1.1\r\nHost: x\r\n";
  struct Case {
    std::string bytes;
    int status;
    const char* says;
  } cases[] = {
      {post + "Transfer-Encoding: chunked\r\nContent-Length: 2\r\n\r\n", 400,
       "both Transfer-Encoding and Content-Length"},
      {post + "Content-Length: abc\r\n\r\n", 400, "Content-Length must be a number"},
      {post + "Content-Length: -5\r\n\r\n", 400, "Content-Length must be a number"},
      {post + "Content-Length: 2\r\nContent-Length: 3\r\n\r\n", 400,
       "two different Content-Length"},
      {post + "Transfer-Encoding: gzip, chunked\r\n\r\n", 501, "not supported"},
      {"GET /v1/rigs/%u0066acecap HTTP/1.1\r\n\r\n", 400, "%u escape"},
      {"GET /a b HTTP/1.1\r\n\r\n", 400, "METHOD TARGET"},
      {"GET / HTTP/2.0\r\n\r\n", 505, "HTTP/1.1"},
      {post + "X-A: 1\r\n folded\r\n\r\n", 400, "obs-fold"},
      {post + "Bad Name: 1\r\n\r\n", 400, "field name"},
      {post + "X-A: 1\nX-B: 2\r\n\r\n", 400, "bare CR or LF"},
      {post + std::string("X-A: a\0b\r\n\r\n", 12), 400, "NUL or another control character"},
      {post + "X-A: a\x01b\r\n\r\n", 400, "NUL or another control character"},
      {"GET /" + std::string(9000, 'a') + " HTTP/1.1\r\n\r\n", 414, "8,192 bytes"},
  };
  for (const Case& c : cases) {
    const Parsed p = Head(c.bytes);
    EXPECT_EQ(p.f, Framing::kError) << c.bytes.substr(0, 80);
    EXPECT_EQ(p.error.status, c.status) << c.bytes.substr(0, 80);
    EXPECT_NE(p.error.detail.find(c.says), std::string::npos) << p.error.detail;
  }
  // A request line over the limit is refused before its end arrives; so are endless headers.
  std::string endless = "GET /" + std::string(9000, 'a');
  size_t scan = 0;
  net::RequestHead head;
  net::FramingError error;
  EXPECT_EQ(ParseHead(endless, scan, HeadLimits{}, head, error), Framing::kError);
  EXPECT_EQ(error.status, 414);
  std::string headers = "GET / HTTP/1.1\r\n";
  while (headers.size() < 70000) headers += "X-Slow: aaaaaaaaaaaaaaaaaaaaaaaa\r\n";
  scan = 0;
  EXPECT_EQ(ParseHead(headers, scan, HeadLimits{}, head, error), Framing::kError);
  EXPECT_EQ(error.status, 431);
}

TEST(Framing, ChunkedBodiesEndAtTheLastChunkAndItsTrailers) {
  const std::string head = "POST /x HTTP/1.1\r\nTransfer-Encoding: Chunked\r\n\r\n";
  const Parsed p = Head(head);
  ASSERT_EQ(p.f, Framing::kComplete);
  EXPECT_TRUE(p.head.chunked);
  const std::string body = "4;ext=1\r\n{\"we\r\nA\r\nights\":{}}\r\n0\r\nX-Trailer: 1\r\n\r\n";
  const std::string next = "GET / HTTP/1.1\r\n\r\n";  // Pipelined: must not be taken as the body's.
  std::string buf = head;
  net::ChunkedState st;
  st.pos = p.head.end;
  net::FramingError error;
  Framing f = Framing::kNeedMore;
  for (char c : body + next) {
    buf += c;
    f = ParseChunked(buf, st, 1 << 20, error);
    if (f != Framing::kNeedMore) break;
  }
  ASSERT_EQ(f, Framing::kComplete) << error.detail;
  EXPECT_EQ(st.pos, head.size() + body.size());
  EXPECT_EQ(st.total, 14u);
  // Handed on whole: the same request with a Content-Length, the data joined, no trailer.
  EXPECT_EQ(Dechunked(std::string_view(buf).substr(0, st.pos), p.head),
            "POST /x HTTP/1.1\r\nContent-Length: 14\r\n\r\n{\"weights\":{}}");

  auto chunked = [&](const std::string& b, size_t max_body) {
    net::ChunkedState s;
    s.pos = head.size();
    net::FramingError e;
    const Framing r = ParseChunked(head + b, s, max_body, e);
    return std::make_pair(r, e.status);
  };
  EXPECT_EQ(chunked("2\r\n{}XX0\r\n\r\n", 100),
            std::make_pair(Framing::kError, 400));  // No CRLF after the data.
  EXPECT_EQ(chunked("zz\r\n", 100), std::make_pair(Framing::kError, 400));
  EXPECT_EQ(chunked("65\r\n", 100), std::make_pair(Framing::kError, 413));  // 101 bytes, over 100.
  EXPECT_EQ(chunked("ffffffffffffffffff\r\n", 100), std::make_pair(Framing::kError, 413));
  EXPECT_EQ(chunked("2\r\n{}", 100).first, Framing::kNeedMore);
}

}  // namespace framing_test
}  // namespace facespace::net
