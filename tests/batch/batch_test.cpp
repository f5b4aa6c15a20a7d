// The batch runner in process: the files a run writes are the evaluator's bytes, the manifest
// vouches for each, a rerun resumes, and shards merged give the one-process run's bytes.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "facespace/batch/run.h"
#include "facespace/offscreen/render.h"
#include "test_util.h"

namespace facespace {
namespace batch_test {  // Named: the target is a unity build, its files share one unit.

namespace fs = std::filesystem;
using nlohmann::json;

const std::shared_ptr<const evaluator::StoredRig>& FaceCap() {
  static const auto rig =
      evaluator::Unstored(formats::LoadRigFile(test::Bundled("facecap/facecap.glb")).value(), "v1");
  return rig;
}

const offscreen::NullRenderer kNull;

constexpr char kSampled[] =
    R"({"sample": {"method": "uniform", "count": 7, "seed": 3, "shapes": ["jawOpen", "cheekPuff", "mouthSmile_L"]},
                                "format": "glb"})";

batch::BatchPlan Plan(const char* request) {
  auto plan = batch::MakeBatchPlan(FaceCap(), request);
  EXPECT_TRUE(plan.ok()) << plan.status().message;
  return std::move(plan.value());
}

std::string Read(const fs::path& path) {
  const std::vector<unsigned char> bytes = test::ReadBytes(path.string());
  return std::string(bytes.begin(), bytes.end());
}

std::vector<json> ManifestLines(const fs::path& dir) {
  std::vector<json> lines;
  std::istringstream in(Read(dir / "manifest.jsonl"));
  for (std::string line; std::getline(in, line);) lines.push_back(json::parse(line));
  return lines;
}

Result<batch::Summary> RunInto(const batch::BatchPlan& plan, const evaluator::Evaluator& evaluator,
                               const std::string& dir, size_t shard = 0, size_t shards = 1) {
  batch::RunOptions options;
  options.dir = dir;
  options.evaluator = &evaluator;
  options.jobs = 2;
  options.shard = shard;
  options.shards = shards;
  return batch::Run(plan, options);
}

TEST(BatchPlan, VariantsAreAPureFunctionOfThePlanAndIndex) {
  const batch::BatchPlan plan = Plan(
      R"({"sample": {"method": "uniform", "count": 5, "seed": 7, "shapes": ["jawOpen", "cheekPuff"]},
                                         "format": "json"})");
  EXPECT_EQ(plan.total, 5u);
  EXPECT_EQ(batch::VariantFile(plan, 3), "v000003.json");
  evaluator::ResolvedPoint a, b;
  batch::VariantPoint(plan, 3, a);
  batch::VariantPoint(plan, 1, b);
  batch::VariantPoint(plan, 3, b);  // The same index again, after another: the same point.
  EXPECT_EQ(a.weights, b.weights);
  const evaluator::Evaluator evaluator(kNull);
  evaluator::Workspace ws;
  auto bytes = evaluator.Run(plan.rig, a, plan.output, ws);
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ(bytes->pieces()[0].front(), '{');
  EXPECT_TRUE(bytes->pieces()[1].empty());
  // A bad plan names its field.
  auto bad = batch::MakeBatchPlan(FaceCap(), R"({"sample": {"method": "random", "count": 5}})");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().fields.at(0).pointer, "/sample/method");
}

TEST(BatchRun, FilesAreTheEvaluatorsBytesAndTheManifestVouchesForThem) {
  const test::TempDir dir;
  const batch::BatchPlan plan =
      Plan(R"({"variants": [{"id": "smile", "weights": {"mouthSmile_L": 1, "mouthSmile_R": 1}},
                                                      {"id": "open", "weights": {"jawOpen": 0.8}}], "format": "obj"})");
  const evaluator::Evaluator evaluator(kNull);
  auto summary = RunInto(plan, evaluator, dir.path.string());
  ASSERT_TRUE(summary.ok()) << summary.status().message;
  EXPECT_EQ(summary->generated, 2u);
  EXPECT_EQ(summary->skipped, 0u);
  EXPECT_EQ(Read(dir.path / "batch.json"), plan.spec_json);
  const std::vector<json> lines = ManifestLines(dir.path);
  ASSERT_EQ(lines.size(), 2u);
  evaluator::Workspace ws;
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(lines[k]["index"], k);
    EXPECT_EQ(lines[k]["id"], k == 0 ? "smile" : "open");
    const std::string file = Read(dir.path / lines[k]["file"].get<std::string>());
    EXPECT_EQ(lines[k]["bytes"], file.size());
    const std::string_view piece[] = {file};
    EXPECT_EQ(lines[k]["sha256"], batch::Sha256Hex(piece));
    evaluator::ResolvedPoint point;
    batch::VariantPoint(plan, k, point);
    EXPECT_TRUE(file == evaluator.Run(plan.rig, point, plan.output, ws)->bytes) << k;
  }
  EXPECT_EQ(lines[1]["weights"], json::parse(R"({"jawOpen": 0.8})"));
  EXPECT_TRUE(fs::exists(dir.path / "sheet.png"));
  // No temporary file or lock is left behind.
  for (const auto& e : fs::directory_iterator(dir.path))
    EXPECT_NE(e.path().filename().string().rfind(".fs-tmp-", 0), 0u);
}

TEST(BatchRun, ARerunResumesAndRedoesOnlyWhatIsMissing) {
  const test::TempDir dir;
  const batch::BatchPlan plan = Plan(kSampled);
  const evaluator::Evaluator evaluator(kNull);
  ASSERT_TRUE(RunInto(plan, evaluator, dir.path.string()).ok());
  const std::string manifest = Read(dir.path / "manifest.jsonl");
  const std::string third = Read(dir.path / "v000003.glb");
  auto again = RunInto(plan, evaluator, dir.path.string());
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->generated, 0u);
  EXPECT_EQ(again->skipped, 7u);
  fs::remove(dir.path / "v000003.glb");
  auto redone = RunInto(plan, evaluator, dir.path.string());
  ASSERT_TRUE(redone.ok());
  EXPECT_EQ(redone->generated, 1u);
  EXPECT_EQ(redone->skipped, 6u);
  EXPECT_EQ(Read(dir.path / "v000003.glb"), third);
  EXPECT_EQ(Read(dir.path / "manifest.jsonl"), manifest);  // Sorted by index again at the end.
}

TEST(BatchRun, AFolderHoldsOneBatch) {
  const test::TempDir dir;
  const evaluator::Evaluator evaluator(kNull);
  ASSERT_TRUE(RunInto(Plan(kSampled), evaluator, dir.path.string()).ok());
  auto other = RunInto(Plan(R"({"variants": [{"weights": {"jawOpen": 1}}], "format": "glb"})"),
                       evaluator, dir.path.string());
  ASSERT_FALSE(other.ok());
  EXPECT_EQ(other.status().code, StatusCode::kFailedPrecondition);
  EXPECT_NE(other.status().message.find("another batch"), std::string::npos)
      << other.status().message;
}

TEST(BatchRun, ShardsMergedAreTheOneProcessRun) {
  const test::TempDir whole, sharded;
  const batch::BatchPlan plan = Plan(kSampled);
  const evaluator::Evaluator evaluator(kNull);
  ASSERT_TRUE(RunInto(plan, evaluator, whole.path.string()).ok());
  auto first = RunInto(plan, evaluator, sharded.path.string(), 0, 2);
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(first->total, 4u);  // Variants 0, 2, 4, 6.
  batch::MergeOptions merge;
  merge.dir = sharded.path.string();
  merge.evaluator = &evaluator;
  auto early = batch::Merge(plan, merge);  // Shard 2 has not run: nothing is merged.
  ASSERT_FALSE(early.ok());
  EXPECT_FALSE(fs::exists(sharded.path / "manifest.jsonl"));
  ASSERT_TRUE(RunInto(plan, evaluator, sharded.path.string(), 1, 2).ok());
  auto merged = batch::Merge(plan, merge);
  ASSERT_TRUE(merged.ok()) << merged.status().message;
  EXPECT_EQ(merged->shards, 2u);
  EXPECT_EQ(merged->variants, 7u);
  for (const char* name : {"manifest.jsonl", "sheet.png", "v000000.glb", "v000005.glb"}) {
    EXPECT_EQ(Read(sharded.path / name), Read(whole.path / name)) << name;
  }
  EXPECT_FALSE(fs::exists(sharded.path / "manifest.shard-1-of-2.jsonl"));
}

TEST(BatchRun, ACancelledRunLeavesNoHalfWrittenFile) {
  const test::TempDir dir;
  const batch::BatchPlan plan = Plan(kSampled);
  const evaluator::Evaluator evaluator(kNull);
  std::atomic<bool> cancel{true};
  batch::RunOptions options;
  options.dir = dir.path.string();
  options.evaluator = &evaluator;
  options.cancel = &cancel;
  auto summary = batch::Run(plan, options);
  ASSERT_TRUE(summary.ok());
  EXPECT_TRUE(summary->cancelled);
  const std::vector<json> lines = ManifestLines(dir.path);
  for (const auto& e : fs::directory_iterator(dir.path)) {
    const std::string name = e.path().filename().string();
    EXPECT_NE(name.rfind(".fs-tmp-", 0), 0u) << name;
    if (e.path().extension() == ".glb") {  // Every variant file there is in the manifest.
      EXPECT_TRUE(std::any_of(lines.begin(), lines.end(), [&](const json& l) {
        return l["file"] == name;
      })) << name;
    }
  }
}

}  // namespace batch_test
}  // namespace facespace
