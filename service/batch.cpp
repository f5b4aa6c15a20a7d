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

// One worker's reusable state.
struct Worker {
  BlendContext context;
  BlendedRig blended;
  std::vector<float> weights;
  Pose pose;
  bool posed = false;
  render::Image image;
};

// Evaluates variant `index` and encodes it in the plan's format.
Result<std::string> Produce(const Plan& plan, size_t index, Worker& w, std::vector<Warning>& warnings,
                            const render::RenderOptions& render_options) {
  const Rig& rig = *plan.rig;
  const api::BatchRequest& r = plan.request;
  w.weights.resize(rig.shapes.size());
  VariantWeights(plan, index, w.weights);
  BlendOptions options = r.render.mesh.options;
  options.pose = w.posed ? &w.pose : nullptr;
  warnings = CheckWeights(rig, w.weights, options.mode).warnings;
  if (Status s = EvaluateRig(rig, w.weights, options, w.blended, w.context); !s.ok()) return s;
  if (!r.image) return ExportMesh(rig, w.blended, w.weights, warnings, r.mesh_format);
  if (Status s = render::Render(rig, w.blended, render_options, w.image); !s.ok()) return s;
  return render::Encode(w.image, r.image_format, r.render.quality);
}

}  // namespace

std::string Sha256Hex(std::span<const unsigned char> bytes) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  EVP_Digest(bytes.data(), bytes.size(), md, &len, EVP_sha256(), nullptr);
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < len; ++i) {
    out += hex[md[i] >> 4];
    out += hex[md[i] & 15];
  }
  return out;
}

Result<Plan> MakePlan(const Rig& rig, const std::string& rig_version, std::string_view request_json) {
  auto request = api::ParseBatchRequest(request_json);
  if (!request.ok()) return request.status();
  Plan plan;
  plan.rig = &rig;
  plan.request = std::move(request.value());
  if (plan.request.sampled) {
    auto spec = api::ResolveSampleSpec(rig, plan.request);
    if (!spec.ok()) return spec.status();
    plan.sample = std::move(spec.value());
    plan.total = SampleCount(plan.sample, rig.shapes.size());
  } else {
    for (const auto& v : plan.request.variants) {
      auto w = ResolveWeights(rig, v.weights);
      if (!w.ok()) return w.status();
      plan.weights.push_back(std::move(w.value()));
    }
    plan.total = plan.weights.size();
  }
  // Whatever the pose asks must resolve too.
  std::vector<float> weights;
  Pose pose;
  bool posed = false;
  std::vector<Warning> warnings;
  if (Status s = ResolvePoseAndWeights(rig, {}, plan.request.render.mesh.pose, weights, pose, posed, warnings); !s.ok()) return s;
  json spec = {{"request", json::parse(request_json, nullptr, false)}, {"rig", rig.name}, {"rig_version", rig_version}};
  plan.spec_json = spec.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  return plan;
}

std::string VariantId(const Plan& plan, size_t index) {
  if (!plan.request.sampled && !plan.request.variants[index].id.empty()) return plan.request.variants[index].id;
  char buf[32];
  std::snprintf(buf, sizeof buf, "v%06zu", index);
  return buf;
}

std::string VariantFile(const Plan& plan, size_t index) { return VariantId(plan, index) + "." + plan.request.format; }

void VariantWeights(const Plan& plan, size_t index, std::span<float> out) {
  if (plan.request.sampled) SampleVariant(*plan.rig, plan.sample, index, out);
  else std::copy(plan.weights[index].begin(), plan.weights[index].end(), out.begin());
}

Result<Summary> Run(const Plan& plan, const RunOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  const fs::path dir = options.dir;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir)) return FailedPrecondition("cannot create the output folder '" + options.dir + "'");
  if (options.shards == 0 || options.shard >= options.shards) return InvalidArgument("bad shard");

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

  render::RenderOptions render_options = plan.request.render.render;
  std::ofstream manifest(dir / "manifest.jsonl", std::ios::app | std::ios::binary);
  std::mutex mu;
  std::condition_variable cv;
  std::atomic<size_t> next{0}, finished{0};
  size_t running = 0;  // Workers still in their loop (guarded by mu).
  Status failure;
  int jobs = options.jobs > 0 ? options.jobs : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  jobs = static_cast<int>(std::min<size_t>(static_cast<size_t>(jobs), std::max<size_t>(1, pending.size())));
  auto cancelled = [&] { return options.cancel && options.cancel->load(); };

  auto work = [&] {
    Worker w;
    std::vector<Warning> pose_warnings;
    std::vector<float> ignored;
    if (Status s = ResolvePoseAndWeights(*plan.rig, {}, plan.request.render.mesh.pose, ignored, w.pose, w.posed, pose_warnings); !s.ok()) {
      std::lock_guard<std::mutex> lock(mu);
      failure = s;
      return;
    }
    for (;;) {
      {
        std::lock_guard<std::mutex> lock(mu);
        if (!failure.ok() || cancelled()) break;
      }
      const size_t slot = next.fetch_add(1);
      if (slot >= pending.size()) break;
      const size_t k = pending[slot];
      std::vector<Warning> warnings;
      auto bytes = Produce(plan, k, w, warnings, render_options);
      const std::string file = VariantFile(plan, k);
      if (bytes.ok()) {
        if (Status s = WriteInBatch(dir, file, bytes.value()); !s.ok()) bytes = s;
      }
      std::lock_guard<std::mutex> lock(mu);
      if (!bytes.ok()) {
        if (failure.ok()) failure = Status{bytes.status().code, VariantId(plan, k) + ": " + bytes.status().message, bytes.status().fields};
        break;
      }
      warnings.insert(warnings.end(), pose_warnings.begin(), pose_warnings.end());
      const std::string& b = bytes.value();
      std::string line = "{\"index\":" + std::to_string(k) + ",\"id\":" + json(VariantId(plan, k)).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) +
                         ",\"file\":" + json(file).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + ",\"bytes\":" + std::to_string(b.size()) + ",\"sha256\":\"" +
                         Sha256Hex({reinterpret_cast<const unsigned char*>(b.data()), b.size()}) +
                         "\",\"weights\":" + api::WeightsMapJson(*plan.rig, w.weights) +
                         ",\"warnings\":" + WarningsToJson(warnings) + "}";
      manifest << line << '\n' << std::flush;
      lines[k] = std::move(line);
      ++summary.generated;
      finished.fetch_add(1);
      cv.notify_all();
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
    Worker w;
    std::vector<Warning> ignored_warnings;
    std::vector<float> ignored;
    ResolvePoseAndWeights(*plan.rig, {}, plan.request.render.mesh.pose, ignored, w.pose, w.posed, ignored_warnings);
    render::RenderOptions cell = plan.request.render.render;
    cell.width = cell.height = 256;
    cell.supersample = std::min(cell.supersample, 2);
    std::vector<render::Image> images;
    std::vector<std::string> labels;
    for (size_t k = options.shard; k < plan.total && images.size() < options.sheet_cells; k += options.shards) {
      const Rig& rig = *plan.rig;
      w.weights.resize(rig.shapes.size());
      VariantWeights(plan, k, w.weights);
      BlendOptions o = plan.request.render.mesh.options;
      o.pose = w.posed ? &w.pose : nullptr;
      if (Status s = EvaluateRig(rig, w.weights, o, w.blended, w.context); !s.ok()) return s;
      images.emplace_back();
      if (Status s = render::Render(rig, w.blended, cell, images.back()); !s.ok()) return s;
      labels.push_back(VariantId(plan, k));
    }
    const int columns = images.size() >= 16 ? 4 : static_cast<int>(std::ceil(std::sqrt(static_cast<double>(images.size()))));
    auto png = render::Encode(render::ContactSheet(images, labels, columns, cell.background), render::ImageFormat::kPng);
    if (!png.ok()) return png.status();
    if (Status s = WriteInBatch(dir, "sheet.png", png.value()); !s.ok()) return s;
  }
  SyncDir(dir);
  summary.seconds = elapsed();
  return summary;
}

}  // namespace facespace::batch
