// Issue 61's pieces in process: the response encoder that replaced cpp-httplib's, and the live
// say's segments (a long text spoken in parts, a short one whole).
#include <gtest/gtest.h>
#include <httplib.h>
#include <zlib.h>

#include <string>

#include "http/encoded.h"
#include "routes/live_say.h"
#include "turns.h"

namespace facespace::http {
namespace bounds_test {  // Named: the target is a unity build, its files share one unit.

std::string Gunzip(const std::string& in) {
  z_stream z{};
  inflateInit2(&z, 15 + 16);
  std::string out;
  char buf[65536];
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  z.avail_in = static_cast<uInt>(in.size());
  int rc = Z_OK;
  while (rc == Z_OK) {
    z.next_out = reinterpret_cast<Bytef*>(buf);
    z.avail_out = sizeof buf;
    rc = inflate(&z, Z_NO_FLUSH);
    out.append(buf, sizeof buf - z.avail_out);
  }
  inflateEnd(&z);
  return rc == Z_STREAM_END ? out : "(not gzip)";
}

// A JSON body of about `bytes`, compressible as answers are.
std::string JsonBody(size_t bytes) {
  std::string s = "{\"values\":[";
  for (size_t i = 0; s.size() < bytes; ++i) s += std::to_string(i % 977) + ".25,";
  s.back() = ']';
  return s + "}";
}

httplib::Request Asking(const char* coding) {
  httplib::Request req;
  req.headers.emplace("Accept-Encoding", coding);
  http::HideAcceptEncoding(req);
  return req;
}

TEST(Encoding, CppHttplibNeverSeesAcceptEncodingAndOurEncoderAnswers) {
  httplib::Request req = Asking("gzip;q=1, br;q=0");
  EXPECT_FALSE(req.has_header("Accept-Encoding"));
  EXPECT_EQ(req.get_header_value(http::kAcceptEncoding), "gzip;q=1, br;q=0");
  httplib::Response res;
  const std::string body = JsonBody(600000);  // Three steps of 256 KB.
  res.set_content(body, "application/json");
  http::CompressBody(req, res, {});
  EXPECT_EQ(res.get_header_value("Content-Encoding"), "gzip");
  EXPECT_NE(res.get_header_value("Vary").find("Accept-Encoding"), std::string::npos);
  EXPECT_LT(res.body.size(), body.size() / 3);
  EXPECT_EQ(Gunzip(res.body), body);
  // A client's own header under our name is not taken for the real one.
  httplib::Request spoofed;
  spoofed.headers.emplace(http::kAcceptEncoding, "gzip");
  spoofed.headers.emplace("Accept-Encoding", "identity");
  http::HideAcceptEncoding(spoofed);
  EXPECT_EQ(spoofed.get_header_value(http::kAcceptEncoding), "identity");
}

TEST(Encoding, WhatIsNotWorthItOrTooLargeOrStoppedGoesAsItIs) {
  struct Case {
    const char* coding;
    std::string body;
    const char* type;
    bool stopped;
  } cases[] = {
      {"br", JsonBody(500), "application/json", false},  // Under kMinCompressed.
      {"br", JsonBody(http::kMaxDynamicCompressed + 1000), "application/json",
       false},                                               // Over the cap.
      {"br", std::string(100000, 'x'), "image/png", false},  // Not text-like.
      {"br", JsonBody(600000), "application/json", true},    // Its request stopped.
      {"identity", JsonBody(600000), "application/json", false},
  };
  for (const Case& c : cases) {
    httplib::Request req = Asking(c.coding);
    httplib::Response res;
    res.set_content(c.body, c.type);
    std::stop_source stop;
    if (c.stopped) stop.request_stop();
    http::CompressBody(req, res, stop.get_token());
    EXPECT_FALSE(res.has_header("Content-Encoding"))
        << c.coding << " " << c.body.size() << " " << c.type;
    EXPECT_EQ(res.body, c.body);
  }
  // br when it is asked for: smaller, and brotli's stream (not gzip's magic).
  httplib::Request req = Asking("br");
  httplib::Response res;
  res.set_content(JsonBody(600000), "application/json");
  http::CompressBody(req, res, {});
  EXPECT_EQ(res.get_header_value("Content-Encoding"), "br");
  EXPECT_LT(res.body.size(), 200000u);
  EXPECT_NE(res.body.substr(0, 2), "\x1f\x8b");
}

TEST(LiveSay, AShortTextIsOnePartAndALongOneIsCutAfterItsSentences) {
  EXPECT_EQ(http::SpeechSegments(
                "Please pass the map, Bob. We will meet at five by the old bridge.", 175),
            std::vector<std::string>{
                "Please pass the map, Bob. We will meet at five by the old bridge."});
  std::string sentences;
  for (int i = 0; i < 12; ++i) sentences += "We will meet at five by the old bridge. ";
  const std::vector<std::string> parts = http::SpeechSegments(sentences, 175);
  ASSERT_GT(parts.size(), 1u);
  std::string joined;
  for (const std::string& p : parts) {
    EXPECT_EQ(p.back(), '.') << "cut inside a sentence: " << p;
    joined += p + " ";
  }
  EXPECT_EQ(joined, sentences);  // Nothing lost or added but the spaces between.
  // Digits are read as long numbers: a part per number or two, however short the text.
  const std::vector<std::string> numbers =
      http::SpeechSegments("999999999999 999999999999 999999999999 999999999999", 80);
  EXPECT_EQ(numbers.size(), 4u);
  EXPECT_EQ(http::SpeechSegments("   ", 175).size(), 0u);
}

TEST(FairTurns, AnAddressRunningNothingAlwaysStartsAndTheFewestRunningGoesNext) {
  net::FairTurns<int> turns(8, 16);  // 8 workers: 2 kept for addresses that run nothing.
  int started_a = 0;
  for (int i = 0; i < 10; ++i) started_a += turns.Arrive("a", i);
  EXPECT_EQ(started_a, 6);              // Up to the reserve.
  EXPECT_TRUE(turns.Arrive("b", 100));  // Runs nothing: starts.
  EXPECT_TRUE(turns.Arrive("c", 200));  // So does another.
  EXPECT_TRUE(turns.Arrive(
      "d", 300));  // And another, past the workers: it queues for a worker, not a turn.
  EXPECT_FALSE(turns.Arrive("b", 101));  // b runs one now, and the reserve is gone.
  EXPECT_EQ(turns.running(), 9u);
  std::vector<int> start;
  turns.End("a", -1, start);  // Nothing may start: 8 still run.
  EXPECT_TRUE(start.empty());
  turns.End("d", -1, start);  // 7 run: still only the reserve left.
  EXPECT_TRUE(start.empty());
  turns.End("c", -1, start);
  EXPECT_TRUE(start.empty());
  turns.End("a", -1, start);  // 5 run: one may start, and b (one running) goes before a (four).
  EXPECT_EQ(start, std::vector<int>{101});
  turns.End("b", -1, start);  // Then a's next.
  EXPECT_EQ(start, (std::vector<int>{101, 6}));
  // The scarce gate: at most 2 renders hold a worker or a place in a line; the third waits at the
  // gate and goes when one of them ends, before anything else of its address.
  net::FairTurns<int> gl(64, 16, {2, 1});
  EXPECT_TRUE(gl.Arrive("r", 1, 0));
  EXPECT_TRUE(gl.Arrive("r", 2, 0));
  EXPECT_FALSE(gl.Arrive("s", 3, 0));
  EXPECT_TRUE(gl.Arrive("s", 4));     // Needs nothing scarce: starts at once.
  EXPECT_TRUE(gl.Arrive("s", 5, 1));  // Another gate: its own cap.
  EXPECT_FALSE(gl.Arrive("t", 6, 1));
  std::vector<int> next;
  gl.End("s", -1, next);
  EXPECT_TRUE(next.empty());
  gl.End("r", 0, next);
  EXPECT_EQ(next, std::vector<int>{3});
  gl.End("s", 1, next);
  EXPECT_EQ(next, (std::vector<int>{3, 6}));
  // Its own cap holds whatever is free.
  net::FairTurns<int> one(64, 2);
  EXPECT_TRUE(one.Arrive("x", 1));
  EXPECT_TRUE(one.Arrive("x", 2));
  EXPECT_FALSE(one.Arrive("x", 3));
}

}  // namespace bounds_test
}  // namespace facespace::http
