// The wire formats of face tracking apps (facespace/net/mocap.h): OSC as VMC sends it, byte for
// byte as the OSC 1.0 specification's examples lay it out, and iFacialMocap's text as the iPhone
// app sends it; hostile packets refused at the byte they stop making sense.
#include "facespace/net/mocap.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace facespace::net {
namespace {

struct Got {
  std::string address;
  std::string tags;
  std::vector<OscArgument> args;
  std::vector<std::string> strings;  // Owned copies of the string arguments.
};

Status Read(std::string_view packet, std::vector<Got>& got) {
  return ReadOsc(packet, [&](const OscMessage& m) {
    Got g;
    g.address = std::string(m.address);
    for (const OscArgument& a : m.arguments) {
      g.tags += a.tag;
      g.args.push_back(a);
      g.strings.emplace_back(a.s);
    }
    got.push_back(std::move(g));
  });
}

TEST(Osc, WritesVmcBlendAsTheSpecLaysItOut) {
  std::string m;
  AppendOscMessage(m, "/VMC/Ext/Blend/Val", "A", 0.5f);
  // "/VMC/Ext/Blend/Val" is 18 bytes: padded to 20; ",sf" to 4; "A" to 4; 0.5f big-endian.
  const std::string want = std::string("/VMC/Ext/Blend/Val\0\0", 20) + std::string(",sf\0", 4) +
                           std::string("A\0\0\0", 4) + std::string("\x3f\x00\x00\x00", 4);
  EXPECT_EQ(m, want);
  std::string apply;
  AppendOscMessage(apply, "/VMC/Ext/Blend/Apply");
  EXPECT_EQ(apply, std::string("/VMC/Ext/Blend/Apply\0\0\0\0", 24) + std::string(",\0\0\0", 4));
}

TEST(Osc, ReadsWhatItWritesInBundles) {
  std::string a, b, inner, outer;
  AppendOscMessage(a, "/VMC/Ext/Blend/Val", "jawOpen", 0.75f);
  AppendOscMessage(b, "/VMC/Ext/Blend/Apply");
  BeginOscBundle(inner);
  AppendOscElement(inner, b);
  BeginOscBundle(outer);
  AppendOscElement(outer, a);
  AppendOscElement(outer, inner);
  std::vector<Got> got;
  ASSERT_TRUE(Read(outer, got).ok());
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].address, "/VMC/Ext/Blend/Val");
  EXPECT_EQ(got[0].tags, "sf");
  EXPECT_EQ(got[0].strings[0], "jawOpen");
  EXPECT_FLOAT_EQ(got[0].args[1].f, 0.75f);
  EXPECT_EQ(got[1].address, "/VMC/Ext/Blend/Apply");
  EXPECT_TRUE(got[1].tags.empty());
}

TEST(Osc, ReadsEveryTagItKnows) {
  // The spec's example message "/foo" ,iisff 1000 -1 "hello" 1.234 5.678, plus a blob, T, N, h, d.
  std::string m = std::string("/foo\0\0\0\0", 8) + std::string(",iisffbTNhd\0", 12);
  m += std::string("\x00\x00\x03\xe8", 4) + std::string("\xff\xff\xff\xff", 4);
  m += std::string("hello\0\0\0", 8);
  m += std::string("\x3f\x9d\xf3\xb6", 4) + std::string("\x40\xb5\xb2\x2d", 4);
  m += std::string("\x00\x00\x00\x03", 4) + std::string("xyz\0", 4);  // A 3-byte blob, padded.
  m += std::string("\x00\x00\x00\x01\x00\x00\x00\x02", 8);            // h: 2^32 + 2.
  m += std::string("\x3f\xf0\x00\x00\x00\x00\x00\x00", 8);            // d: 1.0.
  std::vector<Got> got;
  ASSERT_TRUE(Read(m, got).ok()) << Read(m, got).message;
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].tags, "iisffbTNhd");
  EXPECT_EQ(got[0].args[0].i, 1000);
  EXPECT_EQ(got[0].args[1].i, -1);
  EXPECT_EQ(got[0].strings[2], "hello");
  EXPECT_NEAR(got[0].args[3].f, 1.234f, 1e-6);
  EXPECT_NEAR(got[0].args[4].f, 5.678f, 1e-6);
  EXPECT_EQ(got[0].strings[5], "xyz");
  EXPECT_EQ(got[0].args[6].i, 1);
  EXPECT_EQ(got[0].args[8].i64, (int64_t{1} << 32) + 2);
  EXPECT_DOUBLE_EQ(got[0].args[9].d, 1.0);
}

TEST(Osc, RefusesHostilePacketsAtTheirByte) {
  std::string good;
  AppendOscMessage(good, "/VMC/Ext/Blend/Val", "A", 0.5f);
  std::vector<Got> got;
  // Cut anywhere: refused, never read past the end (ASan would see it).
  for (size_t n = 0; n < good.size(); ++n) {
    got.clear();
    EXPECT_FALSE(Read(good.substr(0, n), got).ok()) << n;
    EXPECT_TRUE(got.empty());
  }
  // A string without its NUL; a tag of unknown size; no type tags; too many arguments.
  EXPECT_FALSE(Read(std::string("/abc", 4), got).ok());
  EXPECT_FALSE(Read(std::string("/a\0\0,q\0\0", 8), got).ok());
  EXPECT_FALSE(Read(std::string("/a\0\0\0\0\0\0", 8), got).ok());
  const std::string many =
      std::string("/a\0\0", 4) + "," + std::string(20, 'N') + std::string(3, '\0');
  const Status s = Read(many, got);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message.find("more than 16 arguments"), std::string::npos) << s.message;
  // A bundle's element larger than the bundle, of size 0, or nested past the depth.
  std::string bundle;
  BeginOscBundle(bundle);
  EXPECT_TRUE(Read(bundle, got).ok());  // An empty bundle is a bundle.
  std::string lying = bundle + std::string("\x00\x00\x10\x00", 4) + good;
  EXPECT_NE(Read(lying, got).message.find("byte 16"), std::string::npos);
  EXPECT_FALSE(Read(bundle + std::string(4, '\0'), got).ok());
  std::string deep = good;
  for (int d = 0; d < 6; ++d) {
    std::string b;
    BeginOscBundle(b);
    AppendOscElement(b, deep);
    deep = b;
  }
  got.clear();
  EXPECT_NE(Read(deep, got).message.find("nest"), std::string::npos);
  EXPECT_TRUE(got.empty());
  // A blob whose length passes the packet.
  const std::string blob = std::string("/a\0\0,b\0\0", 8) + std::string("\x7f\xff\xff\xff", 4);
  EXPECT_FALSE(Read(blob, got).ok());
}

TEST(IFacialMocap, ReadsTheAppsLine) {
  std::vector<std::pair<std::string, float>> blends;
  std::vector<std::pair<std::string, std::vector<float>>> poses;
  const Status s = ReadIFacialMocap(
      "mouthSmile_R-35|eyeBlink_L-100|jawOpen&12.5|hapihapi-0|=head#-21.48,-6.03,-6.6,-0.03,-0.1,"
      "-0.65|rightEye#6.02,2.44,0.25|leftEye#6.03,-1.66,-0.17|",
      [&](std::string_view n, float v) { blends.emplace_back(n, v); },
      [&](std::string_view n, std::span<const float> v) {
        poses.emplace_back(n, std::vector<float>(v.begin(), v.end()));
      });
  ASSERT_TRUE(s.ok()) << s.message;
  ASSERT_EQ(blends.size(), 4u);
  EXPECT_EQ(blends[0].first, "mouthSmile_R");
  EXPECT_FLOAT_EQ(blends[0].second, 35);
  EXPECT_EQ(blends[1].first, "eyeBlink_L");
  EXPECT_FLOAT_EQ(blends[1].second, 100);
  EXPECT_FLOAT_EQ(blends[2].second, 12.5f);  // iFacialMocap 2's '&'.
  ASSERT_EQ(poses.size(), 3u);
  EXPECT_EQ(poses[0].first, "head");
  ASSERT_EQ(poses[0].second.size(), 6u);
  EXPECT_FLOAT_EQ(poses[0].second[0], -21.48f);
  EXPECT_FLOAT_EQ(poses[0].second[5], -0.65f);
  EXPECT_EQ(poses[2].first, "leftEye");
}

TEST(IFacialMocap, RefusesWhatIsNotALine) {
  auto read = [](std::string_view text) {
    size_t n = 0;
    const Status s = ReadIFacialMocap(
        text, [&](std::string_view, float) { ++n; }, [&](std::string_view, auto) { ++n; });
    return std::make_pair(s, n);
  };
  EXPECT_TRUE(read("").first.ok());
  EXPECT_FALSE(read("jawOpen").first.ok());
  EXPECT_FALSE(read("jawOpen-").first.ok());
  EXPECT_FALSE(read("jawOpen-nan").first.ok());
  EXPECT_FALSE(read("jawOpen-1e99").first.ok());  // Not finite as a float.
  EXPECT_FALSE(read("-5").first.ok());
  EXPECT_FALSE(read("=head#1,2,3,4,5,6,7").first.ok());
  EXPECT_FALSE(read(std::string(65, 'a') + "-1").first.ok());
  const auto [s, n] = read("jawOpen-10|eyeBlink_L-x|mouthClose-3");
  EXPECT_NE(s.message.find("item 2"), std::string::npos) << s.message;
  EXPECT_EQ(n, 1u);  // What came before the bad item.
}

}  // namespace
}  // namespace facespace::net
