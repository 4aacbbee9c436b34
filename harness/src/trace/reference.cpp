#include "trace/reference.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "photonbench/error.h"
#include "trace/bsdf.h"
#include "trace/lights.h"
#include "trace/photon_tracer.h"
#include "trace/sampling.h"

namespace pb::trace {
namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();
constexpr int kClasses = 5;  // the partition; `combined` is their sum

struct ClassInfo {
  PathClass id;
  std::string_view name, expression;
};
constexpr ClassInfo kClassInfo[kPathClassCount] = {
    {PathClass::direct, "direct", "C L | C D L"},
    {PathClass::indirect, "indirect", "C D (D|S)* D (D|S)* L"},
    {PathClass::caustics, "caustics", "C D S+ L"},
    {PathClass::indirect_caustics, "indirect_caustics", "C S+ D S+ L"},
    {PathClass::specular, "specular", "C S+ L | C S+ D L | C S+ D (D|S)* D (D|S)* L"},
    {PathClass::combined, "combined", "C (D|S)* L"},
};

float luminance(const glm::vec3& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
float max3(const glm::vec3& v) { return std::max(v.x, std::max(v.y, v.z)); }

// The camera path's light path expression so far, reduced to what decides its class (see
// reference.h): the first vertex's type, whether a diffuse "anchor" vertex exists (the first vertex
// if diffuse, else the first diffuse one after the specular prefix), and which types follow the
// anchor.
struct ClassState {
  uint8_t first = 0;  // 0 none, 1 D, 2 S
  bool anchor = false, d_after = false, s_after = false;
  ClassState push(bool diffuse) const {
    ClassState s = *this;
    if (s.first == 0) {
      s.first = diffuse ? 1 : 2;
      s.anchor = diffuse;
    } else if (!s.anchor) {
      s.anchor = diffuse;
    } else if (diffuse) {
      s.d_after = true;
    } else {
      s.s_after = true;
    }
    return s;
  }
  // Class of the path ending at an emitter now.
  int classify() const {
    if (first == 0) return int(PathClass::direct);
    if (first == 1) {
      if (d_after) return int(PathClass::indirect);
      return s_after ? int(PathClass::caustics) : int(PathClass::direct);
    }
    if (anchor && s_after && !d_after) return int(PathClass::indirect_caustics);
    return int(PathClass::specular);
  }
  // Classes some continuation of this path can still end in.
  uint32_t reachable() const {
    auto bit = [](PathClass c) { return class_bit(c); };
    if (first == 0) return kAllPathClasses;
    if (first == 1) {
      if (d_after) return bit(PathClass::indirect);
      if (s_after) return bit(PathClass::caustics) | bit(PathClass::indirect);
      return bit(PathClass::direct) | bit(PathClass::caustics) | bit(PathClass::indirect);
    }
    if (anchor && d_after) return bit(PathClass::specular);
    return bit(PathClass::specular) | bit(PathClass::indirect_caustics);
  }
};

float power_heuristic(float a, float b) {
  float a2 = a * a, b2 = b * b;
  return a2 + b2 > 0 ? a2 / (a2 + b2) : 0.f;
}

struct Rig {
  glm::vec3 position, right, up, forward;
  float tan_half, aspect;
  int width, height;
  Rig(const scene::Camera& c, int w, int h) : width(w), height(h) {
    position = c.position;
    forward = glm::normalize(c.target - c.position);
    right = glm::normalize(glm::cross(forward, c.up));  // glm::lookAtRH's basis
    up = glm::cross(right, forward);
    tan_half = std::tan(0.5f * c.fov_y);
    aspect = float(w) / float(h);
  }
  glm::vec3 direction(float px, float py) const {
    float x = (2.f * px / width - 1.f) * tan_half * aspect;
    float y = (1.f - 2.f * py / height) * tan_half;  // Vulkan clip y points down: row 0 is the top
    return glm::normalize(forward + x * right + y * up);
  }
};

glm::vec3 offset_origin(const Hit& hit, const glm::vec3& dir) {
  float eps = EmbreeScene::ray_epsilon(hit.position);
  return hit.position +
         hit.geometric_normal * (glm::dot(dir, hit.geometric_normal) >= 0 ? eps : -eps);
}

// ---- path tracing ------------------------------------------------------------------------------

struct PtOutput {
  glm::vec3 value[kClasses];
};

// One camera path through pixel position (px, py). Contributions in SPPM's part of path space (a
// diffuse vertex exists and the vertex next to the emitter is specular) are left out.
void trace_camera_path(const EmbreeScene& world, const LightSet& lights, const Rig& rig, float px,
                       float py, Pcg32& rng, uint32_t wanted, uint32_t max_depth, PtOutput& out,
                       uint64_t& rays) {
  const scene::Scene& scene = world.scene();
  for (auto& v : out.value) v = glm::vec3(0.f);
  glm::vec3 origin = rig.position, dir = rig.direction(px, py);
  glm::vec3 beta(1.f);
  ClassState state;
  bool prev_delta = true, prev_specular = false;
  float prev_pdf = 0;
  glm::vec3 prev_position = origin;
  for (uint32_t depth = 0; depth < max_depth; ++depth) {
    Hit hit;
    ++rays;
    if (!world.intersect(origin, dir, kInfinity, hit)) break;
    glm::vec3 wo = -dir;
    glm::vec3 le = lights.emitted(hit, wo);
    if (max3(le) > 0 && !(state.anchor && prev_specular) && (wanted & (1u << state.classify()))) {
      float w = 1.f;
      if (!prev_delta) w = power_heuristic(prev_pdf, lights.pdf_incident(prev_position, hit));
      out.value[state.classify()] += beta * le * w;
    }
    if (world.is_light_object(hit.object)) break;
    Bsdf bsdf(scene.materials[hit.material], hit);
    bool diffuse = bsdf.is_diffuse();
    ClassState next = state.push(diffuse);
    if ((next.reachable() & wanted) == 0) break;
    // Next-event estimation (skipped where SPPM owns the path: a specular vertex after the anchor).
    if (bsdf.can_eval() && !(next.anchor && !diffuse) && (wanted & (1u << next.classify()))) {
      IncidentSample is;
      float u_select = rng.next_float();
      glm::vec2 u = rng.next_2d();
      if (lights.sample_incident(hit.position, u_select, u, is)) {
        glm::vec3 f = bsdf.eval(wo, is.wi, Transport::radiance);
        if (max3(f) > 0) {
          glm::vec3 o = offset_origin(hit, is.wi);
          float tmax = std::isinf(is.distance)
                           ? kInfinity
                           : is.distance * (1.f - 1e-4f) - EmbreeScene::ray_epsilon(hit.position);
          ++rays;
          if (!world.occluded(o, is.wi, tmax)) {
            float w = is.delta ? 1.f : power_heuristic(is.pdf, bsdf.pdf(wo, is.wi));
            out.value[next.classify()] += beta * f * is.weight * w;
          }
        }
      }
    }
    BsdfSample s;
    glm::vec3 u{rng.next_float(), rng.next_float(), rng.next_float()};
    if (!bsdf.sample(wo, u, Transport::radiance, s)) break;
    beta *= s.weight;
    if (!(max3(beta) > 0) || !std::isfinite(max3(beta))) break;
    if (depth >= 3) {  // Russian roulette on the throughput
      float q = std::min(0.95f, max3(beta));
      if (rng.next_float() >= q) break;
      beta /= q;
    }
    prev_delta = s.delta;
    prev_pdf = s.pdf;
    prev_position = hit.position;
    prev_specular = !diffuse;
    state = next;
    origin = offset_origin(hit, s.wi);
    dir = s.wi;
  }
}

// ---- SPPM
// ----------------------------------------------------------------------------------------

struct VisiblePoint {
  glm::vec3 position{0.0f}, normal{0.0f}, wo{0.0f}, beta{0.0f}, albedo{0.0f};
  float distance = 0;  // camera path length, for the automatic initial radius
  bool valid = false;
  bool specular_prefix = false;  // C S+ D rather than C D
};

struct PixelStats {
  float r2 = 0;  // squared radius, 0 until the first visible point
  double n = 0;
  glm::dvec3
      tau[4]{};  // by photon kind and prefix: caustics, indirect, indirect_caustics, specular
};

// Follows the camera path through specular vertices to the first diffuse one (C S* D).
bool find_visible_point(const EmbreeScene& world, const Rig& rig, float px, float py, Pcg32& rng,
                        uint32_t max_depth, VisiblePoint& vp, uint64_t& rays) {
  const scene::Scene& scene = world.scene();
  glm::vec3 origin = rig.position, dir = rig.direction(px, py), beta(1.f);
  float distance = 0;
  vp.valid = false;
  for (uint32_t depth = 0; depth < max_depth; ++depth) {
    Hit hit;
    ++rays;
    if (!world.intersect(origin, dir, kInfinity, hit)) return false;
    distance += hit.t;
    if (world.is_light_object(hit.object)) return false;
    Bsdf bsdf(scene.materials[hit.material], hit);
    if (bsdf.is_diffuse()) {
      vp.position = hit.position;
      vp.wo = -dir;
      vp.normal =
          glm::dot(hit.geometric_normal, vp.wo) >= 0 ? hit.geometric_normal : -hit.geometric_normal;
      vp.beta = beta;
      vp.albedo = bsdf.albedo();
      vp.distance = distance;
      vp.specular_prefix = depth > 0;
      vp.valid = max3(beta) > 0 && max3(vp.albedo) > 0;
      return vp.valid;
    }
    BsdfSample s;
    glm::vec3 u{rng.next_float(), rng.next_float(), rng.next_float()};
    if (!bsdf.sample(-dir, u, Transport::radiance, s)) return false;
    beta *= s.weight;
    if (depth >= 3) {
      float q = std::min(0.95f, max3(beta));
      if (rng.next_float() >= q) return false;
      beta /= q;
    }
    origin = offset_origin(hit, s.wi);
    dir = s.wi;
  }
  return false;
}

// A hash grid over one iteration's photons, built in photon order (deterministic).
class PhotonGrid {
 public:
  PhotonGrid(const std::vector<PhotonRecord>& photons, float cell)
      : photons_(photons), inv_cell_(1.f / cell) {
    size_t buckets = 1;
    while (buckets < 2 * photons.size()) buckets <<= 1;
    mask_ = buckets - 1;
    start_.assign(buckets + 1, 0);
    std::vector<uint32_t> key(photons.size());
    for (size_t i = 0; i < photons.size(); ++i) {
      key[i] = bucket(cell_of(photons[i].position));
      ++start_[key[i] + 1];
    }
    for (size_t b = 0; b < buckets; ++b) start_[b + 1] += start_[b];
    index_.resize(photons.size());
    std::vector<uint32_t> fill(start_.begin(), start_.end() - 1);
    for (size_t i = 0; i < photons.size(); ++i) index_[fill[key[i]]++] = uint32_t(i);
  }
  template <class F>
  void for_each_near(const glm::vec3& p, float r, F&& f) const {
    glm::ivec3 lo = cell_of(p - r), hi = cell_of(p + r);
    float r2 = r * r;
    for (int z = lo.z; z <= hi.z; ++z)
      for (int y = lo.y; y <= hi.y; ++y)
        for (int x = lo.x; x <= hi.x; ++x) {
          uint32_t b = bucket({x, y, z});
          for (uint32_t k = start_[b]; k < start_[b + 1]; ++k) {
            const PhotonRecord& ph = photons_[index_[k]];
            glm::vec3 d = ph.position - p;
            if (glm::dot(d, d) <= r2 && cell_of(ph.position) == glm::ivec3(x, y, z)) f(ph);
          }
        }
  }

 private:
  glm::ivec3 cell_of(const glm::vec3& p) const { return glm::ivec3(glm::floor(p * inv_cell_)); }
  uint32_t bucket(const glm::ivec3& c) const {
    uint32_t h = uint32_t(c.x) * 73856093u ^ uint32_t(c.y) * 19349663u ^ uint32_t(c.z) * 83492791u;
    return hash_u32(h) & uint32_t(mask_);
  }
  const std::vector<PhotonRecord>& photons_;
  float inv_cell_;
  size_t mask_ = 0;
  std::vector<uint32_t> start_, index_;
};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

bool scene_has_specular(const scene::Scene& scene) {
  for (const auto& o : scene.objects) {
    auto t = scene.materials[o.material].type;
    if (t != scene::MaterialType::diffuse && t != scene::MaterialType::emissive) return true;
  }
  return false;
}

}  // namespace

std::string_view path_class_name(PathClass c) { return kClassInfo[int(c)].name; }
std::string_view path_class_expression(PathClass c) { return kClassInfo[int(c)].expression; }
std::optional<PathClass> parse_path_class(std::string_view name) {
  for (const auto& info : kClassInfo)
    if (info.name == name) return info.id;
  return std::nullopt;
}
std::vector<PathClass> all_path_classes() {
  std::vector<PathClass> out;
  for (const auto& info : kClassInfo) out.push_back(info.id);
  return out;
}

CameraRay camera_ray(const scene::Camera& camera, int width, int height, float px, float py) {
  Rig rig(camera, width, height);
  return {rig.position, rig.direction(px, py)};
}

ReferenceResult render_reference_classes(const EmbreeScene& world, int width, int height,
                                         uint32_t class_mask, const ReferenceOptions& options,
                                         const ProgressFn& progress) {
  if (width <= 0 || height <= 0)
    throw InputError(fmt::format("reference: bad resolution {}x{}", width, height));
  if (class_mask == 0 || (class_mask & ~kAllPathClasses))
    throw InputError("reference: no path class requested");
  if (options.samples == 0) throw InputError("reference: samples must be at least 1");
  auto t0 = std::chrono::steady_clock::now();
  const scene::Scene& scene = world.scene();
  LightSet lights(world);
  Rig rig(world.state().camera, width, height);
  uint32_t wanted = class_mask & class_bit(PathClass::combined) ? kAllPathClasses : class_mask;
  // SPPM is needed when photons can add to a wanted class: any class but `direct`, in a scene with
  // specular surfaces (without them its part of path space is empty).
  uint32_t sppm_classes = class_bit(PathClass::indirect) | class_bit(PathClass::caustics) |
                          class_bit(PathClass::indirect_caustics) | class_bit(PathClass::specular);
  bool use_sppm = (wanted & sppm_classes) && scene_has_specular(scene) && lights.size() > 0;
  uint32_t sppm_iterations = options.sppm_iterations ? options.sppm_iterations : options.samples;
  uint32_t iterations = std::max(options.samples, use_sppm ? sppm_iterations : 0u);

  size_t pixels = size_t(width) * height;
  std::vector<glm::dvec3> sums(pixels * kClasses, glm::dvec3(0.0));
  std::vector<double> lum_sum(pixels, 0.0), lum_sum2(pixels, 0.0);
  std::vector<PixelStats> stats(use_sppm ? pixels : 0);
  std::vector<VisiblePoint> vps(use_sppm ? pixels : 0);
  float pixel_angle = 2.f * rig.tan_half / height;  // footprint per metre of distance

  auto arena = options.threads > 0 ? std::make_unique<tbb::task_arena>(options.threads)
                                   : std::make_unique<tbb::task_arena>();
  EmbreePhotonTracer tracer(world);
  tbb::combinable<uint64_t> ray_count([] { return uint64_t(0); });
  uint64_t photon_rays = 0, photon_paths = 0;
  uint32_t pt_done = 0, sppm_done = 0;
  double rel_error = 0;

  auto estimate_error = [&]() {
    double mean_lum = 0;
    for (size_t i = 0; i < pixels; ++i) mean_lum += lum_sum[i] / pt_done;
    mean_lum /= double(pixels);
    double floor2 = std::pow(0.01 * std::max(mean_lum, 1e-12), 2.0);
    double acc = 0;
    for (size_t i = 0; i < pixels; ++i) {
      double m = lum_sum[i] / pt_done;
      double var =
          std::max(0.0, lum_sum2[i] / pt_done - m * m) * pt_done / std::max(1u, pt_done - 1);
      acc += (var / pt_done) / (m * m + floor2);
    }
    return std::sqrt(acc / double(pixels));
  };

  for (uint32_t it = 0; it < iterations; ++it) {
    uint32_t iteration_seed = hash_combine(options.seed, it);
    // ---- path tracing: one sample per pixel ----
    if (pt_done < options.samples) {
      arena->execute([&] {
        tbb::parallel_for(tbb::blocked_range<int>(0, height, 1),
                          [&](const tbb::blocked_range<int>& rows) {
                            uint64_t& rays = ray_count.local();
                            PtOutput o;
                            for (int y = rows.begin(); y != rows.end(); ++y)
                              for (int x = 0; x < width; ++x) {
                                size_t i = size_t(y) * width + x;
                                Pcg32 rng(iteration_seed, i);
                                glm::vec2 j = rng.next_2d();
                                trace_camera_path(world, lights, rig, x + j.x, y + j.y, rng, wanted,
                                                  options.max_depth, o, rays);
                                glm::vec3 total(0.f);
                                for (int c = 0; c < kClasses; ++c) {
                                  sums[i * kClasses + c] += glm::dvec3(o.value[c]);
                                  if (wanted & (1u << c)) total += o.value[c];
                                }
                                double l = luminance(total);
                                lum_sum[i] += l;
                                lum_sum2[i] += l * l;
                              }
                          });
      });
      ++pt_done;
    }
    // ---- SPPM: visible points, photons, gather, radius update ----
    if (use_sppm && sppm_done < sppm_iterations) {
      uint32_t vp_seed = hash_combine(iteration_seed, 0x5eedu);
      arena->execute([&] {
        tbb::parallel_for(
            tbb::blocked_range<int>(0, height, 1), [&](const tbb::blocked_range<int>& rows) {
              uint64_t& rays = ray_count.local();
              for (int y = rows.begin(); y != rows.end(); ++y)
                for (int x = 0; x < width; ++x) {
                  size_t i = size_t(y) * width + x;
                  Pcg32 rng(vp_seed, i);
                  glm::vec2 j = rng.next_2d();
                  VisiblePoint& vp = vps[i];
                  if (find_visible_point(world, rig, x + j.x, y + j.y, rng, options.max_depth, vp,
                                         rays) &&
                      stats[i].r2 == 0) {
                    float r = options.sppm_radius > 0 ? options.sppm_radius
                                                      : 3.f * pixel_angle * vp.distance;
                    stats[i].r2 = r * r;
                  }
                }
            });
      });
      double r_sum = 0;
      size_t r_count = 0;
      for (size_t i = 0; i < pixels; ++i)
        if (vps[i].valid) r_sum += std::sqrt(stats[i].r2), ++r_count;
      PhotonBatch batch;
      TraceSettings ts;
      ts.paths = options.sppm_photons;
      // L S+ D photons feed caustics and indirect_caustics; L S+ D (D|S)* D ones indirect and
      // specular.
      ts.store = 0;
      if (wanted & (class_bit(PathClass::caustics) | class_bit(PathClass::indirect_caustics)))
        ts.store |= kCausticPhotons;
      if (wanted & (class_bit(PathClass::indirect) | class_bit(PathClass::specular)))
        ts.store |= kCausticIndirectPhotons;
      ts.max_bounces = std::min(31u, std::max(1u, options.max_depth));
      ts.seed = hash_combine(iteration_seed, 0x9407u);
      ts.seed_per_frame = false;
      ts.rr_start = 0;
      arena->execute([&] { tracer.trace(ts, batch); });
      photon_rays += batch.stats.rays;
      photon_paths += batch.stats.paths;
      if (r_count > 0 && !batch.photons.empty()) {
        PhotonGrid grid(batch.photons, float(2.0 * r_sum / r_count));
        arena->execute([&] {
          tbb::parallel_for(
              tbb::blocked_range<size_t>(0, pixels, 256), [&](const tbb::blocked_range<size_t>& r) {
                for (size_t i = r.begin(); i != r.end(); ++i) {
                  const VisiblePoint& vp = vps[i];
                  if (!vp.valid) continue;
                  PixelStats& ps = stats[i];
                  glm::dvec3 phi[2] = {glm::dvec3(0.0),
                                       glm::dvec3(0.0)};  // pure caustic, caustic-indirect
                  uint32_t m = 0;
                  float cos_o = glm::dot(vp.wo, vp.normal);
                  grid.for_each_near(vp.position, std::sqrt(ps.r2), [&](const PhotonRecord& ph) {
                    glm::vec3 wi = -ph.direction;
                    // Same side of the same surface (no leaks through thin walls), and a
                    // reflection.
                    if (glm::dot(ph.normal, vp.normal) <= 0.5f || glm::dot(wi, vp.normal) <= 0 ||
                        cos_o <= 0)
                      return;
                    ++m;
                    glm::vec3 f = vp.albedo * kInvPi;
                    int kind = photon_kind(ph) == kCausticPhotons ? 0 : 1;
                    phi[kind] += glm::dvec3(f * ph.power);
                  });
                  if (m == 0) continue;
                  // Hachisuka & Jensen 2009 eqs. 9-12: keep a fraction alpha of the new photons,
                  // shrink the radius so the density stays, and scale the flux with the area.
                  double n_new = ps.n + options.sppm_alpha * m;
                  double ratio = n_new / (ps.n + m);
                  int base = vp.specular_prefix ? 2 : 0;
                  glm::dvec3 beta(vp.beta);
                  for (int c = 0; c < 4; ++c) {
                    glm::dvec3 add(0.0);
                    if (c == base) add = beta * phi[0];
                    if (c == base + 1) add = beta * phi[1];
                    ps.tau[c] = (ps.tau[c] + add) * ratio;
                  }
                  ps.r2 = float(ps.r2 * ratio);
                  ps.n = n_new;
                }
              });
        });
      }
      ++sppm_done;
    }
    double elapsed = seconds_since(t0);
    bool stop = false;
    if (options.rel_error > 0 && pt_done >= 16 &&
        (pt_done % 4 == 0 || pt_done == options.samples)) {
      rel_error = estimate_error();
      stop = rel_error <= options.rel_error && (!use_sppm || sppm_done >= pt_done);
    }
    if (options.max_seconds > 0 && elapsed >= options.max_seconds) stop = true;
    if (progress) {
      uint64_t rays = photon_rays;
      ray_count.combine_each([&](uint64_t r) { rays += r; });
      progress({it + 1, iterations, rel_error, elapsed, rays});
    }
    if (stop) break;
  }

  // ---- resolve ----
  ReferenceResult result;
  result.samples = pt_done;
  result.sppm_iterations = sppm_done;
  result.photon_paths = photon_paths;
  result.seed = options.seed;
  result.rel_error = pt_done >= 2 ? estimate_error() : 0.0;
  for (int c = 0; c < kPathClassCount; ++c) {
    if (!(class_mask & (1u << c))) continue;
    io::Image img(width, height, 3);
    for (size_t i = 0; i < pixels; ++i) {
      glm::dvec3 v(0.0);
      for (int k = 0; k < kClasses; ++k) {
        if (c != int(PathClass::combined) && k != c) continue;
        v += sums[i * kClasses + k] / double(std::max(1u, pt_done));
        if (use_sppm && sppm_done > 0 && stats[i].r2 > 0) {
          // tau index: caustics 0, indirect 1, indirect_caustics 2, specular 3.
          int t = k == int(PathClass::caustics)            ? 0
                  : k == int(PathClass::indirect)          ? 1
                  : k == int(PathClass::indirect_caustics) ? 2
                  : k == int(PathClass::specular)          ? 3
                                                           : -1;
          if (t >= 0) v += stats[i].tau[t] / (double(sppm_done) * kPi * double(stats[i].r2));
        }
      }
      img.pixels[i * 3 + 0] = float(v.x);
      img.pixels[i * 3 + 1] = float(v.y);
      img.pixels[i * 3 + 2] = float(v.z);
    }
    result.images[c] = std::move(img);
  }
  uint64_t rays = photon_rays;
  ray_count.combine_each([&](uint64_t r) { rays += r; });
  result.rays = rays;
  result.seconds = seconds_since(t0);
  return result;
}

io::Image render_reference(const scene::Scene& scene, const scene::FrameState& state,
                           PathClass path_class, int width, int height,
                           const ReferenceOptions& options, const ProgressFn& progress) {
  EmbreeScene world(scene, state);
  ReferenceResult r =
      render_reference_classes(world, width, height, class_bit(path_class), options, progress);
  return std::move(r.images[int(path_class)]);
}

}  // namespace pb::trace
