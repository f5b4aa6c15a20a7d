#include "batch.h"
#include "durable.h"

#include <openssl/evp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "facespace/core/blend.h"
#include "facespace/core/io.h"
#include "facespace/core/skeleton.h"
#include "facespace/core/weights.h"
#include "facespace/render/render.h"

namespace facespace::batch {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr char kTmpPrefix[] = ".fs-tmp-";

// dir/name, durably; the folder itself is synced once at the end of the run.
Status WriteInBatch(const fs::path& dir, const std::string& name, std::string_view data) {
  return WriteFileDurably(dir, name, data, kTmpPrefix + name, "'" + name + "'", false);
}

}  // namespace

std::string Sha256Hex(std::span<const std::string_view> pieces) {
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr);
  for (std::string_view p : pieces) EVP_DigestUpdate(ctx, p.data(), p.size());
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  EVP_DigestFinal_ex(ctx, md, &len);
  EVP_MD_CTX_free(ctx);
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < len; ++i) {
    out += hex[md[i] >> 4];
    out += hex[md[i] & 15];
  }
  return out;
}

using api::VariantFile;
using api::VariantId;

Result<Summary> Run(const api::BatchPlan& plan, const RunOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  const fs::path dir = options.dir;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir)) return FailedPrecondition("cannot create the output folder '" + options.dir + "'");
  if (options.shards == 0 || options.shard >= options.shards) return InvalidArgument("bad shard");
  if (!options.renderer) return InvalidArgument("no renderer");
  const render::Renderer& renderer = *options.renderer;

  // The folder belongs to one batch: the same request against the same rig.
  const fs::path spec_path = dir / "batch.json";
  if (fs::exists(spec_path)) {
    std::ifstream f(spec_path, std::ios::binary);
    std::string old((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    if (old != plan.spec_json) {
      return FailedPrecondition("'" + options.dir + "' holds another batch (its batch.json differs from this request or rig): "
                                "use another output folder, or empty this one");
    }
  } else if (Status s = WriteInBatch(dir, "batch.json", plan.spec_json); !s.ok()) {
    return s;
  }
  // Leftovers of a run that was killed: temporary files are never complete.
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.path().filename().string().rfind(kTmpPrefix, 0) == 0) fs::remove(e.path(), ec);
  }

  // Resume: a manifest line whose file is there with its size is done. A torn last line
  // (killed mid-write) or a line for a missing file is dropped and its variant redone.
  std::map<size_t, std::string> lines;
  {
    std::ifstream f(dir / "manifest.jsonl");
    std::string line;
    while (std::getline(f, line)) {
      json j = json::parse(line, nullptr, false);
      if (j.is_discarded() || !j.is_object() || !j.contains("index") || !j["index"].is_number_unsigned() ||
          !j.contains("file") || !j["file"].is_string() || !j.contains("bytes") || !j["bytes"].is_number_unsigned()) {
        continue;
      }
      const size_t index = j["index"].get<size_t>();
      if (index >= plan.total || j["file"].get<std::string>() != VariantFile(plan, index)) continue;
      const fs::path file = dir / j["file"].get<std::string>();
      if (fs::is_regular_file(file, ec) && fs::file_size(file, ec) == j["bytes"].get<uint64_t>()) lines[index] = line;
    }
  }
  auto write_manifest = [&] {
    std::string text;
    for (const auto& [index, line] : lines) text += line + "\n";
    return WriteInBatch(dir, "manifest.jsonl", text);
  };
  if (Status s = write_manifest(); !s.ok()) return s;

  std::vector<size_t> pending;
  Summary summary;
  for (size_t k = options.shard; k < plan.total; k += options.shards) {
    ++summary.total;
    if (lines.count(k)) ++summary.skipped;
    else pending.push_back(k);
  }

  std::ofstream manifest(dir / "manifest.jsonl", std::ios::app | std::ios::binary);
  std::mutex mu;
  std::condition_variable cv;
  std::atomic<size_t> next{0}, finished{0};
  size_t running = 0;  // Workers still in their loop (guarded by mu).
  Status failure;
  int jobs = options.jobs > 0 ? options.jobs : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  jobs = static_cast<int>(std::min<size_t>(static_cast<size_t>(jobs), std::max<size_t>(1, pending.size())));
  auto cancelled = [&] { return options.cancel && options.cancel->load(); };

  // Each worker writes its variants to temporary files and flushes them in groups: the files of a
  // group are flushed and renamed, and only then do their manifest lines go in, so resume never
  // trusts a file the manifest does not vouch for, and the disk is not waited on once per file.
  struct Written {
    size_t index;
    int fd;
    std::string file, line;
  };
  constexpr size_t kGroupFiles = 32;
  constexpr auto kGroupAge = std::chrono::milliseconds(250);
  auto work = [&] {
    api::VariantEncoder encoder;
    api::Point point;
    std::vector<Written> group;
    auto group_started = std::chrono::steady_clock::now();
    // Publishes the group; the lines of the files published go into the manifest.
    auto flush = [&]() -> Status {
      Status failed;
      size_t published = 0;
      for (Written& w : group) {
        if (!failed.ok()) {
          Discard(w.fd, dir, kTmpPrefix + w.file);
          continue;
        }
        failed = Publish(w.fd, dir, kTmpPrefix + w.file, w.file, "'" + w.file + "'");
        if (failed.ok()) ++published;
      }
      {
        std::lock_guard<std::mutex> lock(mu);
        for (size_t i = 0; i < published; ++i) {
          manifest << group[i].line << '\n';
          lines[group[i].index] = std::move(group[i].line);
        }
        manifest << std::flush;
        summary.generated += published;
      }
      finished.fetch_add(published);
      cv.notify_all();
      group.clear();
      return failed;
    };
    Status status;
    for (;;) {
      {
        std::lock_guard<std::mutex> lock(mu);
        if (!failure.ok() || cancelled()) break;
      }
      const size_t slot = next.fetch_add(1);
      if (slot >= pending.size()) break;
      const size_t k = pending[slot];
      api::VariantPoint(plan, k, point);
      auto pieces = api::EncodeVariant(plan, point, renderer, encoder);
      const std::string file = VariantFile(plan, k);
      Result<int> fd = pieces.ok() ? WriteTemporary(dir, kTmpPrefix + file, pieces.value(), "'" + file + "'") : pieces.status();
      if (!fd.ok()) {
        status = Prefixed(fd.status(), VariantId(plan, k) + ": ");
        break;
      }
      size_t bytes = 0;
      for (std::string_view p : pieces.value()) bytes += p.size();
      if (group.empty()) group_started = std::chrono::steady_clock::now();
      group.push_back({k, fd.value(), file,
                       "{\"index\":" + std::to_string(k) + ",\"id\":" + json(VariantId(plan, k)).dump(-1, ' ', false, json::error_handler_t::replace) +
                           ",\"file\":" + json(file).dump(-1, ' ', false, json::error_handler_t::replace) + ",\"bytes\":" + std::to_string(bytes) +
                           ",\"sha256\":\"" + Sha256Hex(pieces.value()) + "\",\"weights\":" + api::WeightsMapJson(*plan.rig, point.weights) +
                           ",\"warnings\":" + WarningsToJson(point.report.warnings) + "}"});
      if (group.size() >= kGroupFiles || std::chrono::steady_clock::now() - group_started >= kGroupAge) {
        if (status = flush(); !status.ok()) break;
      }
    }
    if (Status s = flush(); status.ok()) status = s;
    if (!status.ok()) {
      std::lock_guard<std::mutex> lock(mu);
      if (failure.ok()) failure = status;
    }
  };
  auto run_worker = [&] {
    work();
    std::lock_guard<std::mutex> lock(mu);
    --running;
    cv.notify_all();
  };

  std::vector<std::thread> threads;
  running = pending.empty() ? 0 : static_cast<size_t>(jobs);
  for (size_t t = 0; t < running; ++t) threads.emplace_back(run_worker);
  auto report = [&] {
    if (options.progress) options.progress({summary.skipped + finished.load(), summary.skipped, summary.total, elapsed()});
  };
  {
    std::unique_lock<std::mutex> lock(mu);
    while (running > 0) {
      lock.unlock();
      report();
      lock.lock();
      cv.wait_for(lock, std::chrono::milliseconds(200));
    }
  }
  for (std::thread& t : threads) t.join();
  manifest.close();
  summary.cancelled = cancelled();
  report();
  const Status written = write_manifest();
  if (!failure.ok()) return failure;
  if (!written.ok()) return written;

  // The contact sheet of this shard's first variants, once they all exist.
  if (!summary.cancelled && options.sheet_cells > 0 && summary.total > 0 && !fs::exists(dir / "sheet.png")) {
    std::vector<size_t> first;
    for (size_t k = options.shard; k < plan.total && first.size() < options.sheet_cells; k += options.shards) first.push_back(k);
    api::Workspace ws;
    auto png = api::VariantSheet(plan, first, renderer, ws);
    if (!png.ok()) return png.status();
    if (Status s = WriteInBatch(dir, "sheet.png", png.value()); !s.ok()) return s;
  }
  SyncDir(dir);
  summary.seconds = elapsed();
  return summary;
}

}  // namespace facespace::batch
