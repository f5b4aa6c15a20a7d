#include "facespace/batch/queue.h"

#include <fcntl.h>
#include <openssl/rand.h>
#include <sys/file.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "facespace/batch/run.h"
#include "facespace/files/durable.h"

namespace facespace::batch {

namespace fs = std::filesystem;
using nlohmann::json;

std::string NewJobId() {
  unsigned char bytes[16];
  if (RAND_bytes(bytes, sizeof bytes) != 1) {
    std::random_device rd;
    for (unsigned char& b : bytes) b = static_cast<unsigned char>(rd());
  }
  static const char* hex = "0123456789abcdef";
  std::string id;
  for (unsigned char b : bytes) {
    id += hex[b >> 4];
    id += hex[b & 15];
  }
  return id;
}

std::string NowRfc3339() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

namespace {

// path, durably (temporary name, fsync, rename, folder fsync).
Status WriteJobFile(const fs::path& path, const std::string& text) {
  const std::string name = path.filename().string();
  return files::WriteFileDurably(path.parent_path(), name, text, ".tmp-" + name, "'" + name + "'");
}

std::string ReadText(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

size_t ManifestLines(const fs::path& path) {
  std::ifstream f(path);
  size_t n = 0;
  std::string line;
  while (std::getline(f, line)) n += !line.empty() && line.back() == '}';
  return n;
}

constexpr char kClaim[] = ".claim";
constexpr char kCancel[] = "cancel";

// True when some process (this one included, through another open file) holds the job's claim.
bool ClaimHeld(const fs::path& folder) {
  const int fd = ::open((folder / kClaim).c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool held = ::flock(fd, LOCK_SH | LOCK_NB) != 0;
  ::close(fd);
  return held;
}

// What a claim says: the instance running the job, then (once it runs) its rate, for the others
// to show ("host:pid\nrate=12.5\n"). Written over the old text, then cut to its length, so a
// reader never finds the file empty: at worst it sees the new text and the old one's tail, after
// the rate's newline.
void WriteClaim(int fd, const std::string& text) {
  if (::pwrite(fd, text.data(), text.size(), 0) == static_cast<ssize_t>(text.size())) {
    [[maybe_unused]] int r = ::ftruncate(fd, static_cast<off_t>(text.size()));
  }
}

// The rate a claim says, or 0.
double ClaimRate(const fs::path& folder) {
  const std::string text = ReadText(folder / kClaim);
  const size_t at = text.find("\nrate=");
  return at == std::string::npos ? 0.0 : std::atof(text.c_str() + at + 6);
}

// The claim on a job: an exclusive lock on its .claim file, held until closed (or the process
// dies). -1 when another process holds it or the folder is gone.
int TakeClaim(const fs::path& folder, const std::string& instance) {
  const int fd = ::open((folder / kClaim).c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return -1;
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd);
    return -1;
  }
  WriteClaim(fd, instance + "\n");
  return fd;
}

std::string InstanceName() {
  char host[256] = {0};
  if (::gethostname(host, sizeof host - 1) != 0) std::snprintf(host, sizeof host, "localhost");
  return std::string(host) + ":" + std::to_string(::getpid());
}

// Seconds since the file was last written (large when it is not there).
double AgeSeconds(const fs::path& path) {
  std::error_code ec;
  const auto t = fs::last_write_time(path, ec);
  if (ec) return 1e9;
  return std::chrono::duration<double>(fs::file_time_type::clock::now() - t).count();
}

// What a job makes, as its plan says (Submit writes it to job.json's "output"): its files' format
// (a labelled sample's picture: png unless the request said), its labels and its archive.
json JobOutput(const BatchPlan& plan) {
  json labels = json::array();
  for (evaluator::Label l : plan.request.dataset.labels) labels.push_back(evaluator::Name(l));
  return {{"format", plan.request.format},
          {"labels", labels},
          {"archive", evaluator::Name(plan.request.dataset.archive)}};
}

// o[key] when it is a string, else `otherwise` (job.json is read as found on disk).
std::string TextAt(const json& o, const char* key, const std::string& otherwise) {
  return o.is_object() && o.contains(key) && o[key].is_string() ? o[key].get<std::string>()
                                                                : otherwise;
}

// A job's "output" (JobOutput's) into `info`; `format`: a job written before there was one, its
// request's.

void ReadJobOutput(const json& output, const std::string& format, JobInfo& info) {
  info.format = TextAt(output, "format", format);
  info.archive = TextAt(output, "archive", "folder");
  info.labels.clear();
  if (output.is_object() && output.contains("labels") && output["labels"].is_array()) {
    for (const json& l : output["labels"]) {
      if (l.is_string()) info.labels.push_back(l.get<std::string>());
    }
  }
}

}  // namespace

bool IsValidJobId(const std::string& id) {
  if (id.size() != 32) return false;
  for (char c : id) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

FileJobQueue::FileJobQueue(std::string dir, evaluator::RigStore& store,
                           const evaluator::Evaluator& evaluator, JobLimits limits,
                           double poll_seconds, std::function<void()> refresh_store)
    : dir_(std::move(dir)),
      store_(store),
      evaluator_(evaluator),
      limits_(limits),
      poll_seconds_(poll_seconds),
      refresh_store_(std::move(refresh_store)),
      instance_(InstanceName()) {}

FileJobQueue::~FileJobQueue() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stopping_ = true;
    if (running_) running_->cancel.store(true);
  }
  cv_.notify_all();
  if (runner_.joinable()) runner_.join();
}

std::shared_ptr<FileJobQueue::Job> FileJobQueue::Load(const std::string& id) const {
  if (!IsValidJobId(id)) return nullptr;
  const fs::path folder = fs::path(dir_) / id;
  json j = json::parse(ReadText(folder / "job.json"), nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains("request") || !j.contains("rig"))
    return nullptr;
  std::error_code ec;
  if (fs::exists(folder / kCancel, ec))
    return nullptr;  // Deleted; the instance running it removes it.
  auto job = std::make_shared<Job>();
  job->info.id = id;
  job->info.rig = j.value("rig", "");
  job->rig_version = j.value("rig_version", "");
  job->info.created = j.value("created", "");
  job->info.total = j.value("total", size_t{0});
  if (j.contains("variant_bytes") && j["variant_bytes"].is_number())
    job->variant_bytes = j["variant_bytes"].get<double>();
  ReadJobOutput(j.contains("output") ? j["output"] : json(), TextAt(j["request"], "format", "glb"),
                job->info);
  job->body = j["request"].dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  job->info.done = ManifestLines(folder / "out" / "manifest.jsonl");
  json st = json::parse(ReadText(folder / "state.json"), nullptr, false);
  if (!st.is_discarded() && st.is_object()) {
    job->info.state = JobState::kFailed;  // A state.json that says no known state: failed.
    if (st.contains("state") && st["state"].is_string())
      ParseEnum(kJobStates, st["state"].get<std::string>(), &job->info.state);
    job->info.error = st.value("error", "");
  } else {
    job->info.state = ClaimHeld(folder) ? JobState::kRunning : JobState::kQueued;
    if (job->info.state == JobState::kRunning) job->info.rate = ClaimRate(folder);
  }
  return job;
}

std::shared_ptr<FileJobQueue::Job> FileJobQueue::RunningHere(const std::string& id) const {
  std::lock_guard<std::mutex> lock(mu_);
  if (running_ && running_->info.id == id && !running_->removed) {
    auto copy = std::make_shared<Job>();
    copy->info = running_->info;
    copy->variant_bytes = running_->variant_bytes;
    return copy;
  }
  return nullptr;
}

std::vector<std::shared_ptr<FileJobQueue::Job>> FileJobQueue::Scan() const {
  std::vector<std::shared_ptr<Job>> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir_, ec)) {
    const std::string id = e.path().filename().string();
    if (!IsValidJobId(id)) continue;
    if (auto here = RunningHere(id)) {
      out.push_back(here);
      continue;
    }
    if (auto job = Load(id)) {
      out.push_back(job);
      continue;
    }
    // A folder that is no job: a deleted one whose runner is gone, or one whose job.json never
    // reached the disk (an instance died in Submit; give a live one time to write it).
    if ((fs::exists(e.path() / kCancel, ec) || AgeSeconds(e.path()) > 60) &&
        !fs::exists(e.path() / ".tmp-job.json", ec)) {
      const int fd = TakeClaim(e.path(), instance_);
      if (fd >= 0) {
        if (!fs::exists(e.path() / "job.json", ec) || fs::exists(e.path() / kCancel, ec))
          fs::remove_all(e.path(), ec);
        ::close(fd);
      }
    }
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a->info.created < b->info.created ||
           (a->info.created == b->info.created && a->info.id < b->info.id);
  });
  return out;
}

Result<size_t> FileJobQueue::Start() {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (!fs::is_directory(dir_))
    return FailedPrecondition("cannot create the jobs folder '" + dir_ + "'");
  // Jobs whose rig went while they were unfinished are lost; the rest resume, here or elsewhere.
  size_t unfinished = 0;
  for (const auto& job : Scan()) {
    if (job->info.state == JobState::kQueued && !RigFor(*job, false)) {
      const int fd = TakeClaim(fs::path(dir_) / job->info.id, instance_);
      if (fd >= 0) {
        if (auto again = Load(job->info.id); again && again->info.state == JobState::kRunning)
          MarkLost(*again);
        ::close(fd);
      }
      continue;
    }
    unfinished += Unfinished(job->info.state);
  }
  runner_ = std::thread([this] {
    for (;;) {
      if (RunNext()) continue;
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait_for(lock, std::chrono::duration<double>(poll_seconds_),
                   [this] { return stopping_ || wake_; });
      if (stopping_) return;
      wake_ = false;
    }
  });
  return unfinished;
}

// About the bytes of one variant's file: images by their pixels (what renders of faces compress
// to, with room), meshes by their vertices.
static size_t VariantBytes(const Rig& rig, const BatchPlan& plan) {
  const evaluator::BatchRequest& r = plan.request;
  if (r.image) {
    const double pixels = static_cast<double>(r.render.render.width) * r.render.render.height;
    double per_pixel = 0.25;  // PNG of a render: 0.17-0.33 bytes a pixel.
    switch (r.image_format) {
      case picture::ImageFormat::kJpeg:
      case picture::ImageFormat::kWebp: per_pixel = 0.1; break;
      case picture::ImageFormat::kTiff: per_pixel = 4; break;
      case picture::ImageFormat::kExr: per_pixel = 8; break;
      default: break;
    }
    // A labelled sample's files beside its picture (FaceCap at 256²: depth 61 KB, normals 63 KB,
    // ids and KEY.json 3 KB: about 2 bytes a pixel), and a tar member's header and padding each.
    if (r.dataset.labelled()) per_pixel += 2.5;
    return static_cast<size_t>(pixels * per_pixel) + (r.dataset.labelled() ? 4096 * 5 : 4096);
  }
  const size_t vertices = rig.vertex_count();
  switch (r.mesh_format) {
    case formats::MeshFormat::kF32: return vertices * 24 + 4096;
    case formats::MeshFormat::kGlb: return vertices * 40 + 65536;
    default: return vertices * 200 + 4096;  // Text: OBJ (FaceCap's 178 bytes a vertex), JSON.
  }
}

namespace {

// "1.2 GB", "35 MB": sizes for people.
std::string Bytes(double b) {
  char text[32];
  std::snprintf(text, sizeof text, b >= 1e9 ? "%.1f GB" : "%.0f MB", b >= 1e9 ? b / 1e9 : b / 1e6);
  return text;
}

struct Disk {
  double free = 0,
         size = 0;  // Bytes: what an unprivileged writer may still use, and the whole filesystem.
};
std::optional<Disk> DiskOf(const std::string& dir) {
  struct statvfs st {};
  if (::statvfs(dir.c_str(), &st) != 0) return std::nullopt;
  return Disk{static_cast<double>(st.f_bavail) * static_cast<double>(st.f_frsize),
              static_cast<double>(st.f_blocks) * static_cast<double>(st.f_frsize)};
}

}  // namespace

double FileJobQueue::KeepFree(double disk_bytes) const {
  return limits_.keep_free > 0 ? static_cast<double>(limits_.keep_free)
                               : std::min(1024.0 * (1 << 20), 0.05 * disk_bytes);
}

Status FileJobQueue::CheckRoom(double need, size_t variants,
                               const std::vector<std::shared_ptr<Job>>& jobs, bool sampled) const {
  const std::optional<Disk> disk = DiskOf(dir_);
  if (!disk) return Status::Ok();  // Unknown: the writes will say.
  double reserved = 0;
  size_t others = 0;
  for (const auto& j : jobs) {
    if (!Unfinished(j->info.state)) continue;
    // What it has still to write: its variants to go at its bytes a variant.
    reserved += static_cast<double>(j->info.total - std::min(j->info.done, j->info.total)) *
                j->variant_bytes;
    ++others;
  }
  const double keep = KeepFree(disk->size);
  if (need + reserved + keep <= disk->free) return Status::Ok();
  const std::string text =
      "the batch would write about " + Bytes(need) + " (" + std::to_string(variants) +
      " variants); the jobs folder has " + Bytes(disk->free) + " free, of which " +
      Bytes(reserved) + " is kept for the " + std::to_string(others) + " unfinished job(s) and " +
      Bytes(keep) + " is kept free (--keep-free-mb)";
  Status s{StatusCode::kStorageFull, text, {}, "storage-full", 0};
  s.fields.push_back(
      {sampled ? "/sample/count" : "/variants", "fewer variants, or a smaller format"});
  return s;
}

Result<JobInfo> FileJobQueue::Submit(std::shared_ptr<const BatchPlan> plan, std::string_view body,
                                     int* retry_after) {
  const std::shared_ptr<const evaluator::StoredRig>& rig = plan->rig;
  if (plan->total > limits_.max_batch) {
    const std::string ptr = plan->request.sampled ? "/sample/count" : "/variants";
    Status s = InvalidArgument(ptr + ": a batch has at most " + std::to_string(limits_.max_batch) +
                               " variants; this one has " + std::to_string(plan->total));
    s.fields.push_back({ptr, "at most " + std::to_string(limits_.max_batch) + " variants"});
    return s;
  }
  // The disk: the variants' estimated bytes must fit in what the jobs folder has free, beside what
  // the unfinished jobs (every instance's) have still to write, with the margin kept.
  const std::vector<std::shared_ptr<Job>> jobs = Scan();
  const double variant_bytes = static_cast<double>(VariantBytes(rig->rig, *plan));
  if (Status s = CheckRoom(variant_bytes * static_cast<double>(plan->total), plan->total, jobs,
                           plan->request.sampled);
      !s.ok())
    return s;
  // The queue is the folder's: every instance's unfinished jobs count.
  size_t active = 0, remaining = 0;
  double rate = 0, wait = 0;
  for (const auto& j : jobs) {
    if (!Unfinished(j->info.state)) continue;
    ++active;
    remaining += j->info.total - std::min(j->info.done, j->info.total);
    if (j->info.rate > 0) {
      rate = j->info.rate;
      wait = (j->info.total - std::min(j->info.done, j->info.total)) / rate;
    }
  }
  if (active >= limits_.max_jobs) {
    // Until the job running here ends, if its rate is known; else a guess.
    *retry_after = static_cast<int>(std::clamp(rate > 0 ? wait : 10.0, 1.0, 3600.0));
    return WithReason(
        ResourceExhausted("the job queue is full (" + std::to_string(active) + " of " +
                          std::to_string(limits_.max_jobs) + " jobs queued or running, " +
                          std::to_string(remaining) + " variants to go)"),
        kJobQueueFull);
  }
  auto job = std::make_shared<Job>();
  job->info.id = NewJobId();
  job->info.rig = rig->id;
  job->info.state = JobState::kQueued;
  const json output = JobOutput(*plan);
  ReadJobOutput(output, plan->request.format, job->info);
  job->info.created = NowRfc3339();
  job->info.total = plan->total;
  job->rig_version = rig->version;
  job->plan = plan;
  job->body = std::string(body);
  const fs::path folder = fs::path(dir_) / job->info.id;
  std::error_code ec;
  fs::create_directories(folder, ec);
  json j = {{"id", job->info.id},
            {"rig", rig->id},
            {"rig_version", rig->version},
            {"created", job->info.created},
            {"total", plan->total},
            {"output", output},
            {"variant_bytes", variant_bytes},
            {"request", json::parse(body, nullptr, false)}};
  Status written =
      ec ? Internal("cannot create the job's folder: " + ec.message())
         : WriteJobFile(folder / "job.json",
                        j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  if (!written.ok()) {
    fs::remove_all(folder, ec);
    return Prefixed(written, "cannot store the job: ");
  }
  {
    // The runner here plans nothing again for a job submitted here.
    std::lock_guard<std::mutex> lock(mu_);
    submitted_[job->info.id] = plan;
    wake_ = true;
  }
  cv_.notify_all();
  return job->info;
}

std::optional<JobInfo> FileJobQueue::Get(const std::string& id) const {
  if (auto here = RunningHere(id)) return here->info;
  auto job = Load(id);
  if (!job) return std::nullopt;
  return job->info;
}

std::vector<JobInfo> FileJobQueue::List() const {
  std::vector<JobInfo> out;
  for (const auto& job : Scan()) out.push_back(job->info);
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a.created > b.created || (a.created == b.created && a.id < b.id);
  });
  return out;
}

Status FileJobQueue::Remove(const std::string& id) {
  if (!IsValidJobId(id) || !Load(id)) return NotFound("no job '" + id + "'");
  const fs::path folder = fs::path(dir_) / id;
  {
    std::lock_guard<std::mutex> lock(mu_);
    submitted_.erase(id);
    if (running_ && running_->info.id == id) {  // The runner deletes the folder when the job stops.
      running_->removed = true;
      running_->cancel.store(true);
      return Status::Ok();
    }
  }
  std::error_code ec;
  const int fd = TakeClaim(folder, instance_);
  if (fd >= 0) {  // Nobody runs it: gone at once.
    fs::remove_all(folder, ec);
    ::close(fd);
    return Status::Ok();
  }
  // Another instance runs it: it sees the mark within a fraction of a second, stops and removes it.
  return WriteJobFile(folder / kCancel, "{}\n");
}

std::string FileJobQueue::Folder(const std::string& id) const {
  return (fs::path(dir_) / id / "out").string();
}

void FileJobQueue::Finish(Job& job, JobState state, const std::string& error) {
  WriteJobFile(fs::path(dir_) / job.info.id / "state.json",
               json{{"state", Name(state)}, {"error", error}}.dump(
                   -1, ' ', false, nlohmann::json::error_handler_t::replace) +
                   "\n");
  std::lock_guard<std::mutex> lock(mu_);
  job.info.state = state;
  job.info.error = error;
}

bool FileJobQueue::RunNext() {
  for (const auto& candidate : Scan()) {
    if (candidate->info.state != JobState::kQueued) continue;
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (stopping_) return false;
    }
    const fs::path folder = fs::path(dir_) / candidate->info.id;
    // A young job whose rig is not in this instance's store yet (uploaded through another, on a
    // shared filesystem slow to show it) waits for it rather than being lost.
    auto rig = RigFor(*candidate, true);
    if (!rig && AgeSeconds(folder / "job.json") < 30) continue;
    // A claim that states a rate had a runner (killed: its lock is gone), though the manifest lines
    // it made may not all be on the disk yet: this is a resumption all the same.
    const bool ran = ClaimRate(folder) > 0;
    const int fd = TakeClaim(folder, instance_);
    if (fd < 0) continue;  // Another instance took it.
    auto job =
        Load(candidate->info
                 .id);  // Again, now that it is ours: it may have ended or been deleted meanwhile.
    if (!job || job->info.state != JobState::kRunning) {
      ::close(fd);
      continue;
    }
    job->info.state = JobState::kRunning;
    {
      std::lock_guard<std::mutex> lock(mu_);
      auto it = submitted_.find(job->info.id);
      if (it != submitted_.end()) {
        job->plan = it->second;
        submitted_.erase(it);
      }
      running_ = job;
    }
    if (!rig) {
      MarkLost(*job);
    } else {
      if (job->info.done > 0 || ran) {
        std::fprintf(stderr, "jobs: resuming job %s (%zu of %zu variants were done)\n",
                     job->info.id.c_str(), job->info.done, job->info.total);
      }
      Run(job, rig, fd);
    }
    {
      std::lock_guard<std::mutex> lock(mu_);
      running_.reset();
    }
    ::close(fd);
    return true;
  }
  return false;
}

std::shared_ptr<const evaluator::StoredRig> FileJobQueue::RigFor(const Job& job,
                                                                 bool refresh) const {
  auto rig = store_.Get(job.info.rig);
  if ((!rig || rig->version != job.rig_version) && refresh && refresh_store_) {
    refresh_store_();
    rig = store_.Get(job.info.rig);
  }
  return rig && rig->version == job.rig_version ? rig : nullptr;
}

void FileJobQueue::MarkLost(Job& job) {
  const bool replaced = store_.Get(job.info.rig) != nullptr;
  Finish(job, JobState::kLost,
         "rig '" + job.info.rig + "' was " + (replaced ? "replaced" : "removed") +
             " while the job was unfinished; " + std::to_string(job.info.done) + " of " +
             std::to_string(job.info.total) + " variants were done");
}

void FileJobQueue::Run(const std::shared_ptr<Job>& job,
                       const std::shared_ptr<const evaluator::StoredRig>& rig, int claim) {
  const fs::path folder = fs::path(dir_) / job->info.id;
  Result<std::shared_ptr<const BatchPlan>> plan = job->plan;
  if (!job->plan) {  // Submitted elsewhere or before a restart: plan the stored request again.
    auto made = MakeBatchPlan(rig, job->body);
    plan = made.ok() ? Result<std::shared_ptr<const BatchPlan>>(
                           std::make_shared<const BatchPlan>(std::move(made.value())))
                     : Result<std::shared_ptr<const BatchPlan>>(made.status());
  }
  if (!plan.ok()) {
    Finish(*job, JobState::kFailed, plan.status().message);
    return;
  }
  RunOptions options;
  options.dir = Folder(job->info.id);
  options.evaluator = &evaluator_;
  options.jobs = limits_.threads;
  options.cancel = &job->cancel;
  double said = -1.0;  // When the rate was last written in the claim, in the run's seconds.
  const std::optional<Disk> at_start = DiskOf(dir_);
  const size_t workers = options.jobs > 0 ? static_cast<size_t>(options.jobs)
                                          : std::max(1u, std::thread::hardware_concurrency());
  options.progress = [this, &job, &folder, claim, &said, &at_start, workers](const Progress& p) {
    std::error_code ec;
    const bool deleted_elsewhere = fs::exists(folder / kCancel, ec);
    // The disk: bytes a variant as measured after the first few (what the disk lost since the
    // start), and a stop, failed, before the margin is passed.
    const std::optional<Disk> read = at_start ? DiskOf(dir_) : std::nullopt;
    const Disk now = read.value_or(Disk{});
    const size_t made = p.done - p.skipped;
    double measured = 0;
    if (read && made >= 8)
      measured = std::max(0.0, at_start->free - now.free) / static_cast<double>(made);
    // The rate, for the instances that do not run the job: once a variant is made, then each
    // second.
    if (p.done > p.skipped && p.seconds > 0 && p.seconds - said >= 1.0) {
      said = p.seconds;
      char text[64];
      std::snprintf(text, sizeof text, "\nrate=%.1f\n", (p.done - p.skipped) / p.seconds);
      WriteClaim(claim, instance_ + text);
    }
    std::lock_guard<std::mutex> lock(mu_);
    job->info.done = p.done;
    job->info.seconds = p.seconds;
    job->info.rate = p.seconds > 0 ? (p.done - p.skipped) / p.seconds : 0.0;
    if (measured > 0) job->variant_bytes = measured;
    // Progress comes a group of files a worker (kGroupFiles) at most; after the stop each worker
    // ends the variant it makes: that much room is kept beside the margin.
    const double in_flight = static_cast<double>(workers * (kGroupFiles + 1)) * job->variant_bytes;
    if (read && job->out_of_room.empty() && now.free < KeepFree(now.size) + in_flight) {
      job->out_of_room = "stopped before the jobs folder's disk passed its margin (" +
                         Bytes(KeepFree(now.size)) +
                         " kept free, --keep-free-mb): " + std::to_string(p.done) + " of " +
                         std::to_string(p.total) + " variants made, and kept";
      job->cancel.store(true);
    }
    if (deleted_elsewhere) {
      job->removed = true;
      job->cancel.store(true);
    }
  };
  auto summary = batch::Run(*plan.value(), options);
  bool removed = false, stopping = false;
  {
    std::error_code ec;
    const bool deleted_elsewhere = fs::exists(folder / kCancel, ec);
    std::lock_guard<std::mutex> lock(mu_);
    removed = job->removed || deleted_elsewhere;
    stopping = stopping_;
  }
  if (removed) {
    std::error_code ec;
    fs::remove_all(folder, ec);
  } else if (!summary.ok()) {
    Finish(*job, JobState::kFailed, summary.status().message);
  } else if (!job->out_of_room.empty()) {
    Finish(*job, JobState::kFailed, job->out_of_room);
  } else if (summary->cancelled) {
    if (!stopping) Finish(*job, JobState::kCancelled, "");
    // Stopping: no state.json, so this instance's next start, or another instance now, resumes it.
  } else {
    Finish(*job, JobState::kDone, "");
  }
}

}  // namespace facespace::batch
