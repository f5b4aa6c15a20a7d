// The flag parser every command shares (service/commands/flags.h): both spellings of a value,
// switches, positional arguments in order, and usage errors with exit 2.
#include "commands/flags.h"

#include <gtest/gtest.h>

namespace {

using facespace::cli::Flags;

struct Parsed {
  std::string output, mode;
  long long count = 0;
  bool keep = false;
  std::vector<std::string> positional;
};

// A command's flags as the CLI declares them: -o/--output (text), --count (an integer in [1, 10]),
// --mode (text), --keep (a switch).
int Parse(const std::vector<std::string>& args, Parsed& p) {
  Flags flags("usage: facespace demo RIG -o OUT", "A command for the tests.");
  flags.Text("-o, --output", "OUT", "where to write", &p.output)
      .Value("--count", "N", "how many",
             [&p](const std::string& v) {
               return facespace::cli::IntIn("--count", v, 1, 10, &p.count) ? 0 : 2;
             })
      .Text("--mode", "MODE", "relative or absolute", &p.mode)
      .Switch("--keep", "keep the targets", [&p] { p.keep = true; });
  return flags.Parse(args, p.positional);
}

TEST(Flags, ValuesInBothSpellingsSwitchesAndPositionalsInOrder) {
  Parsed p;
  EXPECT_EQ(
      Parse({"rig.glb", "--output", "out.obj", "--count=7", "--keep", "more", "-o", "last.obj"}, p),
      -1);
  EXPECT_EQ(p.output, "last.obj");  // The last one given wins.
  EXPECT_EQ(p.count, 7);
  EXPECT_TRUE(p.keep);
  EXPECT_EQ(p.positional, (std::vector<std::string>{"rig.glb", "more"}));
}

TEST(Flags, AValueMayContainEqualsSignsAndStartWithADash) {
  Parsed p;
  EXPECT_EQ(Parse({"--mode=a=b", "--output", "-"}, p), -1);
  EXPECT_EQ(p.mode, "a=b");
  EXPECT_EQ(p.output, "-");
}

TEST(Flags, UsageErrorsExitTwo) {
  Parsed p;
  testing::internal::CaptureStderr();
  EXPECT_EQ(Parse({"--bogus"}, p), 2);
  EXPECT_EQ(Parse({"--output"}, p), 2);       // A value is missing.
  EXPECT_EQ(Parse({"--keep=yes"}, p), 2);     // A switch takes none.
  EXPECT_EQ(Parse({"--count", "11"}, p), 2);  // Out of its range.
  EXPECT_EQ(Parse({"--count", "3x"}, p), 2);  // Not a number.
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("unknown option '--bogus'"), std::string::npos) << err;
  EXPECT_NE(err.find("--output needs a value (OUT)"), std::string::npos) << err;
  EXPECT_NE(err.find("--keep takes no value"), std::string::npos) << err;
  EXPECT_NE(err.find("usage: facespace demo RIG -o OUT"), std::string::npos) << err;
}

TEST(Flags, HelpListsEveryFlagAndExitsZero) {
  Parsed p;
  testing::internal::CaptureStdout();
  EXPECT_EQ(Parse({"rig.glb", "--help"}, p), 0);
  const std::string out = testing::internal::GetCapturedStdout();
  for (const char* want : {"usage: facespace demo RIG -o OUT", "-o, --output OUT", "--count N",
                           "--keep", "A command for the tests."}) {
    EXPECT_NE(out.find(want), std::string::npos) << want << " in:\n" << out;
  }
}

}  // namespace
