// The file rig store (service/store/rig_store.h) on a real folder: uploads persist and read back, a
// broken or oversized upload leaves nothing behind, another process's changes are seen on refresh,
// and the bundled (read-only) rigs are served but never written.
#include "store/rig_store.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using facespace::FileRigStore;
using facespace::StatusCode;
using facespace::formats::RigFormat;

std::vector<unsigned char> FaceCapBytes() {
  std::ifstream f(std::string(FACESPACE_SOURCE_DIR) + "/assets/facecap/facecap.glb",
                  std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// A fresh folder of its own, removed after the test.
struct TempDir {
  fs::path path;
  TempDir() {
    char tmpl[] = "/tmp/facespace_store_test_XXXXXX";
    path = mkdtemp(tmpl);
  }
  ~TempDir() { fs::remove_all(path); }
  std::vector<std::string> Files() const {
    std::vector<std::string> names;
    for (const auto& e : fs::recursive_directory_iterator(path)) {
      if (e.is_regular_file()) names.push_back(e.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
  }
};

TEST(FileRigStore, AnUploadIsServedAndAFreshStoreReadsItBack) {
  TempDir dir;
  FileRigStore store(dir.path.string());
  ASSERT_TRUE(store.LoadAll().ok());
  EXPECT_EQ(store.Get("face"), nullptr);
  bool created = false;
  const std::vector<unsigned char> bytes = FaceCapBytes();
  ASSERT_TRUE(store.Put("face", bytes, RigFormat::kGlb, "", &created).ok());
  EXPECT_TRUE(created);
  auto rig = store.Get("face");
  ASSERT_NE(rig, nullptr);
  EXPECT_EQ(rig->rig.shapes.size(), 52u);
  EXPECT_EQ(rig->rig.vertex_count(), 4368u);
  EXPECT_FALSE(rig->version.empty());
  ASSERT_TRUE(store.Put("face", bytes, RigFormat::kGlb, "", &created).ok());
  EXPECT_FALSE(created);                                // The same id again replaces it.
  EXPECT_EQ(store.Get("face")->version, rig->version);  // Same bytes, same version.

  FileRigStore again(dir.path.string());
  auto loaded = again.LoadAll();
  ASSERT_TRUE(loaded.ok());
  EXPECT_EQ(loaded.value(), 1u);
  ASSERT_NE(again.Get("face"), nullptr);
  EXPECT_EQ(again.Get("face")->version, rig->version);
}

TEST(FileRigStore, ABrokenUploadLeavesNothingBehind) {
  TempDir dir;
  FileRigStore store(dir.path.string());
  ASSERT_TRUE(store.LoadAll().ok());
  std::vector<unsigned char> bytes = FaceCapBytes();
  bytes.resize(bytes.size() / 2);  // Truncated.
  bool created = false;
  const auto status = store.Put("half", bytes, RigFormat::kGlb, "", &created);
  EXPECT_FALSE(status.ok());
  EXPECT_EQ(status.code, StatusCode::kInvalidArgument) << status.message;
  EXPECT_EQ(store.Get("half"), nullptr);
  EXPECT_TRUE(dir.Files().empty());  // No temporary, no half file.
}

TEST(FileRigStore, UploadsOverTheLimitsAreRefusedBeforeAnythingIsStored) {
  TempDir dir;
  FileRigStore store(dir.path.string());
  store.SetUploadLimits(1000, 1000);  // FaceCap has 4,368 vertices.
  ASSERT_TRUE(store.LoadAll().ok());
  bool created = false;
  const auto status = store.Put("face", FaceCapBytes(), RigFormat::kGlb, "", &created);
  EXPECT_EQ(status.code, StatusCode::kResourceExhausted) << status.message;
  EXPECT_NE(status.message.find("at most 1000"), std::string::npos) << status.message;
  EXPECT_EQ(store.Get("face"), nullptr);
  EXPECT_TRUE(dir.Files().empty());
}

TEST(FileRigStore, AnotherProcessesChangesAreSeenOnRefresh) {
  TempDir dir;
  FileRigStore writer(dir.path.string()), reader(dir.path.string());
  ASSERT_TRUE(writer.LoadAll().ok());
  ASSERT_TRUE(reader.LoadAll().ok());
  bool created = false;
  ASSERT_TRUE(writer.Put("face", FaceCapBytes(), RigFormat::kGlb, "", &created).ok());
  EXPECT_EQ(reader.Get("face"), nullptr);  // Until it looks again.
  auto changes = reader.Refresh();
  ASSERT_TRUE(changes.ok());
  EXPECT_EQ(changes->added, std::vector<std::string>{"face"});
  ASSERT_NE(reader.Get("face"), nullptr);

  auto unchanged = reader.Refresh();
  ASSERT_TRUE(unchanged.ok());
  EXPECT_TRUE(unchanged->added.empty() && unchanged->replaced.empty() &&
              unchanged->removed.empty());

  ASSERT_TRUE(writer.Delete("face").ok());
  changes = reader.Refresh();
  ASSERT_TRUE(changes.ok());
  EXPECT_EQ(changes->removed, std::vector<std::string>{"face"});
  EXPECT_EQ(reader.Get("face"), nullptr);
}

TEST(FileRigStore, BundledRigsAreServedButNeverWritten) {
  TempDir uploads, bundled;
  const fs::path original = bundled.path / "facecap.glb";
  fs::copy_file(std::string(FACESPACE_SOURCE_DIR) + "/assets/facecap/facecap.glb", original);
  FileRigStore store(uploads.path.string(), {bundled.path.string()});
  ASSERT_TRUE(store.LoadAll().ok());
  ASSERT_NE(store.Get("facecap"), nullptr);
  const auto size = fs::file_size(original);

  bool created = false;
  std::vector<unsigned char> other = FaceCapBytes();
  auto status = store.Put("facecap", other, RigFormat::kGlb, "", &created);
  EXPECT_EQ(status.code, StatusCode::kFailedPrecondition) << status.message;
  EXPECT_NE(status.message.find("read-only"), std::string::npos) << status.message;
  status = store.Delete("facecap");
  EXPECT_EQ(status.code, StatusCode::kFailedPrecondition) << status.message;
  EXPECT_TRUE(fs::exists(original));
  EXPECT_EQ(fs::file_size(original), size);
  EXPECT_TRUE(uploads.Files().empty());
  ASSERT_NE(store.Get("facecap"), nullptr);

  // Another id is an upload like any other.
  ASSERT_TRUE(store.Put("mine", other, RigFormat::kGlb, "", &created).ok());
  EXPECT_EQ(uploads.Files(), std::vector<std::string>{"mine.glb"});
}

}  // namespace
