// Group commit (facespace/files/durable.h, PublishGroup): many temporaries made durable with one
// sync and published in order; a failure publishes the files before it and removes it and every one
// after.
#include "facespace/files/durable.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace facespace {
namespace durable_test {

namespace fs = std::filesystem;

fs::path Scratch(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("fs-durable-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string Read(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

std::vector<files::PendingFile> Temporaries(const fs::path& dir, int count) {
  std::vector<files::PendingFile> pending;
  for (int i = 0; i < count; ++i) {
    const std::string name = "v" + std::to_string(i) + ".txt", tmp = ".fs-tmp-" + name,
                      body = "variant " + std::to_string(i);
    const std::string_view pieces[] = {body, "\n"};
    Result<int> fd = files::WriteTemporary(dir, tmp, pieces, "'" + name + "'");
    EXPECT_TRUE(fd.ok()) << fd.status().message;
    pending.push_back({fd.value(), tmp, name, "'" + name + "'"});
  }
  return pending;
}

size_t Temporaries(const fs::path& dir) {
  size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir))
    n += e.path().filename().string().starts_with(".fs-tmp-");
  return n;
}

TEST(PublishGroup, EveryFileOfTheGroupIsPublishedWholeUnderItsName) {
  const fs::path dir = Scratch("all");
  std::vector<files::PendingFile> pending = Temporaries(dir, 40);
  const files::GroupResult r = PublishGroup(dir, pending);
  EXPECT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_EQ(r.published, 40u);
  for (int i = 0; i < 40; ++i)
    EXPECT_EQ(Read(dir / ("v" + std::to_string(i) + ".txt")),
              "variant " + std::to_string(i) + "\n");
  EXPECT_EQ(Temporaries(dir), 0u);
  fs::remove_all(dir);
}

TEST(PublishGroup, AFailedRenamePublishesThoseBeforeItAndRemovesTheRest) {
  const fs::path dir = Scratch("fail");
  fs::create_directories(dir / "v3.txt" /
                         "inside");  // A folder in the way of the fourth file: its rename fails.
  std::vector<files::PendingFile> pending = Temporaries(dir, 6);
  const files::GroupResult r = PublishGroup(dir, pending);
  EXPECT_FALSE(r.status.ok());
  EXPECT_NE(r.status.message.find("cannot publish 'v3.txt'"), std::string::npos)
      << r.status.message;
  EXPECT_EQ(r.published, 3u);
  for (int i = 0; i < 3; ++i)
    EXPECT_TRUE(fs::is_regular_file(dir / ("v" + std::to_string(i) + ".txt"))) << i;
  for (int i = 4; i < 6; ++i)
    EXPECT_FALSE(fs::exists(dir / ("v" + std::to_string(i) + ".txt"))) << i;
  EXPECT_EQ(Temporaries(dir), 0u);
  fs::remove_all(dir);
}

}  // namespace durable_test
}  // namespace facespace
