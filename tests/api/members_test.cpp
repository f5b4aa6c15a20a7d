// The request bodies' member tables (evaluator/members.h): each body's reader takes every member
// its table declares and no other, the document's request schemas are the tables, and no reader
// spells a member name the tables do not declare.
#include "facespace/evaluator/members.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "facespace/evaluator/answers.h"
#include "facespace/evaluator/request.h"
#include "facespace/http/http.h"

namespace facespace::evaluator {
namespace members_test {  // Named: the target is a unity build, its files share one unit.

namespace fs = std::filesystem;
using nlohmann::json;

// A value of the member's declared kind: its example, else its default, else one in range.
json ValueOf(const evaluator::Member& m) {
  if (!m.example.empty()) return json::parse(m.example);
  if (!m.fallback.empty()) return json::parse(m.fallback);
  switch (m.kind) {
    case Kind::kNumber: return std::isfinite(m.lo) ? m.lo : std::isfinite(m.hi) ? m.hi : 1.0;
    case Kind::kInteger: return static_cast<long long>(std::isfinite(m.lo) ? m.lo : 1);
    case Kind::kBoolean: return true;
    case Kind::kString: return "x";
    case Kind::kChoice: return std::string(m.choices.substr(0, m.choices.find('|')));
    case Kind::kSchema: return json::object();
  }
  return nullptr;
}

// The reader of each top-level body, its errors as the Status of its parse.
Status Read(evaluator::Body body, const std::string& text) {
  switch (body) {
    case evaluator::Body::kMesh: return evaluator::ParseMeshRequest(text).status();
    case evaluator::Body::kRender: return evaluator::ParseRenderRequest(text).status();
    case evaluator::Body::kSheet: return evaluator::ParseSheetRequest(text).status();
    case evaluator::Body::kSequence: return evaluator::ParseSequenceRequest(text).status();
    case evaluator::Body::kBatch: return evaluator::ParseBatchRequest(text).status();
    case evaluator::Body::kFit: return evaluator::ParseFitRequest(text).status();
    case evaluator::Body::kSpeech: return evaluator::ParseSpeechRequest(text).status();
    default: return InvalidArgument("not a top-level body");
  }
}
constexpr evaluator::Body kTopLevel[] = {evaluator::Body::kMesh,  evaluator::Body::kRender,
                                         evaluator::Body::kSheet, evaluator::Body::kSequence,
                                         evaluator::Body::kBatch, evaluator::Body::kFit,
                                         evaluator::Body::kSpeech};

bool SaysUnknown(const Status& s, const std::string& pointer) {
  for (const FieldError& f : s.fields) {
    if (f.pointer == pointer && f.message.starts_with("unknown member")) return true;
  }
  return false;
}

TEST(Members, EveryBodyHasItsTableWithNamesOnceAndJsonThatParses) {
  std::set<std::string_view> schemas;
  for (evaluator::Body body : evaluator::kBodies) {
    EXPECT_TRUE(schemas.insert(SchemaName(body)).second) << SchemaName(body);
    ASSERT_FALSE(Members(body).empty()) << SchemaName(body);
    std::set<std::string_view> names;
    for (const evaluator::Member& m : Members(body)) {
      EXPECT_TRUE(names.insert(m.name).second) << SchemaName(body) << "." << m.name << " twice";
      EXPECT_FALSE(m.doc.empty()) << SchemaName(body) << "." << m.name;
      for (std::string_view text : {m.example, m.fallback}) {
        if (!text.empty()) {
          EXPECT_FALSE(json::parse(text, nullptr, false).is_discarded()) << m.name << ": " << text;
        }
      }
      if (m.kind == Kind::kSchema && !m.schema.starts_with('#')) {
        EXPECT_FALSE(json::parse(m.schema, nullptr, false).is_discarded())
            << m.name << ": " << m.schema;
      }
    }
  }
}

// A member the table declares is read (its example, or a value of its kind, is never "unknown"),
// and one it does not is refused with the pointer of the member and the route's members named.
TEST(Members, EachReaderTakesEveryDeclaredMemberAndRefusesOthers) {
  for (evaluator::Body body : kTopLevel) {
    for (const evaluator::Member& m : Members(body)) {
      const std::string text = json{{std::string(m.name), ValueOf(m)}}.dump();
      EXPECT_FALSE(SaysUnknown(Read(body, text), "/" + std::string(m.name)))
          << SchemaName(body) << ": " << text;
    }
    const Status s = Read(body, R"({"wieghts": {}})");
    EXPECT_TRUE(SaysUnknown(s, "/wieghts")) << SchemaName(body) << ": " << s.message;
  }
}

TEST(Members, NestedObjectsRefuseAnUnknownMemberByItsPointer) {
  const std::pair<evaluator::Body, const char*> cases[] = {
      {evaluator::Body::kRender, R"({"camera": {"yaww": 1}})"},
      {evaluator::Body::kRender, R"({"light": {"yaww": 1}})"},
      {evaluator::Body::kMesh, R"({"gaze": {"yaww": 1}})"},
      {evaluator::Body::kSheet, R"({"cells": [{"wieghts": {}}]})"},
      {evaluator::Body::kBatch, R"({"variants": [{"weights": {}, "idd": "a"}]})"},
      {evaluator::Body::kBatch, R"({"sample": {"method": "uniform", "cuont": 3}})"},
      {evaluator::Body::kBatch, R"({"sample": {"method": "uniform"}, "randomize": {"sed": 3}})"},
      {evaluator::Body::kSequence, R"({"keys": [{"time": 0, "wieghts": {}}]})"},
      {evaluator::Body::kSequence, R"({"blink": {"per_minut": 3}})"},
  };
  const char* pointers[] = {"/camera/yaww",     "/light/yaww",     "/gaze/yaww",
                            "/cells/0/wieghts", "/variants/0/idd", "/sample/cuont",
                            "/randomize/sed",   "/keys/0/wieghts", "/blink/per_minut"};
  for (size_t i = 0; i < std::size(cases); ++i) {
    const Status s = Read(cases[i].first, cases[i].second);
    EXPECT_TRUE(SaysUnknown(s, pointers[i])) << cases[i].second << ": " << s.message;
  }
}

TEST(Members, ANumberOutOfItsDeclaredRangeIsRefusedWithTheRange) {
  const Status s = evaluator::ParseRenderRequest(R"({"supersample": 5})").status();
  ASSERT_EQ(s.fields.size(), 1u);
  EXPECT_EQ(s.fields[0].pointer, "/supersample");
  EXPECT_EQ(s.fields[0].message, "must be an integer in [1, 4]");
  EXPECT_EQ(
      evaluator::ParseRenderRequest(R"({"camera": {"zoom": 0}})").status().fields.at(0).message,
      "must be a number in [0.01, 100]");
}

// The document's request schemas are the tables: the same members, closed, no `default` keyword
// (which generated clients would make required), each default in x-facespace-default.
TEST(Members, TheDocumentsRequestSchemasAreTheTables) {
  const json doc = json::parse(OpenApiJson(http::ApiOptions{}));
  const json& schemas = doc["components"]["schemas"];
  for (evaluator::Body body : evaluator::kBodies) {
    const std::string name(SchemaName(body));
    ASSERT_TRUE(schemas.contains(name)) << name;
    const json& s = schemas[name];
    EXPECT_EQ(s.value("additionalProperties", true), false) << name;
    std::set<std::string> declared, documented;
    for (const evaluator::Member& m : Members(body)) declared.insert(std::string(m.name));
    for (const auto& [member, schema] : s["properties"].items()) {
      documented.insert(member);
      EXPECT_FALSE(schema.contains("default")) << name << "." << member;
      const evaluator::Member* m = FindMember(body, member);
      if (m && !m->fallback.empty()) {
        EXPECT_EQ(schema["x-facespace-default"], json::parse(m->fallback)) << name << "." << member;
      }
    }
    EXPECT_EQ(declared, documented) << name;
  }
  // Every $ref of the document names a component it has.
  std::function<void(const json&)> walk = [&](const json& j) {
    if (j.is_object()) {
      if (j.contains("$ref") && j["$ref"].is_string()) {
        const std::string ref = j["$ref"];
        const std::string prefix = "#/components/schemas/";
        if (ref.starts_with(prefix)) {
          EXPECT_TRUE(schemas.contains(ref.substr(prefix.size()))) << ref;
        }
      }
      for (const auto& [k, v] : j.items()) walk(v);
    } else if (j.is_array()) {
      for (const json& v : j) walk(v);
    }
  };
  walk(doc);
}

// The answers' tables (evaluator/answers.h) are the document's answer schemas, closed, and the
// answers a client may post back (a reduced sequence's keys, a frame's moved nodes) take only
// members the request's own table declares.
TEST(Answers, TheDocumentsAnswerSchemasAreTheTables) {
  const json doc = json::parse(OpenApiJson(http::ApiOptions{}));
  const json& schemas = doc["components"]["schemas"];
  std::set<std::string_view> names;
  for (const AnswerTable& answer : kAnswerTables) {
    const std::string name(answer.name);
    EXPECT_TRUE(names.insert(answer.name).second) << name;
    for (Body body : kBodies) EXPECT_NE(SchemaName(body), name) << "a body and an answer";
    ASSERT_TRUE(schemas.contains(name)) << name;
    const json& s = schemas[name];
    EXPECT_EQ(s.value("additionalProperties", true), false) << name;
    std::set<std::string> declared, documented, required;
    for (const Member& m : answer.members) {
      EXPECT_TRUE(declared.insert(std::string(m.name)).second) << name << "." << m.name;
      if (m.required) required.insert(std::string(m.name));
    }
    for (const auto& [member, schema] : s["properties"].items()) documented.insert(member);
    EXPECT_EQ(declared, documented) << name;
    EXPECT_EQ(required, s.value("required", std::set<std::string>{})) << name;
  }
  for (const auto& [answer, body] : {std::pair{Answer::kSequenceKey, Body::kKey},
                                     std::pair{Answer::kPosedJoint, Body::kJoint}}) {
    for (const Member& m : Members(answer))
      EXPECT_NE(FindMember(body, m.name), nullptr) << TableOf(answer).name << "." << m.name;
  }
}

// A writer names its members from the table, in the order it is told, as JSON that parses.
TEST(Answers, AWriterWritesTheDeclaredNames) {
  std::string out = "[";
  AnswerWriter<Answer::kReduced>(out)
      .Raw("keys", "[]")
      .Raw("transition", "\"linear\"")
      .Count("kept", 2)
      .Count("removed", 1)
      .Number("max_error", 0.25)
      .Number("tolerance", 0.5)
      .End() += "]";
  EXPECT_EQ(out, R"([{"keys":[],"transition":"linear","kept":2,"removed":1,"max_error":0.25,)"
                 R"("tolerance":0.5}])");
  EXPECT_FALSE(json::parse(out, nullptr, false).is_discarded());
}

// No reader spells a member name outside the tables: every name a request reader compares a key
// with, or looks up in an object, is a member of some table.
TEST(Members, NoReaderReadsAMemberTheTablesDoNotDeclare) {
  std::set<std::string> declared;
  for (evaluator::Body body : evaluator::kBodies) {
    for (const evaluator::Member& m : Members(body)) declared.insert(std::string(m.name));
  }
  // Names a reader compares that are not body members: the one-member object of a batch's
  // background images (read by `facespace batch` alone), and a fit target's primitives, which are
  // the mesh route's answer (the MeshJson schema) read back.
  const std::set<std::string> not_members = {"images", "positions"};
  const std::regex key_use(
      R"re((?:\bkey|\bk|\.key\(\))\s*[!=]=\s*"([a-z_]+)"|contains\("([a-z_]+)"\)|\["([a-z_]+)"\])re");
  size_t seen = 0;
  std::vector<fs::path> readers;
  for (const auto& entry :
       fs::directory_iterator(fs::path(FACESPACE_SOURCE_DIR) / "api/evaluator/src/request")) {
    if (entry.path().filename() != "members.cpp") readers.push_back(entry.path());
  }
  // The live socket's messages (the other routes read bodies through the readers above).
  readers.push_back(fs::path(FACESPACE_SOURCE_DIR) / "api/http/src/routes/live.cpp");
  for (const fs::path& path : readers) {
    const fs::directory_entry entry(path);
    std::ifstream in(entry.path());
    std::stringstream text;
    text << in.rdbuf();
    const std::string source = text.str();
    for (auto it = std::sregex_iterator(source.begin(), source.end(), key_use);
         it != std::sregex_iterator(); ++it) {
      const std::string name = (*it)[1].matched ? (*it)[1] : (*it)[2].matched ? (*it)[2] : (*it)[3];
      ++seen;
      EXPECT_TRUE(declared.count(name) || not_members.count(name))
          << entry.path().filename() << " reads \"" << name << "\"";
    }
  }
  EXPECT_GT(seen, 100u);  // The pattern finds the readers' names at all.
}

}  // namespace members_test
}  // namespace facespace::evaluator
