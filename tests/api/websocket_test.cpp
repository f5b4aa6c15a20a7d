// RFC 6455 framing (api/net/include/facespace/net/websocket.h): the RFC's own examples, every
// prefix of a frame wanting more, and each broken frame refused with its close code before its
// payload is held.
#include "facespace/net/websocket.h"

#include <gtest/gtest.h>

#include <string>

namespace facespace::net::ws {
namespace websocket_test {

std::string Bytes(std::initializer_list<int> b) {
  std::string s;
  for (int v : b) s.push_back(static_cast<char>(v));
  return s;
}

TEST(WebSocket, AcceptKeyIsTheRfcExample) {
  EXPECT_EQ(net::ws::AcceptKey("dGhlIHNhbXBsZSBub25jZQ=="),
            "s3pPLMBiTxaQ9kYGzzhZRbK+xOo=");  // RFC 6455, 1.3.
  EXPECT_TRUE(net::ws::ValidClientKey("dGhlIHNhbXBsZSBub25jZQ=="));
  EXPECT_FALSE(net::ws::ValidClientKey("short"));
  EXPECT_FALSE(net::ws::ValidClientKey("dGhlIHNhbXBsZSBub25jZR=="));  // Bits past the 16 bytes.
  EXPECT_FALSE(net::ws::ValidClientKey("dGhlIHNhbXBsZSBub25j!Q=="));
}

TEST(WebSocket, MaskedHelloFromTheRfcAndEveryPrefixWantsMore) {
  // RFC 6455, 5.7: a masked text frame "Hello".
  const std::string whole =
      Bytes({0x81, 0x85, 0x37, 0xfa, 0x21, 0x3d, 0x7f, 0x9f, 0x4d, 0x51, 0x58});
  for (size_t n = 0; n < whole.size(); ++n) {
    std::string part = whole.substr(0, n);
    Frame f;
    net::ws::FrameError e;
    EXPECT_EQ(ParseClientFrame(part, 100, f, e), Parsed::kNeedMore) << n;
  }
  std::string buf = whole + "next";
  Frame f;
  net::ws::FrameError e;
  ASSERT_EQ(ParseClientFrame(buf, 100, f, e), Parsed::kFrame);
  EXPECT_TRUE(f.fin);
  EXPECT_EQ(f.opcode, net::ws::Opcode::kText);
  EXPECT_EQ(f.payload, "Hello");
  EXPECT_EQ(f.size, whole.size());
}

TEST(WebSocket, BrokenFramesAreRefusedWithTheirCode) {
  struct Case {
    std::string bytes;
    size_t max;
    net::ws::CloseCode code;
  };
  const Case cases[] = {
      {Bytes({0x81, 0x05, 'H', 'e', 'l', 'l', 'o'}), 100,
       net::ws::CloseCode::kProtocolError},                                        // Unmasked.
      {Bytes({0xC1, 0x80, 0, 0, 0, 0}), 100, net::ws::CloseCode::kProtocolError},  // RSV1.
      {Bytes({0x83, 0x80, 0, 0, 0, 0}), 100, net::ws::CloseCode::kProtocolError},  // Opcode 3.
      {Bytes({0x09, 0x80, 0, 0, 0, 0}), 100, net::ws::CloseCode::kProtocolError},  // A ping split.
      {Bytes({0x89, 0xFE, 0x00, 0x7E}), 1000,
       net::ws::CloseCode::kProtocolError},  // A 126-byte ping.
      {Bytes({0x81, 0xFE, 0x00, 0x05}), 1000,
       net::ws::CloseCode::kProtocolError},  // 16-bit length for 5.
      {Bytes({0x82, 0xFF, 0x80, 0, 0, 0, 0, 0, 0, 0}), 1000,
       net::ws::CloseCode::kProtocolError},  // Top bit of 64.
      {Bytes({0x82, 0xFF, 0, 0, 0, 1, 0, 0, 0, 0}), size_t{1} << 20,
       net::ws::CloseCode::kTooBig},                                         // 4 GiB declared.
      {Bytes({0x81, 0xFE, 0x10, 0x00}), 1000, net::ws::CloseCode::kTooBig},  // 4,096 over 1,000.
  };
  for (const Case& c : cases) {
    std::string buf = c.bytes;
    Frame f;
    net::ws::FrameError e;
    EXPECT_EQ(ParseClientFrame(buf, c.max, f, e), Parsed::kError)
        << testing::PrintToString(c.bytes);
    EXPECT_EQ(e.code, c.code) << e.reason;
    EXPECT_FALSE(e.reason.empty());
  }
}

TEST(WebSocket, ServerFramesAndCloses) {
  EXPECT_EQ(ServerFrame(net::ws::Opcode::kText, "Hi"), Bytes({0x81, 0x02, 'H', 'i'}));
  const std::string mid = ServerFrame(net::ws::Opcode::kBinary, std::string(300, 'x'));
  EXPECT_EQ(mid.substr(0, 4), Bytes({0x82, 0x7E, 0x01, 0x2C}));
  const std::string big = ServerFrame(net::ws::Opcode::kBinary, std::string(70000, 'x'));
  EXPECT_EQ(big.substr(0, 10), Bytes({0x82, 0x7F, 0, 0, 0, 0, 0, 0x01, 0x11, 0x70}));
  const std::string close = CloseFrame(net::ws::CloseCode::kTooBig, std::string(200, 'r'));
  EXPECT_EQ(close.substr(0, 4),
            Bytes({0x88, 125, 0x03, 0xF1}));  // 1009, the reason cut to fit 125.
  EXPECT_EQ(close.size(), 127u);
  // A reason cut within a character keeps whole characters.
  const std::string accented =
      CloseFrame(net::ws::CloseCode::kNormal, std::string(122, 'a') + "\xc3\xa9\xc3\xa9");
  EXPECT_TRUE(net::ws::ValidUtf8(accented.substr(4)));
  EXPECT_TRUE(net::ws::ValidUtf8("caf\xc3\xa9"));
  EXPECT_FALSE(net::ws::ValidUtf8("\xff\xfe"));
  EXPECT_FALSE(net::ws::ValidUtf8("\xed\xa0\x80"));  // A surrogate.
}

}  // namespace websocket_test
}  // namespace facespace::net::ws
