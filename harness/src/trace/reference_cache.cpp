// The content-addressed reference cache and the frame loop that fills it (reference.h).
#include <fmt/format.h>

#include <bit>
#include <chrono>
#include <cstring>
#include <ctime>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <system_error>

#include "photonbench/error.h"
#include "trace/reference.h"

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
  d.value(width), d.value(height), d.value(path_class), d.value(options.max_depth);
  return d.hex();
}

bool ReferenceCache::has(const scene::Scene& scene, const scene::FrameState& state,
                         PathClass path_class, int width, int height,
                         const ReferenceOptions& options) const {
  std::string k = key(scene, state, path_class, width, height, options);
  std::error_code ec;
  if (!std::filesystem::exists(dir_ / (k + ".exr"), ec)) return false;
  auto side = read_sidecar(dir_ / (k + ".json"));
  if (!side) return false;
  uint32_t samples = side->value("samples", 0u);
  double err = side->value("rel_error", 0.0);
  if (samples >= options.samples) return true;
  return options.rel_error > 0 && err > 0 && err <= options.rel_error;
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
  uint32_t missing = 0;
  for (PathClass c : all_path_classes())
    if ((class_mask & class_bit(c)) && !has(scene, state, c, width, height, options))
      missing |= class_bit(c);
  if (!missing) return 0;
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec)
    throw Error(
        fmt::format("cannot create the reference cache {}: {}", dir_.string(), ec.message()));
  EmbreeScene world(scene, state);
  ReferenceResult r = render_reference_classes(world, width, height, missing, options, progress);
  int written = 0;
  for (PathClass c : all_path_classes()) {
    if (!(missing & class_bit(c))) continue;
    std::string k = key(scene, state, c, width, height, options);
    io::write_image(dir_ / (k + ".exr"), r.images[int(c)]);  // atomic (io/image.h)
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
        {"samples", r.samples},
        {"sppm_iterations", r.sppm_iterations},
        {"sppm_photons_per_iteration", options.sppm_photons},
        {"seed", r.seed},
        {"max_depth", options.max_depth},
        {"seconds", r.seconds},
        {"rays", r.rays},
        {"rel_error", r.rel_error},
        {"created", now_iso()},
    };
    write_atomic(dir_ / (k + ".json"), side.dump(2) + "\n");
    ++written;
  }
  return written;
}

io::Image ReferenceCache::get_or_render(const scene::Scene& scene, const scene::FrameState& state,
                                        PathClass path_class, int width, int height,
                                        const ReferenceOptions& options,
                                        const ProgressFn& progress) {
  if (auto img = get(scene, state, path_class, width, height, options)) return std::move(*img);
  render_missing(scene, state, class_bit(path_class), width, height, options, progress);
  auto img = get(scene, state, path_class, width, height, options);
  if (!img) throw Error("reference cache: the entry just written cannot be read back");
  return std::move(*img);
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
    ProgressFn progress = [&](const ReferenceProgress& p) {
      if (!log) return;
      if (p.seconds - last_report < 5.0 && p.iteration != p.total) return;
      last_report = p.seconds;
      log(fmt::format("  {} frame {}: iteration {}/{} ({:.0f}%), {:.1f} s, {:.1f} Mrays/s{}",
                      scene.name, f, p.iteration, p.total, 100.0 * p.iteration / p.total, p.seconds,
                      p.seconds > 0 ? p.rays / p.seconds * 1e-6 : 0.0,
                      p.rel_error > 0 ? fmt::format(", rel. error {:.4f}", p.rel_error) : ""));
    };
    int rendered = cache.render_missing(scene, state, class_mask, width, height, options, progress);
    report.rendered += rendered;
    report.cached += n_classes - rendered;
    if (log) {
      double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - frame_t0).count();
      log(rendered ? fmt::format("{} frame {}: rendered {} class(es) in {:.1f} s", scene.name, f,
                                 rendered, s)
                   : fmt::format("{} frame {}: cached", scene.name, f));
    }
  }
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

}  // namespace pb::trace
