// The content-addressed reference cache and the frame loop that fills it (reference.h).
#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <bit>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <system_error>

#include "io/clock.h"
#include "photonbench/error.h"
#include "reference/reference.h"

namespace pb::trace {
namespace {

// 128-bit content digest: FNV-1a 64 and a second, independently mixed 64-bit lane. Not
// cryptographic; it only has to tell scenes apart.
class Digest {
 public:
  void bytes(const void* data, size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i) {
      a_ = (a_ ^ p[i]) * 0x100000001b3ull;
      b_ = (b_ ^ (p[i] + 0x9e3779b97f4a7c15ull)) * 0xff51afd7ed558ccdull;
      b_ ^= b_ >> 31;
    }
  }
  template <class T>
  void value(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes(&v, sizeof(T));
  }
  void text(std::string_view s) {
    value(uint64_t(s.size()));
    bytes(s.data(), s.size());
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    value(uint64_t(v.size()));
    if (!v.empty()) bytes(v.data(), v.size() * sizeof(T));
  }
  std::string hex() const { return fmt::format("{:016x}{:016x}", a_, b_); }

 private:
  uint64_t a_ = 0xcbf29ce484222325ull, b_ = 0x84222325cbf29ce4ull;
};

std::string read_file_bytes(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void write_atomic(const std::filesystem::path& file, const std::string& content) {
  std::filesystem::path tmp = file;
  tmp += fmt::format(".tmp{}", std::chrono::steady_clock::now().time_since_epoch().count());
  {
    std::ofstream out(tmp, std::ios::binary);
    out << content;
    if (!out) throw Error(fmt::format("cannot write {}", tmp.string()));
  }
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec)
    throw Error(
        fmt::format("cannot rename {} to {}: {}", tmp.string(), file.string(), ec.message()));
}

std::string now_iso() {
  std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

std::optional<nlohmann::json> read_sidecar(const std::filesystem::path& file) {
  std::error_code ec;
  if (!std::filesystem::exists(file, ec)) return std::nullopt;
  try {
    return nlohmann::json::parse(read_file_bytes(file));
  } catch (const std::exception&) {
    return std::nullopt;  // a damaged sidecar is a missing entry: render again
  }
}

// An exclusive lock on a file, held for the object's life and removed with it, so that the cache
// holds only its entries. flock is released by the kernel when the process ends: a crashed holder
// leaves a file but no lock. A waiter that wins the lock on a file its holder has just removed
// (and that a newcomer may have created again) retries on the file now at the path.
class FrameLock {
 public:
  explicit FrameLock(std::filesystem::path file) : file_(std::move(file)) {
    for (;;) {
      fd_ = ::open(file_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
      if (fd_ < 0)
        throw Error(
            fmt::format("cannot open the lock {}: {}", file_.string(), std::strerror(errno)));
      while (::flock(fd_, LOCK_EX) != 0)
        if (errno != EINTR)
          throw Error(fmt::format("cannot lock {}: {}", file_.string(), std::strerror(errno)));
      struct stat held, at_path;
      if (::fstat(fd_, &held) == 0 && ::stat(file_.c_str(), &at_path) == 0 &&
          held.st_ino == at_path.st_ino && held.st_dev == at_path.st_dev)
        return;
      ::close(fd_);
    }
  }
  ~FrameLock() {
    ::unlink(file_.c_str());  // while still held: no one else holds this file's lock
    ::close(fd_);
  }
  FrameLock(const FrameLock&) = delete;
  FrameLock& operator=(const FrameLock&) = delete;

 private:
  std::filesystem::path file_;
  int fd_ = -1;
};

}  // namespace

ReferenceCache::ReferenceCache(std::filesystem::path dir) : dir_(std::move(dir)) {}

std::string ReferenceCache::scene_file_digest(const scene::Scene& scene) const {
  if (scene.file.empty()) return "";
  std::string path = scene.file.string();
  for (const auto& [p, d] : file_digests_)
    if (p == path) return d;
  std::error_code ec;
  std::string digest;
  if (std::filesystem::exists(scene.file, ec)) {
    Digest d;
    d.text(read_file_bytes(scene.file));
    digest = d.hex();
  }
  file_digests_.push_back({path, digest});
  return digest;
}

std::string ReferenceCache::key(const scene::Scene& scene, const scene::FrameState& state,
                                PathClass path_class, int width, int height,
                                const ReferenceOptions& options) const {
  Digest d;
  d.text("photonbench-reference");
  d.value(kReferenceRendererVersion);
  d.text(scene_file_digest(scene));
  for (const auto& m : scene.materials) {
    d.text(m.name);
    d.value(m.type), d.value(m.albedo), d.value(m.specular), d.value(m.emission), d.value(m.ior),
        d.value(m.roughness);
  }
  for (const auto& o : scene.objects) {
    d.text(o.name);
    d.value(o.material);
    d.vec(o.mesh.positions), d.vec(o.mesh.normals), d.vec(o.mesh.triangles);
  }
  d.value(state.frame), d.value(state.time);
  const auto& c = state.camera;
  d.value(c.position), d.value(c.target), d.value(c.up), d.value(c.fov_y);
  for (const auto& l : state.lights) {
    d.value(l.type), d.value(l.radiant), d.value(l.position), d.value(l.direction),
        d.value(l.spot_inner), d.value(l.spot_outer), d.value(l.edge_u), d.value(l.edge_v);
  }
  d.vec(state.object_to_world);
  d.vec(state.deformed_objects);
  d.value(width), d.value(height), d.value(path_class), d.value(options.max_bounces);
  return d.hex();
}

namespace {

// The four images of an entry, by file suffix.
constexpr const char* kImageSuffix[4] = {".exr", ".variance.exr", ".half0.exr", ".half1.exr"};

// Does a stored entry (its sidecar) meet any stop rule of the request?
bool serves(const nlohmann::json& side, const ReferenceOptions& options) {
  uint32_t samples = side.value("samples", 0u);
  double err = side.value("rel_error", 0.0), seconds = side.value("seconds", 0.0);
  // An error of 0 is a measured one when the error rule stopped the render: a black image.
  const bool error_measured = err > 0 || side.value("stopped_by", "") == "rel_error";
  if (options.rel_error > 0 && samples >= 2 && error_measured && err <= options.rel_error)
    return true;
  if (options.samples > 0 && samples >= options.samples) return true;
  return options.max_seconds > 0 && seconds >= options.max_seconds;
}

}  // namespace

bool ReferenceCache::has(const scene::Scene& scene, const scene::FrameState& state,
                         PathClass path_class, int width, int height,
                         const ReferenceOptions& options) const {
  std::string k = key(scene, state, path_class, width, height, options);
  std::error_code ec;
  for (const char* suffix : kImageSuffix)
    if (!std::filesystem::exists(dir_ / (k + suffix), ec)) return false;
  auto side = read_sidecar(dir_ / (k + ".json"));
  return side && serves(*side, options);
}

std::optional<ReferenceImage> ReferenceCache::get_entry(const scene::Scene& scene,
                                                        const scene::FrameState& state,
                                                        PathClass path_class, int width, int height,
                                                        const ReferenceOptions& options) const {
  std::string k = key(scene, state, path_class, width, height, options);
  std::error_code ec;
  for (const char* suffix : kImageSuffix)
    if (!std::filesystem::exists(dir_ / (k + suffix), ec)) return std::nullopt;
  auto side = read_sidecar(dir_ / (k + ".json"));
  if (!side || !serves(*side, options)) return std::nullopt;
  ReferenceImage entry;
  entry.mean = io::read_image(dir_ / (k + kImageSuffix[0]));
  entry.variance = io::read_image(dir_ / (k + kImageSuffix[1]));
  entry.half[0] = io::read_image(dir_ / (k + kImageSuffix[2]));
  entry.half[1] = io::read_image(dir_ / (k + kImageSuffix[3]));
  entry.samples = side->value("samples", 0u);
  entry.seed = side->value("seed", 0u);
  entry.seconds = side->value("seconds", 0.0);
  entry.rel_error = side->value("rel_error", 0.0);
  entry.stopped_by = parse_stop_rule(side->value("stopped_by", "")).value_or(StopRule::samples);
  entry.max_bounces = side->value("max_bounces", 0u);
  entry.estimator = parse_estimator(side->value("estimator", "")).value_or(Estimator::pt);
  return entry;
}

std::optional<io::Image> ReferenceCache::get(const scene::Scene& scene,
                                             const scene::FrameState& state, PathClass path_class,
                                             int width, int height,
                                             const ReferenceOptions& options) const {
  if (!has(scene, state, path_class, width, height, options)) return std::nullopt;
  return io::read_image(dir_ / (key(scene, state, path_class, width, height, options) + ".exr"));
}

int ReferenceCache::render_missing(const scene::Scene& scene, const scene::FrameState& state,
                                   uint32_t class_mask, int width, int height,
                                   const ReferenceOptions& options, const ProgressFn& progress) {
  auto missing_classes = [&] {
    uint32_t missing = 0;
    for (PathClass c : all_path_classes())
      if ((class_mask & class_bit(c)) && !has(scene, state, c, width, height, options))
        missing |= class_bit(c);
    return missing;
  };
  if (!missing_classes()) return 0;
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec)
    throw Error(
        fmt::format("cannot create the reference cache {}: {}", dir_.string(), ec.message()));
  // Processes sharing the cache (the shards of a sharded run) may want the same frame at once:
  // one renders it under this lock while the others wait, then find its entries and reuse them,
  // so no entry mixes the images of two renders and none is rendered twice.
  const FrameLock lock(dir_ /
                       (".lock-" + key(scene, state, PathClass::combined, width, height, options)));
  const uint32_t missing = missing_classes();
  if (!missing) return 0;
  EmbreeScene world(scene, state, one_frame_options());
  ReferenceResult r = render_reference_classes(world, width, height, missing, options, progress);
  int written = 0;
  for (PathClass c : all_path_classes()) {
    if (!(missing & class_bit(c))) continue;
    std::string k = key(scene, state, c, width, height, options);
    const ReferenceImage& img = r.classes[int(c)];
    const io::Image* images[4] = {&img.mean, &img.variance, &img.half[0], &img.half[1]};
    for (int i = 0; i < 4; ++i)
      io::write_image(dir_ / (k + kImageSuffix[i]), *images[i]);  // atomic (io/image.h)
    nlohmann::json side = {
        {"key", k},
        {"renderer_version", kReferenceRendererVersion},
        {"scene", scene.name},
        {"scene_file", scene.file.string()},
        {"frame", state.frame},
        {"time", state.time},
        {"class", std::string(path_class_name(c))},
        {"expression", std::string(path_class_expression(c))},
        {"width", width},
        {"height", height},
        {"samples", img.samples},
        {"seed", img.seed},
        {"seconds", img.seconds},
        {"rel_error", img.rel_error},
        {"stopped_by", std::string(stop_rule_name(img.stopped_by))},
        {"target_rel_error", options.rel_error},
        {"target_max_seconds", options.max_seconds},
        {"target_samples", options.samples},
        {"max_bounces", options.max_bounces},
        {"estimator", std::string(estimator_name(img.estimator))},
        {"estimator_why", r.pilot.why},
        {"light_sampler", std::string(light_selection_name(r.light_selection))},
        {"photons_per_iteration", r.photon_paths > 0 ? options.photon_mapping.photons : 0u},
        {"rays", r.rays},
        {"images",
         {{"mean", k + kImageSuffix[0]},
          {"variance", k + kImageSuffix[1]},
          {"half0", k + kImageSuffix[2]},
          {"half1", k + kImageSuffix[3]}}},
        {"created", now_iso()},
    };
    if (r.pilot.ran)
      side["pilot"] = {{"pt_error2", r.pilot.pt_error2},     {"bdpt_error2", r.pilot.bdpt_error2},
                       {"pt_rays", r.pilot.pt_rays},         {"bdpt_rays", r.pilot.bdpt_rays},
                       {"photon_rays", r.pilot.photon_rays}, {"pt_cost", r.pilot.pt_cost},
                       {"bdpt_cost", r.pilot.bdpt_cost},     {"seconds", r.pilot.seconds},
                       {"iterations", r.pilot.iterations}};
    write_atomic(dir_ / (k + ".json"), side.dump(2) + "\n");  // last: marks the entry complete
    ++written;
  }
  return written;
}

ReferenceImage ReferenceCache::get_or_render_entry(const scene::Scene& scene,
                                                   const scene::FrameState& state,
                                                   PathClass path_class, int width, int height,
                                                   const ReferenceOptions& options,
                                                   const ProgressFn& progress) {
  if (auto entry = get_entry(scene, state, path_class, width, height, options))
    return std::move(*entry);
  render_missing(scene, state, class_bit(path_class), width, height, options, progress);
  auto entry = get_entry(scene, state, path_class, width, height, options);
  if (!entry) throw Error("reference cache: the entry just written cannot be read back");
  return std::move(*entry);
}

io::Image ReferenceCache::get_or_render(const scene::Scene& scene, const scene::FrameState& state,
                                        PathClass path_class, int width, int height,
                                        const ReferenceOptions& options,
                                        const ProgressFn& progress) {
  if (auto img = get(scene, state, path_class, width, height, options)) return std::move(*img);
  return get_or_render_entry(scene, state, path_class, width, height, options, progress).mean;
}

std::string describe_progress(const ReferenceProgress& p) {
  std::string line = p.max_samples ? fmt::format("iteration {}/{}", p.iteration, p.max_samples)
                                   : fmt::format("iteration {}", p.iteration);
  if (p.target > 0)
    line += p.rel_error > 0
                ? fmt::format(", rel. error {:.4f} (target {:.4f})", p.rel_error, p.target)
                : fmt::format(", rel. error pending (target {:.4f})", p.target);
  line += p.max_seconds > 0 ? fmt::format(", {:.1f}/{:.0f} s", p.seconds, p.max_seconds)
                            : fmt::format(", {:.1f} s", p.seconds);
  if (p.seconds > 0) line += fmt::format(", {:.1f} Mrays/s", p.rays / p.seconds * 1e-6);
  return line;
}

ReferenceJobReport render_references(const scene::Scene& scene, uint32_t first_frame,
                                     uint32_t last_frame, uint32_t class_mask, int width,
                                     int height, const ReferenceOptions& options,
                                     ReferenceCache& cache,
                                     const std::function<void(const std::string&)>& log) {
  ReferenceJobReport report;
  auto t0 = std::chrono::steady_clock::now();
  int n_classes = std::popcount(class_mask);
  for (uint32_t f = first_frame; f <= last_frame; ++f) {
    scene::FrameState state = scene.at(f);
    auto frame_t0 = std::chrono::steady_clock::now();
    double last_report = 0;
    ReferenceProgress last;
    ProgressFn progress = [&](const ReferenceProgress& p) {
      last = p;
      if (!log || p.seconds - last_report < 5.0) return;
      last_report = p.seconds;
      log(fmt::format("  {} frame {}: {}", scene.name, f, describe_progress(p)));
    };
    int rendered = cache.render_missing(scene, state, class_mask, width, height, options, progress);
    report.rendered += rendered;
    report.cached += n_classes - rendered;
    if (log) {
      double s = io::seconds_since(frame_t0);
      log(rendered ? fmt::format("{} frame {}: rendered {} class(es) in {:.1f} s ({})", scene.name,
                                 f, rendered, s, describe_progress(last))
                   : fmt::format("{} frame {}: cached", scene.name, f));
    }
  }
  report.seconds = io::seconds_since(t0);
  return report;
}

}  // namespace pb::trace
