// The routes in process: the real cpp-httplib server on a loopback port, a memory store, the null
// renderer. Status codes, headers and bodies, checked against core evaluated in the test.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cstring>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "facespace/evaluator/evaluator.h"
#include "facespace/http/http.h"
#include "facespace/offscreen/render.h"
#include "loopback.h"
#include "memory_store.h"
#include "test_util.h"

namespace facespace {
namespace api_test {  // Named: the target is a unity build, its files share one unit.

using nlohmann::json;

class ApiTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    store_ = new test::MemoryStore;
    store_->Seed();
    http::ApiOptions o;
    o.api_key = "test-key";
    o.log_requests = false;
    o.max_render_size = 256;
    o.max_sheet_cells = 3;
    api_ = new http::Api(*store_, evaluator_, o);
    // The server as `facespace serve` runs it: connections through the front.
    net::FrontOptions front;
    front.workers = 8;
    front.log_requests = false;
    front.max_body = o.max_body;
    front.head_check = [](const net::RequestHeadView& head) { return api_->CheckHead(head); };
    front.refusal = &http::Api::RefusalResponse;
    static net::FrontStats front_stats;
    server_ = new net::FrontServer(front, front_stats);
    api_->Register(*server_);
    port_ = server_->bind_to_any_port("127.0.0.1");
    thread_ = new std::thread([] { server_->listen_after_bind(); });
    while (!server_->is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  static void TearDownTestSuite() {
    server_->stop();
    thread_->join();
    delete thread_;
    delete server_;
    delete api_;
    delete store_;
  }
  // A client that waits as long as the work may take (cpp-httplib's 5 s read timeout is a time
  // limit, and keyed work under the sanitizers beside other load has taken longer): tests judge
  // answers, not speed.
  static httplib::Client Client() {
    httplib::Client c("127.0.0.1", port_);
    c.set_read_timeout(300, 0);
    c.set_write_timeout(300, 0);
    return c;
  }

  // A raw exchange on one connection: `request` is sent as it is (headers only, or a partial
  // body), then what the server answers within 3 s is read (a server that waits for a body that
  // never comes answers nothing in that time). `then`, when set, is sent after the first answer.
  static std::string Raw(const std::string& request, std::string* second = nullptr,
                         const std::string& then = {}) {
    const int fd = test::ConnectLoopback(port_, 3);
    std::string out;
    if (fd >= 0 && send(fd, request.data(), request.size(), 0) > 0) {
      out = ReadAnswer(fd);
      if (second && send(fd, then.data(), then.size(), MSG_NOSIGNAL) > 0) *second = ReadAnswer(fd);
    }
    close(fd);
    return out;
  }
  // One answer: through the blank line, then Content-Length bytes of body.
  static std::string ReadAnswer(int fd) {
    std::string out;
    char buf[4096];
    for (;;) {
      const size_t end = out.find("\r\n\r\n");
      if (end != std::string::npos) {
        const size_t cl = out.find("Content-Length: ");
        const size_t body =
            cl == std::string::npos || cl > end ? 0 : std::stoul(out.substr(cl + 16));
        if (out.size() >= end + 4 + body) return out;
      }
      const ssize_t n = recv(fd, buf, sizeof buf, 0);
      if (n <= 0) return out;
      out.append(buf, static_cast<size_t>(n));
    }
  }
  static std::string Status(const std::string& raw) { return raw.substr(0, raw.find("\r\n")); }
  static std::string Header(const std::string& raw, const std::string& name) {
    const size_t at = raw.find("\r\n" + name + ": ");
    if (at == std::string::npos) return {};
    const size_t from = at + name.size() + 4;
    return raw.substr(from, raw.find("\r\n", from) - from);
  }
  static json RawBody(const std::string& raw) {
    return json::parse(raw.substr(std::min(raw.size(), raw.find("\r\n\r\n") + 4)), nullptr, false);
  }
  static json Body(const httplib::Result& r) { return json::parse(r->body, nullptr, false); }

  static inline test::MemoryStore* store_ = nullptr;
  static inline offscreen::NullRenderer null_;
  static inline evaluator::Evaluator evaluator_{null_};
  static inline http::Api* api_ = nullptr;
  static inline httplib::Server* server_ = nullptr;
  static inline std::thread* thread_ = nullptr;
  static inline int port_ = 0;
};

// What does not change (topology, a rig's description) is encoded once per coding: brotli or gzip
// as asked, the same body once decoded (the client decodes), an ETag per coding, and the indices
// also as little-endian uint32 for WebGL clients.
TEST_F(ApiTest, TopologyAndDescriptionComeEncodedAsAskedAndAsU32) {
  auto get = [](const std::string& path, const std::string& coding) {
    httplib::Client c = Client();
    return c.Get(path, {{"Accept-Encoding", coding}});
  };
  for (const std::string path : {"/v1/rigs/facecap/topology", "/v1/rigs/facecap", "/v1/rigs"}) {
    auto plain = get(path, "identity"), br = get(path, "br, gzip"),
         gz = get(path, "gzip;q=1, br;q=0");
    ASSERT_TRUE(plain && br && gz) << path;
    EXPECT_EQ(plain->status, 200);
    EXPECT_FALSE(plain->has_header("Content-Encoding")) << path;
    EXPECT_EQ(br->get_header_value("Content-Encoding"), "br") << path;
    EXPECT_EQ(gz->get_header_value("Content-Encoding"), "gzip") << path;
    EXPECT_EQ(br->body, plain->body) << path;
    EXPECT_EQ(gz->body, plain->body) << path;
    EXPECT_EQ(br->get_header_value("Vary"), "Accept, Accept-Encoding");
    EXPECT_NE(br->get_header_value("ETag"), gz->get_header_value("ETag"));
    auto again = Client().Get(
        path, {{"Accept-Encoding", "br"}, {"If-None-Match", br->get_header_value("ETag")}});
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 304) << path;
  }
  const json topology = json::parse(get("/v1/rigs/facecap/topology", "identity")->body);
  auto u32 = get("/v1/rigs/facecap/topology?format=u32", "br");
  ASSERT_TRUE(u32);
  EXPECT_EQ(u32->get_header_value("Content-Type"), "application/octet-stream");
  std::vector<uint32_t> expected;
  std::string counts;
  for (const json& p : topology["primitives"]) {
    for (const json& i : p["indices"]) expected.push_back(i.get<uint32_t>());
    counts += (counts.empty() ? "" : ",") + std::to_string(p["indices"].size());
  }
  ASSERT_EQ(u32->body.size(), 4 * expected.size());
  std::vector<uint32_t> got(expected.size());
  std::memcpy(got.data(), u32->body.data(), u32->body.size());
  EXPECT_EQ(got, expected);
  EXPECT_EQ(u32->get_header_value("Facespace-Index-Counts"), counts);
  auto bad = get("/v1/rigs/facecap/topology?format=u16", "identity");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 422);
  EXPECT_NE(bad->body.find("format"), std::string::npos);
}

// Issue 48: every answer states its cost; work over an anonymous request's budget is refused before
// it is done (422 over-budget naming the member that drives it), and the same work with the key is
// done.
TEST_F(ApiTest, EveryAnswerStatesItsCostAndAnonymousWorkOverItsBudgetIsRefused) {
  auto health = Client().Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->get_header_value("Facespace-Cost"), "0.0001");
  std::string keys = "{\"tolerance\":0,\"keys\":[";
  for (int i = 0; i < 60000; ++i)
    keys += (i ? ",{\"time\":" : "{\"time\":") + std::to_string(i) + "}";
  keys += "]}";
  auto anonymous = Client().Post("/v1/rigs/facecap/sequence/reduce", keys, "application/json");
  ASSERT_TRUE(anonymous);
  EXPECT_EQ(anonymous->status, 422);
  const json problem = json::parse(anonymous->body);
  EXPECT_EQ(problem["type"], "urn:facespace:problem:over-budget");
  EXPECT_EQ(problem["errors"][0]["pointer"], "/keys");
  const double cost = std::stod(anonymous->get_header_value("Facespace-Cost"));
  EXPECT_GT(cost, 2.0);
  auto keyed = Client().Post("/v1/rigs/facecap/sequence/reduce",
                             {{"Authorization", "Bearer test-key"}}, keys, "application/json");
  ASSERT_TRUE(keyed);
  EXPECT_EQ(keyed->status, 200);
  EXPECT_EQ(json::parse(keyed->body)["kept"],
            2);  // Sixty thousand keys of the rest pose: the ends stay.
  EXPECT_EQ(std::stod(keyed->get_header_value("Facespace-Cost")), cost);
  auto small =
      Client().Post("/v1/rigs/facecap/sequence/reduce",
                    R"({"tolerance":0,"keys":[{"time":0},{"time":1}]})", "application/json");
  ASSERT_TRUE(small);
  EXPECT_EQ(small->status, 200);
  EXPECT_LT(std::stod(small->get_header_value("Facespace-Cost")), 0.01);
}

TEST_F(ApiTest, MeshF32IsTheBlendInWorldSpaceWithItsHeaders) {
  auto r = Client().Get("/v1/rigs/facecap/mesh?w.jawOpen=0.6&w.cheekPuff=0.7&format=f32");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/octet-stream");
  EXPECT_EQ(r->get_header_value("Facespace-Weight-Sum"), "1.3");
  EXPECT_EQ(r->get_header_value("Facespace-Warnings"), "extrapolation;value=1.3");
  const Rig& rig = store_->Get("facecap")->rig;
  std::vector<float> w(rig.shapes.size(), 0.0f);
  for (size_t i = 0; i < w.size(); ++i) {
    if (rig.shapes[i].name == "jawOpen") w[i] = 0.6f;
    if (rig.shapes[i].name == "cheekPuff") w[i] = 0.7f;
  }
  BlendedRig blended;
  BlendContext context;
  ASSERT_TRUE(EvaluateRig(rig, w, {}, blended, context).ok());
  std::vector<float> want;
  formats::WorldPositions(blended, want);
  ASSERT_GE(r->body.size(), want.size() * 4);
  std::vector<float> got(want.size());
  std::memcpy(got.data(), r->body.data(), want.size() * 4);
  for (size_t i = 0; i < want.size(); ++i) ASSERT_EQ(got[i], want[i]) << i;
  // The same request again: the ETag matches, 304.
  auto again = Client().Get("/v1/rigs/facecap/mesh?w.jawOpen=0.6&w.cheekPuff=0.7&format=f32",
                            {{"If-None-Match", r->get_header_value("ETag")}});
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 304);
}

TEST_F(ApiTest, ErrorsAreProblemDetailsNamingTheField) {
  auto r =
      Client().Post("/v1/rigs/facecap/mesh", R"({"weights": {"jawOpn": 1}})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/problem+json");
  json p = Body(r);
  EXPECT_EQ(p["type"], "urn:facespace:problem:invalid-weights");
  EXPECT_EQ(p["errors"][0]["pointer"], "/weights/jawOpn");

  r = Client().Post("/v1/rigs/facecap/mesh", R"({"weights": )", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_EQ(Body(r)["type"], "urn:facespace:problem:malformed-json");
  // Where: the line and column the parser stopped at (the stray "}" of line 3).
  r = Client().Post("/v1/rigs/facecap/mesh", "{\"weights\": {\n  \"jawOpen\": 0.5,\n  \"x\": }\n}",
                    "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_NE(Body(r)["detail"].get<std::string>().find("at line 3, column 8"), std::string::npos)
      << r->body;

  r = Client().Post("/v1/rigs/facecap/mesh",
                    R"({"weights": {"jawOpen": 0.9, "cheekPuff": 0.8}, "strict": true})",
                    "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Body(r)["type"], "urn:facespace:problem:weights-leave-authored-space");
  EXPECT_EQ(Body(r)["warnings"][0]["code"], "extrapolation");
  EXPECT_EQ(r->get_header_value("Facespace-Weight-Sum"), "1.7");

  r = Client().Get("/v1/rigs/nope/mesh");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
  EXPECT_EQ(Body(r)["type"], "urn:facespace:problem:rig-not-found");
  r = Client().Get("/v1/rigs/facecpa/mesh");  // A typo of an id: the nearest is suggested.
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
  EXPECT_NE(Body(r)["detail"].get<std::string>().find("did you mean 'facecap'?"), std::string::npos)
      << r->body;
}

TEST_F(ApiTest, RenderWithTheNullRendererIsTheBackgroundAtTheAskedSize) {
  auto r =
      Client().Get("/v1/rigs/facecap/render?w.jawOpen=1&width=40&height=30&background=%23ff0000");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(r->get_header_value("Content-Type"), "image/png");
  EXPECT_EQ(r->get_header_value("Facespace-Weight-Sum"), "1");
  auto image =
      offscreen::Decode({reinterpret_cast<const unsigned char*>(r->body.data()), r->body.size()});
  ASSERT_TRUE(image.ok());
  EXPECT_EQ(image->width, 40);
  EXPECT_EQ(image->height, 30);
  EXPECT_NEAR(image->rgba[0], 1.0f, 1e-3);
  EXPECT_NEAR(image->rgba[1], 0.0f, 1e-3);

  r = Client().Get("/v1/rigs/facecap/render?width=300");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Body(r)["errors"][0]["parameter"], "width");

  r = Client().Get("/v1/rigs/facecap/render?width=64&height=64",
                   {{"Accept", "image/png;q=0, image/jpeg"}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->get_header_value("Content-Type"), "image/jpeg");
  r = Client().Get("/v1/rigs/facecap/render?width=64&height=64", {{"Accept", "text/html"}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 406);
}

// Every setting that changes the picture changes the cache key, so the ETag, and no render is
// answered from the cache of another (an exposure of 2 was once answered with exposure 0's image).
TEST_F(ApiTest, EveryRenderSettingHasItsOwnCacheEntry) {
  const std::string base = "/v1/rigs/facecap/render?width=32&height=32";
  std::map<std::string, std::string> seen;  // ETag -> the query that had it.
  for (const std::string extra :
       {"", "&exposure=2", "&exposure=-1", "&view=clay", "&view=heatmap", "&frame=all",
        "&frame=shapes", "&yaw=10", "&pitch=5", "&fov=40", "&zoom=2", "&background=%23ff0000",
        "&supersample=2", "&w.jawOpen=1", "&normals=recompute"}) {
    auto r = Client().Get(base + extra);
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << extra << " " << r->body;
    const std::string etag = r->get_header_value("ETag");
    ASSERT_FALSE(etag.empty());
    EXPECT_TRUE(seen.emplace(etag, extra).second)
        << "'" << extra << "' has the ETag of '" << seen[etag] << "'";
    auto again = Client().Get(base + extra);
    ASSERT_TRUE(again);
    EXPECT_EQ(again->get_header_value("ETag"), etag)
        << extra;  // And the same request the same one.
  }
}

// The response cache keeps a render at once and a mesh (cheap to make again) only when it is asked
// for a second time: the third identical mesh request is the first hit, the second render is. Every
// answer has the same bytes and ETag. A point asked for once is not kept.
TEST_F(ApiTest, MeshesAreKeptOnTheirSecondRequestRendersOnTheirFirst) {
  auto timing = [](const httplib::Result& r) {
    return r ? r->get_header_value("Server-Timing") : std::string("no answer");
  };
  const std::string hit = "cache;desc=\"hit\"";
  const std::string mesh = "/v1/rigs/facecap/mesh?format=f32&w.jawOpen=0.123457&w.eyeBlink_L=0.3";
  std::vector<httplib::Result> answers;
  for (int i = 0; i < 3; ++i) answers.push_back(Client().Get(mesh));
  for (const auto& r : answers) {
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << r->body;
    EXPECT_EQ(r->body, answers[0]->body);
    EXPECT_EQ(r->get_header_value("ETag"), answers[0]->get_header_value("ETag"));
  }
  EXPECT_NE(timing(answers[0]), hit);
  EXPECT_NE(timing(answers[1]), hit);  // Made again, and now kept.
  EXPECT_EQ(timing(answers[2]), hit);
  EXPECT_NE(timing(Client().Get("/v1/rigs/facecap/mesh?format=f32&w.jawOpen=0.654321")),
            hit);  // Another point.

  const std::string render = "/v1/rigs/facecap/render?width=24&height=24&w.jawOpen=0.123457";
  auto first = Client().Get(render), second = Client().Get(render);
  ASSERT_TRUE(first && second);
  EXPECT_NE(timing(first), hit);
  EXPECT_EQ(timing(second), hit);
  EXPECT_EQ(first->body, second->body);
}

TEST_F(ApiTest, SheetRefusesMoreCellsThanConfigured) {
  auto r = Client().Post("/v1/rigs/facecap/sheet",
                         R"({"cells": [{}, {}, {}, {}], "width": 16, "height": 16})",
                         "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Body(r)["type"], "urn:facespace:problem:too-many-cells");
  r = Client().Post(
      "/v1/rigs/facecap/sheet",
      R"({"cells": [{"weights": {"jawOpen": 1}, "label": "open"}, {}], "width": 16, "height": 16})",
      "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "image/png");
}

TEST_F(ApiTest, CheckAndSequenceAndFit) {
  auto r = Client().Post("/v1/rigs/facecap/check", R"({"weights": {"jawOpen": 1.5}})",
                         "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  json c = Body(r);
  EXPECT_EQ(c["sum"], 1.5);
  EXPECT_EQ(c["weights"]["jawOpen"], 1.5);
  EXPECT_EQ(c["warnings"][0]["code"], "extrapolation");

  r = Client().Post(
      "/v1/rigs/facecap/sequence/sample",
      R"({"keys": [{"time": 0, "weights": {}}, {"time": 1, "shape": "jawOpen"}], "times": [0.5], "transition": "linear"})",
      "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(Body(r)["frames"][0]["weights"]["jawOpen"], 0.5);
  EXPECT_EQ(Body(r)["space"], "world");  // As blend's JSON: positions placed by their nodes.

  // "format": "weights": each frame's time, weights and sum, no mesh (clients that blend on the
  // GPU).
  r = Client().Post(
      "/v1/rigs/facecap/sequence/sample",
      R"({"keys": [{"time": 0}, {"time": 1, "weights": {"jawOpen": 1}}], "times": [0.25, 0.5], "format": "weights"})",
      "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  json w = Body(r);
  ASSERT_EQ(w["frames"].size(), 2u);
  EXPECT_EQ(w["frames"][1]["weights"]["jawOpen"], 0.5);
  EXPECT_EQ(w["frames"][0]["sum"], 0.25);
  EXPECT_FALSE(w["frames"][0].contains("primitives"));
  EXPECT_FALSE(w["frames"][0].contains("pose"));  // Keys of weights pose nothing.
  r = Client().Post("/v1/rigs/facecap/sequence/sample",
                    R"({"keys": [{"time": 0}, {"time": 1}], "times": [0], "format": "f32"})",
                    "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Body(r)["errors"][0]["pointer"], "/format");

  r = Client().Post("/v1/rigs/facecap/sequence/reduce", R"({"keys": [{"time": 0}, {"time": 1}]})",
                    "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Body(r)["errors"][0]["pointer"], "/tolerance");

  // Fit the mesh JSON of a point: the same point back.
  auto mesh = Client().Get("/v1/rigs/facecap/mesh?w.jawOpen=0.4&format=json");
  ASSERT_TRUE(mesh);
  json m = Body(mesh);
  r = Client().Post("/v1/rigs/facecap/fit", json{{"target", m}}.dump(), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body.substr(0, 300);
  EXPECT_NEAR(Body(r)["weights"]["jawOpen"].get<double>(), 0.4, 1e-3);
}

// An answer's status and the methods its Allow header names.
void ExpectAllow(const httplib::Result& r, int status, const std::string& allow) {
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, status);
  EXPECT_EQ(r->get_header_value("Allow"), allow);
}

TEST_F(ApiTest, TheRouteTableFeedsAllowAndTheOpenApiPaths) {
  auto r = Client().Delete("/v1/rigs/facecap/mesh");
  ExpectAllow(r, 405, "GET, HEAD, POST, OPTIONS");
  r = Client().Post("/v1/rigs/facecap", "{}", "application/json");
  ExpectAllow(r, 405, "GET, HEAD, PUT, DELETE, OPTIONS");
  r = Client().Get("/v1/rigs/facecap/check");
  ExpectAllow(r, 405, "POST, OPTIONS");
  // OPTIONS says what the 405 says.
  r = Client().Options("/v1/rigs/facecap/mesh");
  ExpectAllow(r, 204, "GET, HEAD, POST, OPTIONS");
  r = Client().Options("/v1/nowhere");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);

  r = Client().Get("/openapi.json");
  ASSERT_TRUE(r);
  json doc = Body(r);
  // Every documented operation answers something other than 404/405 here, and the count is the
  // table's.
  size_t operations = 0;
  for (auto& [path, item] : doc["paths"].items()) {
    for (auto& [method, op] : item.items()) {
      ++operations;
      EXPECT_TRUE(op.contains("operationId")) << method << " " << path;
    }
  }
  EXPECT_EQ(operations, 33u);  // The route table's 33 (POST /v1/rigs/{id}/capture the last added).
  EXPECT_TRUE(doc["paths"]["/v1/rigs/{id}"]["get"]["parameters"].is_array());
  // The GET parameters the document declares are the ones the routes read: each, given a value
  // no route takes, is refused for its value, never as an unknown parameter.
  for (const char* path : {"/v1/rigs/{id}/mesh", "/v1/rigs/{id}/render"}) {
    const json& params = doc["paths"][path]["get"]["parameters"];
    ASSERT_GT(params.size(), 10u) << path;
    for (const json& p : params) {
      const std::string name = p["name"];
      if (p["in"] != "query" || name == "w" || name == "c" || name == "e")
        continue;  // Maps: w[NAME], c[NAME], e[NAME].
      std::string url = std::string(path).replace(std::string(path).find("{id}"), 4, "facecap") +
                        "?" + name + "=%7Bnot-a-value";
      r = Client().Get(url);
      ASSERT_TRUE(r);
      EXPECT_EQ(r->body.find("unknown parameter"), std::string::npos)
          << url << ": " << r->body.substr(0, 200);
    }
  }
  // Weights as the document declares them (deepObject: w[NAME]) are the weights of w.NAME.
  EXPECT_EQ(doc["paths"]["/v1/rigs/{id}/mesh"]["get"]["parameters"][1]["style"], "deepObject");
  auto bracketed = Client().Get("/v1/rigs/facecap/mesh?w%5BjawOpen%5D=0.5&format=f32");
  auto dotted = Client().Get("/v1/rigs/facecap/mesh?w.jawOpen=0.5&format=f32");
  ASSERT_TRUE(bracketed && dotted);
  EXPECT_EQ(bracketed->status, 200);
  EXPECT_EQ(bracketed->get_header_value("Facespace-Weight-Sum"), "0.5");
  EXPECT_EQ(bracketed->body, dotted->body);

  r = Client().Get("/metrics");
  ASSERT_TRUE(r);
  // Route labels from the table: /topology is counted under its rig's label, as before.
  // The access log (and the counters) run after the response is sent: wait for it, bounded.
  // Other tests may have counted some already: the count grows by one.
  auto counted = [](const std::string& text) {
    const std::string label =
        "facespace_http_requests_total{route=\"/v1/rigs/{id}\",status=\"200\"} ";
    const size_t at = text.find(label);
    return at == std::string::npos ? 0L : std::stol(text.substr(at + label.size()));
  };
  const long before = counted(r->body);
  ASSERT_TRUE(Client().Get("/v1/rigs/facecap/topology"));
  for (int i = 0; i < 200; ++i) {
    r = Client().Get("/metrics");
    ASSERT_TRUE(r);
    if (counted(r->body) == before + 1) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(counted(r->body), before + 1) << r->body;
}

TEST_F(ApiTest, BatchAndJobsWithoutAQueueAre503AfterAuth) {
  const std::string body = R"({"sample": {"method": "uniform", "count": 2}})";
  auto r = Client().Post("/v1/rigs/facecap/batch", body, "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 401);  // The key is checked first, from the headers.
  r = Client().Post("/v1/rigs/facecap/batch", {{"Authorization", "Bearer test-key"}}, body,
                    "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 503);
  r = Client().Get("/v1/jobs/0123456789abcdef0123456789abcdef");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 503);
  // The list holds the derive jobs, which need no queue: none here.
  r = Client().Get("/v1/jobs");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->body, R"({"jobs":[]})");
}

TEST_F(ApiTest, UploadsTakeFbxAndColladaByMediaTypeFileNameOrMagic) {
  httplib::Headers auth = {{"Authorization", "Bearer test-key"}};
  const std::vector<unsigned char> fbx =
      test::ReadBytes(test::SharedAssets() +
                      "/more/FBX/ufbx_maya_blend_inbetween/maya_blend_inbetween_7500_binary.fbx");
  const std::vector<unsigned char> dae = test::ReadBytes(
      test::SharedAssets() + "/more/Collada/CTS_morph_two_targets/morph_two_targets.dae");
  const std::string fbx_body(fbx.begin(), fbx.end()), dae_body(dae.begin(), dae.end());
  // An octet stream with a file name.
  httplib::Headers named = auth;
  named.emplace("Content-Disposition", "attachment; filename=\"cube.fbx\"");
  auto r = Client().Put("/v1/rigs/cube", named, fbx_body, "application/octet-stream");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 201) << r->body;
  r = Client().Get("/v1/rigs/cube");
  ASSERT_TRUE(r);
  EXPECT_EQ(Body(r)["shapes"].size(), 5u)
      << r->body;  // LiftTop, MoveToSide and their 3 in-betweens.
  // The slider at 0.5 is the in-between alone: its mesh differs from the rest's.
  r = Client().Get("/v1/rigs/cube/mesh?w.LiftTop=0.5&format=json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  // Without a name: told by the magic. COLLADA by its media type.
  r = Client().Put("/v1/rigs/cube2", auth, fbx_body, "application/octet-stream");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 201) << r->body;
  r = Client().Put("/v1/rigs/pyramid", auth, dae_body, "model/vnd.collada+xml");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 201) << r->body;
  EXPECT_EQ(Body(Client().Get("/v1/rigs/pyramid"))["shapes"].size(), 2u);
  // A truncated FBX is an invalid rig, named; an unknown octet stream is 415; the store keeps
  // serving.
  r = Client().Put("/v1/rigs/cube", named, fbx_body.substr(0, 5000), "application/octet-stream");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422) << r->body;
  EXPECT_NE(Body(r)["detail"].get<std::string>().find("FBX"), std::string::npos) << r->body;
  r = Client().Put("/v1/rigs/cube", auth, "just bytes", "application/octet-stream");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 415);
  EXPECT_EQ(Body(Client().Get("/v1/rigs/cube"))["shapes"].size(), 5u);
  for (const char* id : {"cube", "cube2", "pyramid"})
    Client().Delete(std::string("/v1/rigs/") + id, auth);
}

// glb bodies come from writers kept per rig: after a rig is replaced under the same id, its glb
// is the new rig's (the same bytes as that rig under another id), never the old template patched.
TEST_F(ApiTest, GlbAfterAReplacedRigIsTheNewRigs) {
  httplib::Headers auth = {{"Authorization", "Bearer test-key"}};
  auto bytes = [](const char* asset) {
    const std::vector<unsigned char> b = test::ReadBytes(test::RealAsset(asset));
    return std::string(b.begin(), b.end());
  };
  const std::string face = bytes("FaceCap/facecap_decoded.glb"), fox = bytes("Fox/Fox.glb");
  ASSERT_EQ(Client().Put("/v1/rigs/swap", auth, face, "model/gltf-binary")->status, 201);
  auto first = Client().Get("/v1/rigs/swap/mesh?format=glb");
  auto second = Client().Get(
      "/v1/rigs/swap/mesh?format=glb&w.jawOpen=0.5");  // Patched from the first's template.
  ASSERT_TRUE(first && second);
  EXPECT_EQ(second->status, 200);
  EXPECT_NE(first->body, second->body);
  ASSERT_EQ(Client().Put("/v1/rigs/swap", auth, fox, "model/gltf-binary")->status, 200);
  ASSERT_EQ(Client().Put("/v1/rigs/fox2", auth, fox, "model/gltf-binary")->status, 201);
  for (int i = 0; i < 2; ++i) {  // Twice: the second from a kept writer.
    auto replaced =
        Client().Get("/v1/rigs/swap/mesh?format=glb&animation=0&time=" + std::to_string(0.3 * i));
    auto other =
        Client().Get("/v1/rigs/fox2/mesh?format=glb&animation=0&time=" + std::to_string(0.3 * i));
    ASSERT_TRUE(replaced && other);
    EXPECT_EQ(replaced->status, 200) << replaced->body;
    EXPECT_EQ(replaced->body, other->body);
  }
  for (const char* id : {"swap", "fox2"}) Client().Delete(std::string("/v1/rigs/") + id, auth);
}

TEST_F(ApiTest, UploadsNeedTheKey) {
  const std::vector<unsigned char> fox = test::ReadBytes(test::RealAsset("Fox/Fox.glb"));
  const std::string body(fox.begin(), fox.end());
  auto r = Client().Put("/v1/rigs/fox", body, "model/gltf-binary");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 401);
  httplib::Headers auth = {{"Authorization", "Bearer test-key"}};
  r = Client().Put("/v1/rigs/fox", auth, body, "model/gltf-binary");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 201) << r->body;
  r = Client().Put("/v1/rigs/fox", auth, "not a glb", "model/gltf-binary");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Body(r)["type"], "urn:facespace:problem:invalid-rig");
  r = Client().Delete("/v1/rigs/fox", auth);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 204);
}

// Requests refused from their request line and headers are answered at once, before any body
// (the server used to wait out its read timeout for a body that never came, or invite it with 100).
// The face by name over HTTP: an expression is the mesh of its mapped weights (body and query
// alike), a gaze sets FaceCap's eye shapes through its range map, typos are 422 naming the member,
// and a sequence's blinks and gaze track show in its frames.
TEST_F(ApiTest, ExpressionsGazeAndBlinksByName) {
  auto post = [](const std::string& path, const std::string& body) {
    return Client().Post(path, body, "application/json");
  };
  auto by_name = post("/v1/rigs/facecap/mesh", R"({"expressions": {"happy": 1}, "format": "f32"})");
  auto by_weights = post(
      "/v1/rigs/facecap/mesh",
      R"({"weights": {"mouthSmile_L": 1, "mouthSmile_R": 1, "cheekSquint_L": 0.5, "cheekSquint_R": 0.5,
                                                                 "eyeSquint_L": 0.4, "eyeSquint_R": 0.4}, "format": "f32"})");
  auto rest = post("/v1/rigs/facecap/mesh", R"({"format": "f32"})");
  auto query = Client().Get("/v1/rigs/facecap/mesh?e.happy=1&format=f32");
  ASSERT_TRUE(by_name && by_weights && rest && query);
  ASSERT_EQ(by_name->status, 200) << by_name->body;
  EXPECT_EQ(by_name->body, by_weights->body);
  EXPECT_EQ(query->body, by_weights->body);
  EXPECT_NE(by_name->body, rest->body);

  auto rig = Client().Get("/v1/rigs/facecap");
  ASSERT_TRUE(rig);
  const json d = Body(rig);
  EXPECT_EQ(d["expressions"]["happy"]["weights"]["mouthSmile_L"], 1);
  EXPECT_EQ(d["gaze"]["type"], "shapes");

  auto check = post("/v1/rigs/facecap/check", R"({"gaze": {"yaw": 20, "pitch": -5}})");
  ASSERT_TRUE(check);
  ASSERT_EQ(check->status, 200) << check->body;
  const json w = Body(check)["weights"];
  EXPECT_NEAR(w["eyeLookOut_L"].get<double>(), 20.0 / 30.0, 1e-6);
  EXPECT_NEAR(w["eyeLookIn_R"].get<double>(), 20.0 / 30.0, 1e-6);
  EXPECT_NEAR(w["eyeLookDown_L"].get<double>(), 5.0 / 25.0, 1e-6);
  auto q = Client().Get("/v1/rigs/facecap/mesh?gaze=20,-5&format=f32");
  auto b = post("/v1/rigs/facecap/mesh", R"({"gaze": {"yaw": 20, "pitch": -5}, "format": "f32"})");
  ASSERT_TRUE(q && b);
  EXPECT_EQ(q->body, b->body);

  for (const auto& [body, pointer] :
       {std::pair{R"({"expressions": {"hapy": 1}})", "/expressions/hapy"},
        std::pair{R"({"gaze": {"target": [0, 0, 1], "yaw": 3}})", "/gaze"},
        std::pair{R"({"gaze": {"yaw": "left"}})", "/gaze/yaw"},
        std::pair{R"({"expressions": [1]})", "/expressions"}}) {
    auto r = post("/v1/rigs/facecap/mesh", body);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 422) << body;
    EXPECT_EQ(Body(r)["errors"][0]["pointer"], pointer) << r->body;
  }
  // 60 s at 15 blinks a minute, sampled at 50 fps: 12 to 18 closings, the gaze track from left to
  // right.
  std::string times;
  for (int i = 0; i <= 3000; ++i) times += (i ? "," : "") + FormatNumber(i * 0.02);
  auto seq = post(
      "/v1/rigs/facecap/sequence/sample",
      R"({"keys": [{"time": 0}, {"time": 60}], "blink": {"per_minute": 15, "seed": 4}, "format": "weights",
                      "gaze": {"keys": [{"time": 0, "yaw": 30, "pitch": 0}, {"time": 60, "yaw": -30, "pitch": 0}]}, "times": [)" +
          times + "]}");
  ASSERT_TRUE(seq) << httplib::to_string(seq.error());
  ASSERT_EQ(seq->status, 200) << seq->body.substr(0, 300);
  const json frames = Body(seq)["frames"];
  ASSERT_EQ(frames.size(), 3001u);
  int closings = 0;
  bool closed = false;
  for (const json& f : frames) {
    const double blink = f["weights"].value("eyeBlink_L", 0.0);
    if (blink > 0.9 && !closed) ++closings;
    closed = blink > 0.9;
  }
  EXPECT_GE(closings, 12);
  EXPECT_LE(closings, 18);
  EXPECT_NEAR(frames[0]["weights"]["eyeLookOut_L"].get<double>(), 1.0, 1e-6);
  EXPECT_NEAR(frames[750]["weights"]["eyeLookOut_L"].get<double>(), 0.5, 1e-3);  // t = 15: yaw 15.
  EXPECT_NEAR(frames[3000]["weights"]["eyeLookOut_R"].get<double>(), 1.0, 1e-6);
}

TEST_F(ApiTest, RefusalsComeFromTheHeadersBeforeTheBody) {
  // A Content-Length over the limit, no body sent: 413 naming the limit.
  std::string raw =
      Raw("PUT /v1/rigs/big HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer "
          "test-key\r\nContent-Length: 900000000\r\n\r\n");
  EXPECT_EQ(Status(raw), "HTTP/1.1 413 Payload Too Large") << raw;
  EXPECT_EQ(Header(raw, "Content-Type"), "application/problem+json");
  EXPECT_NE(RawBody(raw).value("detail", "").find("--max-body"), std::string::npos) << raw;
  EXPECT_EQ(Header(raw, "Connection"), "close");

  // The same with Expect: 100-continue: the 413 is the answer, never a 100.
  raw =
      Raw("PUT /v1/rigs/big HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer "
          "test-key\r\nContent-Length: 900000000\r\nExpect: 100-continue\r\n\r\n");
  EXPECT_EQ(Status(raw), "HTTP/1.1 413 Payload Too Large") << raw;
  EXPECT_EQ(RawBody(raw).value("status", 0), 413) << raw;
  // An upload without the key: 401 before the body, not 100.
  raw =
      Raw("PUT /v1/rigs/big HTTP/1.1\r\nHost: x\r\nContent-Length: 1000\r\nExpect: "
          "100-continue\r\n\r\n");
  EXPECT_EQ(Status(raw), "HTTP/1.1 401 Unauthorized") << raw;
  // A body that will be taken: 100, then the answer once it is sent.
  const std::string body = R"({"weights": {"jawOpen": 0.5}, "format": "f32"})";
  std::string answer;
  raw =
      Raw("POST /v1/rigs/facecap/mesh HTTP/1.1\r\nHost: x\r\nContent-Type: "
          "application/json\r\nContent-Length: " +
              std::to_string(body.size()) + "\r\nExpect: 100-continue\r\n\r\n",
          &answer, body);
  EXPECT_EQ(Status(raw), "HTTP/1.1 100 Continue") << raw;
  EXPECT_EQ(Status(answer), "HTTP/1.1 200 OK") << answer;

  // POST of JSON with no length at all: 411 at once (it used to wait 10 s for the connection to
  // close).
  raw = Raw(
      "POST /v1/rigs/facecap/mesh HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n\r\n");
  EXPECT_EQ(Status(raw), "HTTP/1.1 411 Length Required") << raw;
  EXPECT_EQ(RawBody(raw).value("type", ""), "urn:facespace:problem:length-required");
  // PATCH on a rig: 405 at once, with the Allow that OPTIONS gives.
  raw = Raw("PATCH /v1/rigs/facecap HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n\r\n");
  EXPECT_EQ(Status(raw), "HTTP/1.1 405 Method Not Allowed") << raw;
  EXPECT_EQ(Header(raw, "Allow"), "GET, HEAD, PUT, DELETE, OPTIONS");
  // An unknown path under a body method: 404 at once.
  raw = Raw("POST /v1/nowhere HTTP/1.1\r\nHost: x\r\nContent-Length: 10\r\n\r\n");
  EXPECT_EQ(Status(raw), "HTTP/1.1 404 Not Found") << raw;
}

TEST_F(ApiTest, ParserRefusalsAreProblemDocuments) {
  std::string raw = Raw("GET /v1/rigs/facecap/mesh?w.jawOpen=" + std::string(9000, '1') +
                        " HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(Status(raw), "HTTP/1.1 414 URI Too Long") << raw.substr(0, 200);
  EXPECT_EQ(Header(raw, "Content-Type"), "application/problem+json");
  json problem = RawBody(raw);
  EXPECT_EQ(problem.value("type", ""), "urn:facespace:problem:uri-too-long");
  EXPECT_NE(problem.value("detail", "").find("8,192"), std::string::npos);
  raw = Raw("GET\r\n\r\n");
  EXPECT_EQ(Status(raw), "HTTP/1.1 400 Bad Request") << raw;
  EXPECT_NE(RawBody(raw).value("detail", "").find("request line"), std::string::npos) << raw;
}

// GET refused unknown parameters while POST ignored unknown members ({"wieghts": ...} gave the
// neutral face): both refuse them now, naming the closest valid name, and a member or parameter
// given twice.
TEST_F(ApiTest, UnknownAndRepeatedMembersAreRefusedInBodiesAndQueries) {
  auto r = Client().Post("/v1/rigs/facecap/mesh", R"({"wieghts": {"jawOpen": 1}, "format": "f32"})",
                         "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  json problem = Body(r);
  ASSERT_EQ(problem["errors"].size(), 1u) << r->body;
  EXPECT_EQ(problem["errors"][0]["pointer"], "/wieghts");
  EXPECT_NE(problem["errors"][0]["detail"].get<std::string>().find("did you mean 'weights'"),
            std::string::npos)
      << r->body;

  r = Client().Post("/v1/rigs/facecap/render", R"({"widht": 64})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_NE(r->body.find("did you mean 'width'"), std::string::npos) << r->body;
  r = Client().Post("/v1/rigs/facecap/sheet", R"({"cells": "shapes", "colums": 2})",
                    "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_NE(r->body.find("did you mean 'columns'"), std::string::npos) << r->body;
  r = Client().Post("/v1/rigs/facecap/sequence/sample",
                    R"({"keys": [{"time": 0, "weights": {}}], "time": [0]})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_NE(r->body.find("did you mean 'times'"), std::string::npos) << r->body;

  // A member given twice, at the top or deeper: 422 with its JSON Pointer.
  r = Client().Post("/v1/rigs/facecap/mesh", R"({"format": "f32", "format": "glb"})",
                    "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Body(r)["errors"][0]["pointer"], "/format") << r->body;
  r = Client().Post("/v1/rigs/facecap/sheet",
                    R"({"cells": [{"weights": {}}, {"weights": {"jawOpen": 1, "jawOpen": 0}}]})",
                    "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Body(r)["errors"][0]["pointer"], "/cells/1/weights/jawOpen") << r->body;
  // A query parameter with a JSON body would be lost: refused.
  r = Client().Post("/v1/rigs/facecap/mesh?format=f32", R"({"weights": {}})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Body(r)["errors"][0]["parameter"], "format") << r->body;
  // An empty body says so.
  r = Client().Post("/v1/rigs/facecap/mesh", "", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_NE(Body(r).value("detail", "").find("empty"), std::string::npos) << r->body;

  // The query: a parameter given twice, and the closest name for an unknown one.
  r = Client().Get("/v1/rigs/facecap/mesh?format=f32&format=glb");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Body(r)["errors"][0]["parameter"], "format") << r->body;
  EXPECT_NE(r->body.find("2 times"), std::string::npos) << r->body;
  r = Client().Get("/v1/rigs/facecap/render?w.jawOpen=1&w.jawOpen=0");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  r = Client().Get("/v1/rigs/facecap/render?wdith=64");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_NE(r->body.find("did you mean 'width'"), std::string::npos) << r->body;
  r = Client().Get("/v1/rigs/facecap/mesh?jawOpen=1");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_NE(r->body.find("w.NAME=VALUE"), std::string::npos) << r->body;
}

// FaceCap's positions are quantized (int16 with a scaling node): its JSON used to give those
// integers while f32 and OBJ gave world space. Every flat format is in world space now (floats,
// the node applied), or all in mesh space with space=mesh; the JSON says which.
TEST_F(ApiTest, EveryFlatFormatIsInOneSpace) {
  const std::string q = "/v1/rigs/facecap/mesh?w.jawOpen=0.6&w.cheekPuff=0.2";
  auto f32 = Client().Get(q + "&format=f32");
  auto js = Client().Get(q + "&format=json");
  auto obj = Client().Get(q + "&format=obj");
  ASSERT_TRUE(f32 && js && obj);
  ASSERT_EQ(js->status, 200) << js->body;
  json doc = Body(js);
  EXPECT_EQ(doc["space"], "world");
  std::vector<float> from_json, from_obj;
  for (const json& p : doc["primitives"]) {
    for (const json& v : p["positions"]) from_json.push_back(v.get<float>());
  }
  std::istringstream lines(obj->body);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("v ", 0) != 0) continue;
    float x, y, z;
    ASSERT_EQ(std::sscanf(line.c_str(), "v %f %f %f", &x, &y, &z), 3);
    from_obj.insert(from_obj.end(), {x, y, z});
  }
  ASSERT_EQ(from_json.size(), from_obj.size());
  ASSERT_GE(f32->body.size(), from_json.size() * 4);
  float diagonal = 0;
  for (size_t i = 0; i < from_json.size(); ++i) {
    float world;
    std::memcpy(&world, f32->body.data() + 4 * i, 4);
    ASSERT_EQ(from_json[i], world) << i;  // The JSON's shortest text reads back to the same float.
    ASSERT_NEAR(from_obj[i], world, 1e-6f * (1 + std::fabs(world))) << i;
    diagonal = std::max(diagonal, std::fabs(world));
  }
  EXPECT_LT(
      diagonal,
      10.0f);  // World space: a head a couple of units across, not int16 units in the thousands.

  // space=mesh: the mesh's own units, in every flat format alike.
  auto js_mesh = Client().Get(q + "&format=json&space=mesh");
  auto f32_mesh = Client().Get(q + "&format=f32&space=mesh");
  ASSERT_TRUE(js_mesh && f32_mesh);
  json mesh_doc = Body(js_mesh);
  EXPECT_EQ(mesh_doc["space"], "mesh");
  const float first = mesh_doc["primitives"][0]["positions"][0].get<float>();
  float first_f32;
  std::memcpy(&first_f32, f32_mesh->body.data(), 4);
  EXPECT_EQ(first, first_f32);
  EXPECT_GT(std::fabs(first), 100.0f);  // Quantized units.
  EXPECT_NE(js_mesh->get_header_value("ETag"), js->get_header_value("ETag"));

  // Fit takes the JSON as the mesh route writes it, in either space.
  for (const json* target : {&doc, &mesh_doc}) {
    auto fit =
        Client().Post("/v1/rigs/facecap/fit", json{{"target", *target}}.dump(), "application/json");
    ASSERT_TRUE(fit);
    ASSERT_EQ(fit->status, 200) << fit->body;
    EXPECT_NEAR(Body(fit)["weights"]["jawOpen"].get<double>(), 0.6, 1e-3) << (*target)["space"];
  }
}

TEST_F(ApiTest, HeadCarriesGetsHeaders) {
  auto get = Client().Get("/v1/rigs/facecap/mesh?format=f32&w.jawOpen=0.25");
  auto head = Client().Head("/v1/rigs/facecap/mesh?format=f32&w.jawOpen=0.25");
  ASSERT_TRUE(get && head);
  EXPECT_EQ(head->status, 200);
  for (const char* name : {"Cache-Control", "Content-Type", "ETag", "Content-Length"}) {
    EXPECT_EQ(head->get_header_value(name), get->get_header_value(name)) << name;
  }
  EXPECT_EQ(get->get_header_value("Cache-Control"), "public, no-cache");
}

}  // namespace api_test
}  // namespace facespace
