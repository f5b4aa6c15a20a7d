// The maker processes of a batch (api/batch/src/maker.h): their messages read back whole or
// refused, a forked maker's answers, its errors, and its death said as such.
#include "maker.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

namespace facespace::batch {
namespace {

MadeVariant Example() {
  MadeVariant m;
  m.head = "{\"index\":3";
  m.tail = ",\"bytes\":5}";
  m.codes = {"extrapolation", "out_of_range"};
  m.sum = 1.25;
  m.tar = "tar bytes";
  return m;
}

TEST(MakerMessage, RoundTrips) {
  MadeVariant m = Example();
  const std::string files[2] = {"png bytes", std::string("\0exr\xff", 5)};
  m.files = {{"v3.png", {"png ", "bytes"}},
             {"v3.depth.exr", {files[1], {}}}};  // A file in two pieces arrives as one.
  const std::string message = EncodeMade(Status::Ok(), m);
  MadeVariant back;
  ASSERT_TRUE(DecodeMade(message, back).ok());
  EXPECT_EQ(back.head, m.head);
  EXPECT_EQ(back.tail, m.tail);
  EXPECT_EQ(back.codes, m.codes);
  EXPECT_DOUBLE_EQ(back.sum, 1.25);
  EXPECT_EQ(back.tar, "tar bytes");
  ASSERT_EQ(back.files.size(), 2u);
  EXPECT_EQ(back.files[0].second[0], files[0]);
  EXPECT_EQ(back.files[1].first, "v3.depth.exr");
  EXPECT_EQ(back.files[1].second[0], files[1]);
}

TEST(MakerMessage, CarriesTheMakersError) {
  MadeVariant back;
  const Status s = DecodeMade(
      EncodeMade(WithReason(InvalidArgument("v3: bad weight"), "invalid-weights"), {}), back);
  EXPECT_EQ(s.code, StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message, "v3: bad weight");
  EXPECT_EQ(s.reason, "invalid-weights");
}

TEST(MakerMessage, EveryTruncationAndABadCodeAreRefused) {
  MadeVariant m = Example();
  m.files = {{"v3.png", {"png", {}}}};
  const std::string message = EncodeMade(Status::Ok(), m);
  MadeVariant back;
  for (size_t n = 0; n < message.size(); ++n) {
    EXPECT_FALSE(DecodeMade(std::string_view(message).substr(0, n), back).ok()) << n;
  }
  std::string bad = message;
  bad[0] = 99;
  EXPECT_FALSE(DecodeMade(bad, back).ok());
  std::string huge = message;
  for (int i = 8; i < 16; ++i)
    huge[static_cast<size_t>(i)] = '\xff';  // The first piece's length: past the end.
  EXPECT_FALSE(DecodeMade(huge, back).ok());
}

TEST(MakerProcess, AnswersFromItsOwnProcessThenItsDeathIsSaid) {
  auto maker = MakerProcess::Start([](size_t k, MadeVariant& out) {
    if (k == 7) return InvalidArgument("no seventh");
    out.head = "k=" + std::to_string(k) + " pid=" + std::to_string(getpid());
    return Status::Ok();
  });
  ASSERT_TRUE(maker.ok());
  MadeVariant got;
  ASSERT_TRUE(maker.value()->Ask(5, got).ok());
  EXPECT_EQ(got.head.rfind("k=5 pid=", 0), 0u);
  EXPECT_NE(got.head, "k=5 pid=" + std::to_string(getpid()));  // Made in the child.
  EXPECT_EQ(maker.value()->Ask(7, got).code, StatusCode::kInvalidArgument);
  ASSERT_TRUE(maker.value()->Ask(1, got).ok());
  const pid_t pid = std::stoi(got.head.substr(got.head.find("pid=") + 4));
  ASSERT_EQ(kill(pid, SIGKILL), 0);
  const Status dead = maker.value()->Ask(2, got);
  EXPECT_EQ(dead.code, StatusCode::kInternal);
  EXPECT_NE(dead.message.find("ended by signal 9"), std::string::npos) << dead.message;
  EXPECT_FALSE(maker.value()->Ask(3, got).ok());
}

}  // namespace
}  // namespace facespace::batch
