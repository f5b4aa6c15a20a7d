// The problem table (api/http/src/http/problems.h): one entry a type, each reason the code names is
// one of them, a Status answers its reason's status, and /openapi.json lists them all.
#include "http/problems.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "facespace/formats/io.h"
#include "facespace/http/http.h"

namespace facespace::http {
namespace problems_test {  // Named: the target is a unity build, its files share one unit.

namespace fs = std::filesystem;

TEST(Problems, EachTypeOnceWithAnErrorStatusAndATitle) {
  std::set<std::string_view> names;
  for (const http::ProblemType& t : http::Problems()) {
    EXPECT_TRUE(names.insert(t.name).second) << t.name << " twice";
    EXPECT_TRUE(std::regex_match(std::string(t.name), std::regex("[a-z]+(-[a-z]+)*"))) << t.name;
    EXPECT_GE(t.status, 400) << t.name;
    EXPECT_LE(t.status, 599) << t.name;
    EXPECT_FALSE(t.title.empty()) << t.name;
  }
  EXPECT_EQ(names.size(), static_cast<size_t>(http::Problem::kCount));
}

TEST(Problems, AStatusAnswersTheStatusItsReasonNames) {
  EXPECT_EQ(
      TypeOf(http::ProblemOf(WithReason(ResourceExhausted("decoders in use"), "busy"))).status,
      503);
  EXPECT_EQ(TypeOf(http::ProblemOf(WithReason(InvalidArgument("x"), "malformed-json"))).status,
            400);
  EXPECT_EQ(TypeOf(http::ProblemOf(WithReason(FailedPrecondition("bundled"), "read-only"))).status,
            409);
  // No reason, or one that is not the table's: the code's own problem, never an undeclared type.
  EXPECT_EQ(http::ProblemOf(InvalidArgument("x")), http::Problem::kInvalidRequest);
  EXPECT_EQ(http::ProblemOf(WithReason(NotFound("x"), "no-such-reason")), http::Problem::kNotFound);
  EXPECT_EQ(http::ProblemOf(ResourceExhausted("x")), http::Problem::kTooLarge);
  EXPECT_EQ(http::ProblemOf(Status{StatusCode::kStorageFull, "full", {}, "", 0}),
            http::Problem::kStorageFull);
  // A limit passed up through an input's wrapper keeps its own problem.
  EXPECT_EQ(http::ProblemOf(WithInputReason(ResourceExhausted("x"), "invalid-weights")),
            http::Problem::kTooLarge);
  EXPECT_EQ(http::ProblemOf(WithInputReason(InvalidArgument("x"), "invalid-weights")),
            http::Problem::kInvalidWeights);
}

// The text of the call whose '(' is at `open`, to its matching ')', string and character literals
// skipped over (a message may hold parentheses and semicolons).
std::string CallText(const std::string& s, size_t open) {
  int depth = 0;
  for (size_t i = open; i < s.size(); ++i) {
    const char c = s[i];
    if (c == '"' || c == '\'') {
      for (++i; i < s.size() && s[i] != c; ++i) i += s[i] == '\\';
    } else if (c == '(') {
      ++depth;
    } else if (c == ')' && --depth == 0) {
      return s.substr(open, i - open + 1);
    }
  }
  return "";
}

// Every string literal the sources give a Status as its reason: the last argument of WithReason and
// WithInputReason, and the slugs of `.reason = ...;` statements.
std::set<std::string> ReasonsInSources() {
  std::set<std::string> found;
  const std::regex with(R"x(\bWith(?:Input)?Reason\()x"),
      last(R"x(,\s*"([a-z]+(?:-[a-z]+)*)"\s*\)$)x");
  const std::regex assign(R"x(\breason = ([^;]*);)x"), slug(R"x("([a-z]+(?:-[a-z]+)*)")x");
  for (const char* dir : {"core", "api", "service", "render"}) {
    for (const auto& entry :
         fs::recursive_directory_iterator(fs::path(FACESPACE_SOURCE_DIR) / dir)) {
      const std::string ext = entry.path().extension().string();
      if (!entry.is_regular_file() || (ext != ".cpp" && ext != ".h")) continue;
      std::ifstream in(entry.path());
      std::stringstream text;
      text << in.rdbuf();
      const std::string s = text.str();
      for (std::sregex_iterator m(s.begin(), s.end(), with), end; m != end; ++m) {
        const std::string call = CallText(s, static_cast<size_t>(m->position() + m->length() - 1));
        if (std::smatch k; std::regex_search(call, k, last)) found.insert(k[1]);
      }
      for (std::sregex_iterator m(s.begin(), s.end(), assign), end; m != end; ++m) {
        const std::string rhs = (*m)[1];
        for (std::sregex_iterator k(rhs.begin(), rhs.end(), slug); k != end; ++k)
          found.insert((*k)[1]);
      }
    }
  }
  return found;
}

TEST(Problems, EveryReasonTheSourcesNameIsDeclared) {
  const std::set<std::string> reasons = ReasonsInSources();
  EXPECT_GE(reasons.size(), 15u) << "the scan found too few reasons to be reading the sources";
  for (const std::string& r : reasons)
    EXPECT_TRUE(http::ProblemNamed(r).has_value()) << "reason '" << r << "' is not in problems.h";
}

TEST(Problems, TheDocumentListsEveryType) {
  const nlohmann::json doc = nlohmann::json::parse(OpenApiJson(http::ApiOptions{}));
  const nlohmann::json& listed = doc["x-facespace-problems"];
  const nlohmann::json& types =
      doc["components"]["schemas"]["Problem"]["properties"]["type"]["enum"];
  ASSERT_EQ(listed.size(), http::Problems().size());
  ASSERT_EQ(types.size(), http::Problems().size());
  for (size_t i = 0; i < http::Problems().size(); ++i) {
    const http::ProblemType& t = http::Problems()[i];
    EXPECT_EQ(listed[i]["type"], "urn:facespace:problem:" + std::string(t.name));
    EXPECT_EQ(listed[i]["status"], t.status);
    EXPECT_EQ(types[i], listed[i]["type"]);
  }
}

// A declaration the reader keeps and the document names: the manifest's members (formats/io.h).
TEST(Declared, TheManifestSchemaNamesTheMembersTheReaderTakes) {
  const nlohmann::json doc = nlohmann::json::parse(OpenApiJson(http::ApiOptions{}));
  const nlohmann::json& schema = doc["components"]["schemas"]["Manifest"];
  std::set<std::string> documented, read;
  for (const auto& [name, _] : schema["properties"].items()) documented.insert(name);
  for (std::string_view name : formats::ManifestMembers()) read.insert(std::string(name));
  EXPECT_EQ(documented, read);
  EXPECT_EQ(schema["additionalProperties"], false);  // As the reader refuses an unknown member.
}

}  // namespace problems_test
}  // namespace facespace::http
