// The on-disk job queue in process: a submitted job runs to done, another instance over the same
// folder says the same, a full queue refuses with a wait, and a removed job leaves nothing.
#include "facespace/batch/queue.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <thread>

#include "facespace/offscreen/render.h"
#include "memory_store.h"
#include "test_util.h"

namespace facespace {
namespace queue_test {  // Named: the target is a unity build, its files share one unit.

namespace fs = std::filesystem;

const offscreen::NullRenderer kNull;

// The job's state once it has left "queued" and "running" (or after `seconds`).
batch::JobInfo WaitForEnd(const batch::JobQueue& queue, const std::string& id,
                          double seconds = 60) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (;;) {
    auto info = queue.Get(id);
    if (!info) return {};
    if (!batch::Unfinished(info->state) || std::chrono::steady_clock::now() > until) return *info;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

std::shared_ptr<const batch::BatchPlan> Plan(const evaluator::RigStore& store,
                                             const std::string& body) {
  auto plan = batch::MakeBatchPlan(store.Get("facecap"), body);
  EXPECT_TRUE(plan.ok()) << plan.status().message;
  return std::make_shared<const batch::BatchPlan>(std::move(plan.value()));
}

// A jobs folder, a store with FaceCap, and the evaluator the queues run jobs with.
class JobQueue : public ::testing::Test {
 protected:
  JobQueue() { store.Seed(); }
  const test::TempDir dir;
  test::MemoryStore store;
  const evaluator::Evaluator evaluator{kNull};
};

constexpr char kBody[] =
    R"({"sample": {"method": "uniform", "count": 6, "seed": 1, "shapes": ["jawOpen"]}, "format": "f32"})";

TEST_F(JobQueue, ASubmittedJobRunsToDoneAndEveryInstanceSaysSo) {
  batch::JobLimits limits;
  limits.threads = 2;
  batch::FileJobQueue queue(dir.path.string(), store, evaluator, limits, 0.05);
  ASSERT_TRUE(queue.Start().ok());
  int retry_after = 0;
  auto job = queue.Submit(Plan(store, kBody), kBody, &retry_after);
  ASSERT_TRUE(job.ok()) << job.status().message;
  EXPECT_TRUE(batch::IsValidJobId(job->id));
  EXPECT_EQ(job->rig, "facecap");
  EXPECT_EQ(job->total, 6u);
  const batch::JobInfo done = WaitForEnd(queue, job->id);
  EXPECT_EQ(done.state, batch::JobState::kDone) << done.error;
  EXPECT_EQ(done.done, 6u);
  const fs::path folder = queue.Folder(job->id);
  for (const char* name : {"manifest.jsonl", "v000000.f32", "v000005.f32", "sheet.png"})
    EXPECT_TRUE(fs::exists(folder / name)) << name;
  // FaceCap's f32 body: positions and normals of every vertex.
  EXPECT_EQ(fs::file_size(folder / "v000000.f32"), store.Get("facecap")->rig.vertex_count() * 24);

  // Another instance over the folder (a restart, or a second server) reads the same.
  batch::FileJobQueue other(dir.path.string(), store, evaluator, limits, 0.05);
  auto started = other.Start();
  ASSERT_TRUE(started.ok());
  EXPECT_EQ(started.value(), 0u);  // Nothing unfinished.
  auto seen = other.Get(job->id);
  ASSERT_TRUE(seen.has_value());
  EXPECT_EQ(seen->state, batch::JobState::kDone);
  ASSERT_EQ(other.List().size(), 1u);

  ASSERT_TRUE(other.Remove(job->id).ok());
  EXPECT_FALSE(queue.Get(job->id).has_value());
  EXPECT_FALSE(fs::exists(folder));
  EXPECT_EQ(queue.Remove(job->id).code, StatusCode::kNotFound);
  EXPECT_EQ(queue.Remove("../../etc").code, StatusCode::kNotFound);  // Never a path.
}

TEST_F(JobQueue, LimitsRefuseWithTheFieldOrAWait) {
  batch::JobLimits limits;
  limits.max_jobs = 1;
  limits.max_batch = 5;
  // Not started: a job submitted stays queued, so the queue is full.
  batch::FileJobQueue queue(dir.path.string(), store, evaluator, limits, 60);
  int retry_after = 0;
  auto big = queue.Submit(Plan(store, kBody), kBody, &retry_after);  // 6 variants, 5 allowed.
  ASSERT_FALSE(big.ok());
  EXPECT_EQ(big.status().code, StatusCode::kInvalidArgument);
  EXPECT_EQ(big.status().fields.at(0).pointer, "/sample/count");
  const std::string small = R"({"variants": [{"weights": {"jawOpen": 1}}], "format": "json"})";
  ASSERT_TRUE(queue.Submit(Plan(store, small), small, &retry_after).ok());
  auto full = queue.Submit(Plan(store, small), small, &retry_after);
  ASSERT_FALSE(full.ok());
  EXPECT_EQ(full.status().reason, batch::kJobQueueFull);
  EXPECT_GE(retry_after, 1);
  ASSERT_EQ(queue.List().size(), 1u);
  EXPECT_EQ(queue.List()[0].state, batch::JobState::kQueued);
}

TEST_F(JobQueue, AJobLeftUnfinishedResumesInTheNextInstance) {
  std::string id;
  {
    // Submitted to an instance that stops before running it (as a restart would).
    batch::FileJobQueue stopped(dir.path.string(), store, evaluator, {}, 60);
    int retry_after = 0;
    auto job = stopped.Submit(Plan(store, kBody), kBody, &retry_after);
    ASSERT_TRUE(job.ok());
    id = job->id;
  }
  batch::FileJobQueue next(dir.path.string(), store, evaluator, {}, 0.05);
  auto started = next.Start();
  ASSERT_TRUE(started.ok());
  EXPECT_EQ(started.value(), 1u);
  const batch::JobInfo done = WaitForEnd(next, id);  // Planned again from the stored request.
  EXPECT_EQ(done.state, batch::JobState::kDone) << done.error;
  EXPECT_EQ(done.done, 6u);
}

}  // namespace queue_test
}  // namespace facespace
