#include "reference/reference.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include "io/clock.h"
#include "photonbench/error.h"
#include "reference/aimed_emission.h"
#include "reference/bdpt.h"
#include "reference/path_space.h"
#include "trace/bsdf.h"
#include "trace/lights.h"
#include "trace/photon_tracer.h"
#include "trace/sampling.h"

namespace pb::trace {
namespace {

using namespace detail;

constexpr std::string_view kStopRuleNames[] = {"rel_error", "max_seconds", "samples"};

// ---- path tracing ------------------------------------------------------------------------------

// Path tracing runs as a wavefront over one image row at a time: the row's paths advance a vertex
// together, so each step's closest-hit rays and each step's shadow rays go to Embree as one stream
// (EmbreeScene::intersect_stream, occluded_stream). The camera's rays of a row, and the shadow rays
// from their first hits to a light, are coherent, and Embree traces them as SIMD packets; that is
// where the wavefront pays (issue 30: the camera stream alone took bench_trace from 0.86x to 0.95x
// of Embree's tutorial). Each path draws from its own pixel's generator in the order a path-by-path
// loop would, so the image does not depend on the order paths advance in.

// One camera path between two of its vertices: the ray it goes on along, what it carries, and
// what the MIS weight and the classification of its next vertex need to know about this one.
struct CameraPath {
  explicit CameraPath(const Pcg32& generator) : rng(generator) {}
  Ray ray;
  glm::vec3 beta{1.f};
  glm::vec3 prev_position{0.f};
  float prev_pdf = 0;
  bool prev_delta = true, prev_specular = false;  // the camera counts as a delta vertex
  ClassState state;
  uint32_t depth = 0;  // scattering vertices before the vertex the next segment reaches
  Pcg32 rng;
  glm::vec3* out = nullptr;  // the pixel's kClasses slots of the frame
};

// A next-event estimate that waits for its shadow ray: added to *slot when the ray is clear.
struct PendingLight {
  glm::vec3 contribution{0.f};
  glm::vec3* slot = nullptr;
};

// What a row's wavefront keeps between its steps.
struct PathWavefront {
  std::vector<CameraPath> paths;  // the live paths
  std::vector<Ray> rays;          // their next segments, in the order of `paths`
  std::vector<Hit> hits;
  std::vector<uint8_t> found;
  std::vector<Ray> shadow_rays;
  std::vector<PendingLight> pending;
  std::vector<uint8_t> blocked;
};

struct PathTracingSetup {
  const EmbreeScene& world;
  const LightSet& lights;
  uint32_t wanted, budget;
  bool use_nee, use_hits;
};

// The path's vertex at `hit`: emission reached by the BSDF-sampled segment, next-event estimation
// (its shadow ray queued in `wave`), and the next direction. False when the path ends here; paths
// in photon mapping's part of path space (photon_mapping_owns) add nothing, and paths stop after
// `budget` scattering vertices.
bool shade_vertex(const PathTracingSetup& setup, CameraPath& path, const Hit& hit,
                  PathWavefront& wave, uint64_t& rays) {
  const scene::Scene& scene = setup.world.scene();
  const uint32_t wanted = setup.wanted;
  glm::vec3 wo = -path.ray.dir;
  glm::vec3 le = setup.lights.emitted(hit, wo);
  if (max3(le) > 0 && !photon_mapping_owns(path.state.anchor, path.prev_specular) &&
      (wanted & (1u << path.state.classify()))) {
    // A BSDF-sampled hit: weighted against NEE, which could have sampled it unless the last
    // scattering was a delta lobe (or the camera).
    float w = 1.f;
    if (!path.prev_delta) {
      if (!setup.use_hits)
        w = 0.f;
      else if (setup.use_nee)
        w = power_heuristic(path.prev_pdf, setup.lights.pdf_incident(path.prev_position, hit));
    }
    path.out[path.state.classify()] += path.beta * le * w;
  }
  if (setup.world.is_light_object(hit.object) || path.depth + 1 > setup.budget) return false;
  Bsdf bsdf(scene.materials[hit.material], hit);
  bool diffuse = bsdf.is_diffuse();
  ClassState next = path.state.push(diffuse);
  if ((next.reachable() & wanted) == 0) return false;
  // Next-event estimation (skipped where photon mapping owns the path: a specular vertex next to
  // the light after the anchor).
  if (setup.use_nee && bsdf.can_eval() && !photon_mapping_owns(next.anchor, !diffuse) &&
      (wanted & (1u << next.classify()))) {
    IncidentSample is;
    float u_select = path.rng.next_float();
    glm::vec2 u = path.rng.next_2d();
    if (setup.lights.sample_incident(hit.position, u_select, u, is)) {
      glm::vec3 f = bsdf.eval(wo, is.wi, Transport::radiance);
      if (max3(f) > 0) {
        ++rays;
        bool infinite = std::isinf(is.distance);
        float w = is.delta || !setup.use_hits ? 1.f : power_heuristic(is.pdf, bsdf.pdf(wo, is.wi));
        PendingLight light{path.beta * f * is.weight * w, &path.out[next.classify()]};
        if (std::optional<Ray> ray = shadow_ray(hit, infinite ? is.wi : is.point, infinite)) {
          wave.shadow_rays.push_back(*ray);
          wave.pending.push_back(light);
        } else {
          *light.slot += light.contribution;  // the light lies within the offset: clear
        }
      }
    }
  }
  BsdfSample s;
  glm::vec3 u{path.rng.next_float(), path.rng.next_float(), path.rng.next_float()};
  if (!bsdf.sample(wo, u, Transport::radiance, s)) return false;
  path.beta *= s.weight;
  if (!(max3(path.beta) > 0) || !std::isfinite(max3(path.beta))) return false;
  if (path.depth >= 3) {  // Russian roulette on the throughput
    float q = std::min(0.95f, max3(path.beta));
    if (path.rng.next_float() >= q) return false;
    path.beta /= q;
  }
  path.prev_delta = s.delta;
  path.prev_pdf = s.pdf;
  path.prev_position = hit.position;
  path.prev_specular = !diffuse;
  path.state = next;
  path.ray = Ray{offset_origin(hit, s.wi), s.wi, kUnboundedRay};
  ++path.depth;
  return true;
}

// Advances the wavefront's paths until all have ended: per step, one stream of closest hits (the
// camera's first step coherent), the vertices shaded, and one stream of their shadow rays
// (coherent when they leave the first hits).
void advance_wavefront(const PathTracingSetup& setup, PathWavefront& wave, uint64_t& rays) {
  for (bool first = true; !wave.paths.empty(); first = false) {
    size_t n = wave.paths.size();
    wave.rays.resize(n), wave.hits.resize(n), wave.found.resize(n);
    for (size_t k = 0; k < n; ++k) wave.rays[k] = wave.paths[k].ray;
    setup.world.intersect_stream(wave.rays, wave.hits, wave.found, first);
    rays += n;
    wave.shadow_rays.clear(), wave.pending.clear();
    size_t live = 0;
    for (size_t k = 0; k < n; ++k) {
      CameraPath& path = wave.paths[k];
      if (wave.found[k] && shade_vertex(setup, path, wave.hits[k], wave, rays)) {
        if (live != k) wave.paths[live] = path;
        ++live;
      }
    }
    wave.paths.erase(wave.paths.begin() + live, wave.paths.end());
    wave.blocked.resize(wave.shadow_rays.size());
    setup.world.occluded_stream(wave.shadow_rays, wave.blocked, first);
    for (size_t k = 0; k < wave.pending.size(); ++k)
      if (!wave.blocked[k]) *wave.pending[k].slot += wave.pending[k].contribution;
  }
}

// ---- photon mapping ----------------------------------------------------------------------------

struct VisiblePoint {
  glm::vec3 position{0.0f}, normal{0.0f}, wo{0.0f}, beta{0.0f}, albedo{0.0f};
  float distance = 0;            // camera path length, for the automatic initial radius
  uint32_t specular_prefix = 0;  // specular vertices before it (C S^k D)
  bool valid = false;
};

// Follows the camera path through specular vertices to the first diffuse one (C S* D).
bool find_visible_point(const EmbreeScene& world, const Rig& rig, float px, float py, Pcg32& rng,
                        uint32_t budget, VisiblePoint& vp, uint64_t& rays) {
  const scene::Scene& scene = world.scene();
  glm::vec3 origin = rig.position, dir = rig.direction(px, py), beta(1.f);
  float distance = 0;
  vp.valid = false;
  for (uint32_t depth = 0; depth < budget; ++depth) {
    Hit hit;
    ++rays;
    if (!world.intersect(origin, dir, kUnboundedRay, hit)) return false;
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
      vp.specular_prefix = depth;
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

// One photon as the gather reads it (52 bytes where PhotonRecord has 96): what the gather tests
// and sums, stored in cell order so that a cell's photons are one contiguous run.
struct GatherPhoton {
  glm::vec3 position;
  uint32_t bounce_caustic;  // bounce << 1 | 1 for a caustic photon (L S+ D), 0 caustic-indirect
  glm::vec3 power;
  glm::vec3 normal;
  glm::vec3 wi;  // towards where the photon came from (-PhotonRecord::direction)
};

// Grid cell edge over the mean gather radius. (measured: bench below)
constexpr double kCellPerRadius = 2.0;

// A hash grid over one iteration's photons. Each bucket holds its photons in photon order, so a
// visible point sums the same photons in the same order whatever the thread count.
class PhotonGrid {
 public:
  PhotonGrid(const std::vector<PhotonRecord>& photons, float cell, tbb::task_arena& arena)
      : inv_cell_(1.f / cell) {
    size_t buckets = 1;
    while (buckets < 2 * photons.size()) buckets <<= 1;
    mask_ = buckets - 1;
    std::vector<uint32_t> key(photons.size());
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, photons.size(), 4096),
                        [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t i = r.begin(); i != r.end(); ++i)
                            key[i] = bucket(cell_of(photons[i].position));
                        });
    });
    start_.assign(buckets + 1, 0);
    for (uint32_t k : key) ++start_[k + 1];
    for (size_t b = 0; b < buckets; ++b) start_[b + 1] += start_[b];
    std::vector<uint32_t> slot(photons.size());
    {
      std::vector<uint32_t> fill(start_.begin(), start_.end() - 1);
      for (size_t i = 0; i < photons.size(); ++i) slot[i] = fill[key[i]]++;
    }
    photons_.resize(photons.size());
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, photons.size(), 4096),
                        [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t i = r.begin(); i != r.end(); ++i) {
                            const PhotonRecord& ph = photons[i];
                            bool caustic = photon_kind(ph) == kCausticPhotons;
                            photons_[slot[i]] = {ph.position, ph.bounce << 1 | uint32_t(caustic),
                                                 ph.power, ph.normal, -ph.direction};
                          }
                        });
    });
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
            const GatherPhoton& ph = photons_[k];
            glm::vec3 d = ph.position - p;
            // A bucket may hold another cell's photons (hash collisions): count each in its own.
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
  std::vector<GatherPhoton> photons_;
  float inv_cell_;
  size_t mask_ = 0;
  std::vector<uint32_t> start_;
};

bool scene_has_specular(const scene::Scene& scene) {
  for (const auto& o : scene.objects) {
    auto t = scene.materials[o.material].type;
    if (t != scene::MaterialType::diffuse && t != scene::MaterialType::emissive) return true;
  }
  return false;
}

// What one iteration of photon mapping needs across iterations: the visible points are redrawn
// every iteration (new jitter, new specular choices), so nothing but scratch memory is kept and the
// iterations stay independent.
struct PhotonPass {
  const EmbreeScene& world;
  EmbreePhotonTracer tracer;
  const Rig& rig;
  const ReferenceOptions& options;
  uint32_t wanted, budget;
  float pixel_angle;  // footprint per metre of distance
  std::vector<VisiblePoint> vps;
  std::vector<float> radius2;
  uint64_t photon_rays = 0, photon_paths = 0;
  bool emission_set = false;  // aimed emission's densities handed to the tracer (first run)

  PhotonPass(const EmbreeScene& w, const Rig& r, const ReferenceOptions& o, uint32_t wanted_mask,
             uint32_t bounce_budget)
      : world(w), tracer(w), rig(r), options(o), wanted(wanted_mask), budget(bounce_budget) {
    pixel_angle = 2.f * rig.tan_half / rig.height;
    vps.resize(size_t(rig.width) * rig.height);
    radius2.resize(vps.size());
  }

  // Iteration `i` (1-based) of Knaus & Zwicker 2011: an independent photon-map estimate whose
  // squared radius is r_1^2 prod_{j<i} (j + alpha) / (j + 1) (their eq. 20), so that the variance
  // grows and the blur bias shrinks just fast enough for the average over iterations to converge.
  // Adds each pixel's estimate into frame[pixel * kClasses + class].
  // With stride > 1 only the pilot's grid of pixels (in_grid) gets visible points, and `paths`
  // (0: options.sppm_photons) photon paths are traced.
  void run(uint32_t iteration_seed, double radius_scale2, tbb::task_arena& arena,
           tbb::combinable<uint64_t>& ray_count, std::vector<glm::vec3>& frame, int stride = 1,
           uint32_t paths = 0) {
    const int width = rig.width, height = rig.height;
    if (!emission_set && options.sppm_aimed_emission) aim_emission(arena);
    emission_set = true;
    uint32_t vp_seed = hash_combine(iteration_seed, 0x5eedu);
    arena.execute([&] {
      tbb::parallel_for(
          tbb::blocked_range<int>(0, height, 1), [&](const tbb::blocked_range<int>& rows) {
            uint64_t& rays = ray_count.local();
            for (int y = rows.begin(); y != rows.end(); ++y)
              for (int x = 0; x < width; ++x) {
                size_t i = size_t(y) * width + x;
                VisiblePoint& vp = vps[i];
                vp.valid = false;
                if (!in_grid(x, y, stride)) continue;
                Pcg32 rng(vp_seed, i);
                glm::vec2 j = rng.next_2d();
                // A photon path makes at least one specular interaction before it reaches the
                // visible point, so the camera side may use at most budget - 2 specular vertices.
                if (find_visible_point(world, rig, x + j.x, y + j.y, rng, budget - 1, vp, rays)) {
                  float r = options.sppm_radius > 0
                                ? options.sppm_radius
                                : options.sppm_radius_footprints * pixel_angle * vp.distance;
                  radius2[i] = float(double(r) * r * radius_scale2);
                }
              }
          });
    });
    double r_sum = 0;
    size_t r_count = 0;
    for (size_t i = 0; i < vps.size(); ++i)
      if (vps[i].valid) r_sum += std::sqrt(radius2[i]), ++r_count;
    if (r_count == 0) return;
    PhotonBatch batch;
    TraceSettings ts;
    ts.paths = paths ? paths : options.sppm_photons;
    // L S+ D photons feed caustics and indirect_caustics; L S+ D (D|S)* D ones indirect and
    // specular.
    ts.store = 0;
    if (wanted & (class_bit(PathClass::caustics) | class_bit(PathClass::indirect_caustics)))
      ts.store |= kCausticPhotons;
    if (wanted & (class_bit(PathClass::indirect) | class_bit(PathClass::specular)))
      ts.store |= kCausticIndirectPhotons;
    ts.max_bounces = std::min(31u, budget);
    ts.seed = hash_combine(iteration_seed, 0x9407u);
    ts.seed_per_frame = false;
    ts.rr_start = 0;
    arena.execute([&] { tracer.trace(ts, batch); });
    photon_rays += batch.stats.rays;
    photon_paths += batch.stats.paths;
    if (batch.photons.empty()) return;
    PhotonGrid grid(batch.photons, float(kCellPerRadius * r_sum / r_count), arena);
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, vps.size(), 256),
                        [&](const tbb::blocked_range<size_t>& range) {
                          for (size_t i = range.begin(); i != range.end(); ++i)
                            gather(grid, i, frame);
                        });
    });
  }

  // Aimed emission (above): valid because every photon this pass stores had a specular first
  // interaction (ts.store holds caustic kinds only).
  void aim_emission(tbb::task_arena& arena) {
    std::vector<std::optional<EmissionDensity>> densities;
    arena.execute([&] { densities = aimed_emission_densities(world); });
    for (uint32_t e = 0; e < densities.size(); ++e)
      if (densities[e]) tracer.set_emission_density(e, &*densities[e]);
  }

  void gather(const PhotonGrid& grid, size_t i, std::vector<glm::vec3>& frame) const {
    const VisiblePoint& vp = vps[i];
    if (!vp.valid) return;
    float cos_o = glm::dot(vp.wo, vp.normal);
    if (cos_o <= 0) return;
    glm::dvec3 phi[2] = {glm::dvec3(0.0), glm::dvec3(0.0)};  // caustic-indirect, pure caustic
    uint32_t max_photon_hits = budget - vp.specular_prefix;  // scattering vertices left for it
    float r2 = radius2[i];
    grid.for_each_near(vp.position, std::sqrt(r2), [&](const GatherPhoton& ph) {
      // Same side of the same surface (no leaks through thin walls), a reflection, and a path short
      // enough (the photon's hits, the visible point included, plus the camera's specular prefix).
      if (glm::dot(ph.normal, vp.normal) <= 0.5f || glm::dot(ph.wi, vp.normal) <= 0 ||
          (ph.bounce_caustic >> 1) + 1 > max_photon_hits)
        return;
      phi[ph.bounce_caustic & 1u] += glm::dvec3(ph.power);
    });
    for (glm::dvec3& p : phi) p *= glm::dvec3(vp.albedo * kInvPi);
    double norm = 1.0 / (kPi * double(r2));
    glm::dvec3 beta(vp.beta);
    // caustic photons: caustics (C D S+ L) or indirect_caustics (C S+ D S+ L); caustic-indirect
    // ones: indirect or specular.
    int pure = int(vp.specular_prefix > 0 ? PathClass::indirect_caustics : PathClass::caustics);
    int mixed = int(vp.specular_prefix > 0 ? PathClass::specular : PathClass::indirect);
    frame[i * kClasses + pure] += glm::vec3(beta * phi[1] * norm);
    frame[i * kClasses + mixed] += glm::vec3(beta * phi[0] * norm);
  }
};

// ---- accumulation over iterations ---------------------------------------------------------------

// Per pixel and requested class: sums over iterations of the iteration image, of its square, of
// the odd iterations' images, and of the squared luminance (for the error estimate).
struct Moments {
  glm::dvec3 sum{0.0}, sum2{0.0}, odd{0.0};
  double lum2 = 0;
};

class Accumulator {
 public:
  Accumulator(size_t pixels, uint32_t class_mask) : pixels_(pixels) {
    for (int c = 0; c < kPathClassCount; ++c)
      if (class_mask & (1u << c)) classes_.push_back(c);
    moments_.resize(pixels * classes_.size());
  }
  // Adds iteration `iteration` (0-based) from frame[pixel * kClasses + class].
  void add(uint32_t iteration, const std::vector<glm::vec3>& frame, tbb::task_arena& arena) {
    bool odd = iteration % 2 == 1;
    size_t k = classes_.size();
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, pixels_, 1024),
                        [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t i = r.begin(); i != r.end(); ++i) {
                            const glm::vec3* f = &frame[i * kClasses];
                            // The classes' sum in float (one conversion, not five): an
                            // iteration's image is float, its rounding far below the noise.
                            glm::vec3 combined = f[0];
                            for (int q = 1; q < kClasses; ++q) combined += f[q];
                            for (size_t j = 0; j < k; ++j) {
                              int c = classes_[j];
                              const glm::dvec3 v(c == int(PathClass::combined) ? combined : f[c]);
                              Moments& m = moments_[i * k + j];
                              m.sum += v;
                              m.sum2 += v * v;
                              if (odd) m.odd += v;
                              double l = luminance(glm::vec3(v));
                              m.lum2 += l * l;
                            }
                          }
                        });
    });
    ++iterations_;
  }
  uint32_t iterations() const { return iterations_; }

  // Mean luminance over the image of class slot j.
  double mean_luminance(size_t j) const {
    if (iterations_ == 0) return 0;
    double acc = 0;
    size_t k = classes_.size();
    for (size_t i = 0; i < pixels_; ++i) acc += luminance(glm::vec3(moments_[i * k + j].sum));
    return acc / (double(iterations_) * double(pixels_));
  }

  // reference.h's error estimate over the requested classes; 0 before two iterations.
  double rel_error() const {
    if (iterations_ < 2) return 0;
    double n = iterations_, acc = 0;
    size_t k = classes_.size(), counted = 0;
    for (size_t j = 0; j < k; ++j) {
      double mean_lum = 0;
      for (size_t i = 0; i < pixels_; ++i)
        mean_lum += luminance(glm::vec3(moments_[i * k + j].sum));
      mean_lum /= n * double(pixels_);
      if (!(mean_lum > 0)) continue;
      double floor2 = std::pow(0.01 * mean_lum, 2.0);
      for (size_t i = 0; i < pixels_; ++i) {
        const Moments& m = moments_[i * k + j];
        double mean = luminance(glm::vec3(m.sum)) / n;
        double var_of_mean = std::max(0.0, m.lum2 - n * mean * mean) / (n * (n - 1));
        acc += var_of_mean / (mean * mean + floor2);
      }
      ++counted;
    }
    return counted ? std::sqrt(acc / double(counted * pixels_)) : 0.0;
  }

  // Mean, variance of the mean and the even/odd halves of class slot j.
  void resolve(size_t j, int width, int height, ReferenceImage& out) const {
    out.mean = io::Image(width, height, 3);
    out.variance = io::Image(width, height, 3);
    out.half[0] = io::Image(width, height, 3);
    out.half[1] = io::Image(width, height, 3);
    double n = iterations_;
    double n_odd = iterations_ / 2, n_even = iterations_ - iterations_ / 2;
    size_t k = classes_.size();
    for (size_t i = 0; i < pixels_; ++i) {
      const Moments& m = moments_[i * k + j];
      for (int ch = 0; ch < 3; ++ch) {
        double mean = n > 0 ? m.sum[ch] / n : 0.0;
        double var = n > 1 ? std::max(0.0, m.sum2[ch] - n * mean * mean) / (n * (n - 1)) : 0.0;
        out.mean.pixels[i * 3 + ch] = float(mean);
        out.variance.pixels[i * 3 + ch] = float(var);
        out.half[0].pixels[i * 3 + ch] = n_even > 0 ? float((m.sum[ch] - m.odd[ch]) / n_even) : 0.f;
        out.half[1].pixels[i * 3 + ch] = n_odd > 0 ? float(m.odd[ch] / n_odd) : 0.f;
      }
    }
  }
  const std::vector<int>& classes() const { return classes_; }

 private:
  size_t pixels_;
  std::vector<int> classes_;
  std::vector<Moments> moments_;
  uint32_t iterations_ = 0;
};

// Estimator::automatic's pilot (reference.h): on a grid of pixels, per requested class, the
// luminance moments of path tracing's, bidirectional path tracing's and photon mapping's estimates.
class Pilot {
 public:
  enum Part { path_tracing, bidirectional, splats, photons };
  Pilot(int width, int height, int stride, const std::vector<int>& classes)
      : classes_(classes), stride_(stride) {
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        if (in_grid(x, y, stride)) pixels_.push_back(size_t(y) * width + x);
    for (auto& m : moments_) m.resize(pixels_.size() * classes_.size());
  }
  // One iteration of `part`, read from frame[pixel * kClasses + class] at the grid's pixels. The
  // render's frame holds path tracing's image and then, once photon mapping has added to it, the
  // sum of both: photon mapping's part is that sum less the path tracing image added last
  // (luminance is linear).
  void add(Part part, const std::vector<glm::vec3>& frame) {
    const size_t k = classes_.size();
    if (part == path_tracing) last_path_tracing_.assign(pixels_.size() * k, 0.0);
    for (size_t p = 0; p < pixels_.size(); ++p) {
      const glm::vec3* v = &frame[pixels_[p] * kClasses];
      for (size_t j = 0; j < k; ++j) {
        double l = 0;
        if (classes_[j] == int(PathClass::combined))
          for (int c = 0; c < kClasses; ++c) l += luminance(v[c]);
        else
          l = luminance(v[classes_[j]]);
        size_t slot = p * k + j;
        if (part == path_tracing) last_path_tracing_[slot] = l;
        if (part == photons && !last_path_tracing_.empty()) l -= last_path_tracing_[slot];
        moments_[part][slot].add(l);
      }
    }
    ++iterations_[part];
  }
  uint32_t iterations(Part part) const { return iterations_[part]; }
  // The error estimate's square (reference.h) for one full-image iteration of path tracing or of
  // bidirectional path tracing, plus photon mapping, relative to the pixel means of both unbiased
  // estimators averaged plus photon mapping's (a short run of path tracing alone can miss the light
  // of a small bright region at many pixels, and dividing by its low mean there would inflate the
  // other estimator's relative variance). Light tracing's splats on the grid stand for stride^2
  // light paths each, so their variance is scaled by 1 / stride^2 to a full iteration's; path
  // tracing's and photon mapping's come from the render's own full iterations.
  double error2(bool bdpt) const {
    std::vector<double> class_mean(classes_.size(), 0.0);
    for (size_t p = 0; p < pixels_.size(); ++p)
      for (size_t j = 0; j < classes_.size(); ++j) class_mean[j] += mean(p, j) / pixels_.size();
    double acc = 0;
    size_t counted = 0;
    for (size_t p = 0; p < pixels_.size(); ++p)
      for (size_t j = 0; j < classes_.size(); ++j) {
        if (!(class_mean[j] > 0)) continue;
        size_t slot = p * classes_.size() + j;
        double var = variance(photons, slot);
        var += bdpt ? variance(bidirectional, slot) +
                          variance(splats, slot) / (double(stride_) * stride_)
                    : variance(path_tracing, slot);
        double m = mean(p, j);
        acc += var / (m * m + std::pow(0.01 * class_mean[j], 2.0));
        ++counted;
      }
    return counted ? acc / double(counted) : 0.0;
  }

 private:
  struct Moment {
    double s1 = 0, s2 = 0;
    void add(double v) { s1 += v, s2 += v * v; }
    double mean(uint32_t n) const { return n ? s1 / n : 0.0; }
    double variance(uint32_t n) const {
      return n > 1 ? std::max(0.0, s2 - s1 * s1 / n) / (n - 1) : 0.0;
    }
  };
  double variance(Part part, size_t slot) const {
    return moments_[part][slot].variance(iterations_[part]);
  }
  double mean(Part part, size_t slot) const { return moments_[part][slot].mean(iterations_[part]); }
  double mean(size_t p, size_t j) const {
    size_t slot = p * classes_.size() + j;
    return 0.5 * (mean(path_tracing, slot) + mean(bidirectional, slot) + mean(splats, slot)) +
           mean(photons, slot);
  }
  std::vector<int> classes_;
  int stride_;
  std::vector<size_t> pixels_;
  std::array<std::vector<Moment>, 4> moments_;
  std::array<uint32_t, 4> iterations_{};
  std::vector<double> last_path_tracing_;  // the grid's luminances of the last path tracing image
};

// The pilot's grid: every stride-th pixel in x and y, about 2000 pixels. (1000, which would halve
// the pilot's cost on short renders, picked path tracing on cornell-box in both rounds of
// bench_reference at 320x180: too few pixels see its hotspot's paths.)
int pilot_stride(size_t pixels) { return std::max(1, int(std::sqrt(double(pixels) / 2000.0))); }

// The path-tracing pass over every pixel of the grid of `stride` (every pixel: stride 1), a row
// at a time (the wavefront above).
void path_tracing_pass(const EmbreeScene& world, const LightSet& lights, const Rig& rig,
                       const ReferenceOptions& options, uint32_t wanted, uint32_t budget,
                       uint32_t iteration_seed, int stride, tbb::task_arena& arena,
                       tbb::combinable<uint64_t>& ray_count, std::vector<glm::vec3>& frame) {
  const PathTracingSetup setup{world,
                               lights,
                               wanted,
                               budget,
                               options.light_strategies != LightStrategies::bsdf_only,
                               options.light_strategies != LightStrategies::nee_only};
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, rig.height, 1),
                      [&](const tbb::blocked_range<int>& rows) {
                        uint64_t& rays = ray_count.local();
                        PathWavefront wave;
                        for (int y = rows.begin(); y != rows.end(); ++y) {
                          wave.paths.clear();
                          for (int x = 0; x < rig.width; ++x) {
                            if (!in_grid(x, y, stride)) continue;
                            size_t i = size_t(y) * rig.width + x;
                            CameraPath path(Pcg32(iteration_seed, i));
                            glm::vec2 j = path.rng.next_2d();
                            path.ray = Ray{rig.position, rig.direction(x + j.x, y + j.y)};
                            path.prev_position = rig.position;
                            path.out = &frame[i * kClasses];
                            for (int c = 0; c < kClasses; ++c) path.out[c] = glm::vec3(0.f);
                            wave.paths.push_back(path);
                          }
                          advance_wavefront(setup, wave, rays);
                        }
                      });
  });
}

// Estimator::automatic (reference.h): the render starts as path tracing, and the pilot watches it.
// Path tracing's and photon mapping's iterations are the render's own (read at the grid's pixels),
// so they cost the pilot nothing and are kept when path tracing stays; beside each, one iteration
// of bidirectional path tracing on the grid of about 2000 pixels is the pilot's only extra work.
// After every iteration it predicts from the per-iteration variances and rays what reaching the
// target costs with either and decides:
//   * bidirectional path tracing, from kPilotMinIterations on, when predicted cheaper by
//     kPilotMargin than what path tracing has left to do (the render then restarts with it, so
//     the image is exactly its render; path tracing's iterations are dropped);
//   * path tracing when the pilot's next iteration would take its spending past kPilotBudget of
//     path tracing's predicted render, or after kPilotIterations: its cost scales with the render,
//     and where the render is short path tracing, the anchor, keeps it.
// A small bright region that path tracing finds by chance hides in a short pilot (its variance
// grows with the samples), so path tracing's prediction is low early on: the rule that stops the
// pilot early can only pick path tracing, whose cost is then the one predicted.
class EstimatorPilot {
 public:
  EstimatorPilot(const Rig& rig, const ReferenceOptions& options, const std::vector<int>& classes,
                 BdptPass& bdpt, tbb::task_arena& arena, tbb::combinable<uint64_t>& ray_count)
      : options_(options),
        bdpt_(bdpt),
        arena_(arena),
        ray_count_(ray_count),
        stride_(pilot_stride(size_t(rig.width) * rig.height)),
        pilot_(rig.width, rig.height, stride_, classes),
        frame_size_(size_t(rig.width) * rig.height * kClasses),
        seed_(hash_combine(options.seed, 0x9170u)) {}

  // The render's image after its path tracing pass (path_tracing) or after photon mapping added
  // to it (photons), and the rays that pass traced.
  void observe(Pilot::Part part, const std::vector<glm::vec3>& frame, uint64_t rays) {
    pilot_.add(part, frame);
    (part == Pilot::photons ? photon_rays_ : pt_rays_) += double(rays);
  }

  // After the render's iteration `done` (1-based): one bidirectional iteration on the grid where
  // it can still change the choice, then the decision; nothing while the pilot goes on.
  std::optional<Estimator> step(uint32_t done) {
    watched_ = done;
    if (done < 2) return std::nullopt;  // path tracing's variance needs two iterations
    predict(done);
    uint32_t bdpt_done = pilot_.iterations(Pilot::bidirectional);
    if (bdpt_done < kPilotBdptIterations && bdpt_could_win(done)) {
      if (bdpt_done > 0 && over_budget(bdpt_done)) return Estimator::pt;
      run_bidirectional(bdpt_done);
      predict(done);
      ++bdpt_done;
    }
    if (bdpt_done >= kPilotMinIterations &&
        report_.bdpt_cost * kPilotMargin < pt_left(done, report_.pt_cost))
      return Estimator::bdpt;
    if (done >= kPilotIterations) return Estimator::pt;
    return std::nullopt;
  }

  PilotReport report() const {
    PilotReport r = report_;
    r.ran = true;
    r.iterations = watched_;
    r.bdpt_iterations = pilot_.iterations(Pilot::bidirectional);
    r.pilot_rays = spent_;
    return r;
  }

 private:
  // Per-iteration error^2 and rays of each (photon mapping's in both), and the predicted cost of
  // reaching the target: iterations (error^2 falls as 1 / n) x rays per iteration.
  void predict(uint32_t done) {
    uint32_t n_photon = std::max(1u, pilot_.iterations(Pilot::photons));
    uint32_t n_bdpt = std::max(1u, pilot_.iterations(Pilot::bidirectional));
    report_.pt_rays = pt_rays_ / done, report_.bdpt_rays = bdpt_rays_ / n_bdpt;
    report_.photon_rays = photon_rays_ / n_photon;
    report_.pt_error2 = pilot_.error2(false);
    report_.bdpt_error2 = pilot_.error2(true);
    double pt_iteration = report_.pt_rays_per_iteration();
    double bdpt_iteration = kBdptRayCost * report_.bdpt_rays + report_.photon_rays;
    if (options_.rel_error > 0) {
      double target2 = double(options_.rel_error) * options_.rel_error;
      double least = std::max(2u, options_.min_samples);
      report_.pt_cost = std::max(least, report_.pt_error2 / target2) * pt_iteration;
      report_.bdpt_cost = std::max(least, report_.bdpt_error2 / target2) * bdpt_iteration;
    } else {  // error^2 x cost per iteration: the cost of any given error
      report_.pt_cost = report_.pt_error2 * pt_iteration;
      report_.bdpt_cost = report_.bdpt_error2 * bdpt_iteration;
    }
    report_.budget = kPilotBudget * predicted_pt_render();
  }
  // What path tracing has left to do after `done` iterations (to the target; for a render without
  // one, the cost of any given error has nothing left behind).
  double pt_left(uint32_t done, double pt_cost) const {
    if (!(options_.rel_error > 0)) return pt_cost;
    return pt_cost - double(done) * report_.pt_rays_per_iteration();
  }
  // Whether bidirectional path tracing could be picked on what the pilot knows: its cost has a
  // floor whatever its variance (the error rule's least iterations, at its rays per iteration),
  // and while that floor is above what path tracing has left, its pilot iterations would buy
  // nothing (they resume if path tracing's prediction grows, as it does where it finds a bright
  // region by chance). Before its first iteration its rays are taken to be path tracing's (its
  // camera subpaths alone trace those; it traced 1.4 to 3 times as many on the shipped scenes).
  bool bdpt_could_win(uint32_t done) const {
    if (!(options_.rel_error > 0)) return true;
    double least = std::max(2u, options_.min_samples);
    double bdpt_rays =
        pilot_.iterations(Pilot::bidirectional) ? report_.bdpt_rays : report_.pt_rays;
    double floor = least * (kBdptRayCost * bdpt_rays + report_.photon_rays);
    return floor * kPilotMargin < pt_left(done, report_.pt_cost);
  }
  // Whether one more pilot iteration, costing about what the last ones did, would take the
  // pilot's own rays past kPilotBudget of path tracing's predicted render, or its own time past
  // kPilotBudget of the render's time limit: a render that the limit ends is as long as the limit
  // (and not reproducible by its seed anyway), and rays undercount bidirectional path tracing's
  // work on long paths (its MIS weights grow with the path: on villa, 32 pilot iterations on a
  // 25th of the pixels took 1.06 s of a render of 76 iterations in 10 s, bench_reference).
  bool over_budget(uint32_t bdpt_done) const {
    double rays = spent_ * (bdpt_done + 1.0) / bdpt_done;
    double seconds = report_.seconds * (bdpt_done + 1.0) / bdpt_done;
    return rays > report_.budget ||
           (options_.max_seconds > 0 && seconds > kPilotBudget * options_.max_seconds);
  }
  void run_bidirectional(uint32_t index) {
    auto t0 = std::chrono::steady_clock::now();
    if (frame_.empty()) frame_.resize(frame_size_), splat_frame_.resize(frame_size_);
    const double scale = double(stride_) * stride_;  // full-image rays per grid ray
    uint64_t rays = bdpt_.run(hash_combine(seed_, index, 1u), arena_, ray_count_, frame_, stride_,
                              &splat_frame_);
    bdpt_rays_ += scale * double(rays);
    spent_ += kBdptRayCost * double(rays);
    pilot_.add(Pilot::bidirectional, frame_);
    pilot_.add(Pilot::splats, splat_frame_);
    report_.seconds += io::seconds_since(t0);
  }
  // Path tracing's whole render, in rays: to the error target, or the samples asked for, whichever
  // is fewer; a render stopped by its time limit alone has no prediction (the pilot runs in full).
  double predicted_pt_render() const {
    double render = std::numeric_limits<double>::infinity();
    if (options_.rel_error > 0) render = report_.pt_cost;
    if (options_.samples > 0)
      render = std::min(render, double(options_.samples) * report_.pt_rays_per_iteration());
    return render;
  }

  const ReferenceOptions& options_;
  BdptPass& bdpt_;
  tbb::task_arena& arena_;
  tbb::combinable<uint64_t>& ray_count_;
  int stride_;
  Pilot pilot_;
  size_t frame_size_;
  std::vector<glm::vec3> frame_, splat_frame_;  // allocated at the first bidirectional iteration
  uint32_t seed_;
  double pt_rays_ = 0, photon_rays_ = 0, bdpt_rays_ = 0;  // full-image rays, summed
  double spent_ = 0;      // the pilot's own rays, bidirectional ones weighted by kBdptRayCost
  uint32_t watched_ = 0;  // render iterations seen
  PilotReport report_;
};

}  // namespace

std::string_view stop_rule_name(StopRule rule) { return kStopRuleNames[int(rule)]; }
std::optional<StopRule> parse_stop_rule(std::string_view name) {
  for (int r = 0; r < 3; ++r)
    if (kStopRuleNames[r] == name) return StopRule(r);
  return std::nullopt;
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
  if (!(options.rel_error > 0) && !(options.max_seconds > 0) && options.samples == 0)
    throw InputError("reference: no stop rule (rel_error, max_seconds and samples are all off)");
  auto t0 = std::chrono::steady_clock::now();
  const scene::Scene& scene = world.scene();
  LightSet lights(world);
  Rig rig(world.state().camera, width, height);
  uint32_t wanted = class_mask & class_bit(PathClass::combined) ? kAllPathClasses : class_mask;
  uint32_t budget = bounce_budget(options.max_bounces);
  // Photon mapping has work when photons can add to a wanted class (any but `direct`) in a scene
  // with specular surfaces (without them its part of path space is empty), and when paths may have
  // the two scattering vertices (L S D) its paths need at least.
  uint32_t photon_classes = class_bit(PathClass::indirect) | class_bit(PathClass::caustics) |
                            class_bit(PathClass::indirect_caustics) |
                            class_bit(PathClass::specular);
  bool use_photons =
      (wanted & photon_classes) && scene_has_specular(scene) && lights.size() > 0 && budget >= 2;

  size_t pixels = size_t(width) * height;
  std::vector<glm::vec3> frame(pixels * kClasses);
  auto acc = std::make_unique<Accumulator>(pixels, class_mask);
  auto arena = options.threads > 0 ? std::make_unique<tbb::task_arena>(options.threads)
                                   : std::make_unique<tbb::task_arena>();
  tbb::combinable<uint64_t> ray_count([] { return uint64_t(0); });
  std::unique_ptr<PhotonPass> photons;
  if (use_photons) photons = std::make_unique<PhotonPass>(world, rig, options, wanted, budget);
  auto total_rays = [&] {
    uint64_t rays = photons ? photons->photon_rays : 0;
    ray_count.combine_each([&](uint64_t r) { rays += r; });
    return rays;
  };
  // The automatic choice pilots (EstimatorPilot) on an image of at least 9 times the pilot's
  // pixels and a render not limited to a few iterations; smaller renders are bidirectional.
  Estimator estimator = options.estimator;
  std::unique_ptr<BdptPass> bdpt;
  if (estimator != Estimator::pt)
    bdpt = std::make_unique<BdptPass>(world, lights, rig, wanted, budget, options.mis_heuristic);
  PilotReport report;
  std::unique_ptr<EstimatorPilot> pilot;
  if (estimator == Estimator::automatic) {
    bool worth = (options.samples == 0 || options.samples >= 8 * kPilotIterations) &&
                 pilot_stride(pixels) >= 3;
    if (worth)
      pilot =
          std::make_unique<EstimatorPilot>(rig, options, acc->classes(), *bdpt, *arena, ray_count);
    estimator = worth ? Estimator::pt : Estimator::bdpt;
  }

  double rel_error = 0, radius_scale2 = 1;
  StopRule stopped_by = StopRule::samples;
  for (uint32_t it = 0;; ++it) {
    uint32_t iteration_seed = hash_combine(options.seed, it);
    uint64_t rays_before = pilot ? total_rays() : 0;
    // ---- the unbiased estimator: one camera sample per pixel ----
    if (estimator == Estimator::bdpt)
      bdpt->run(iteration_seed, *arena, ray_count, frame);
    else
      path_tracing_pass(world, lights, rig, options, wanted, budget, iteration_seed, 1, *arena,
                        ray_count, frame);
    if (pilot) pilot->observe(Pilot::path_tracing, frame, total_rays() - rays_before);
    // ---- photon mapping: visible points, photons, gather ----
    if (photons) {
      if (it > 0) radius_scale2 *= (it + options.sppm_alpha) / (it + 1.0);
      uint64_t photon_rays_before = total_rays();
      photons->run(iteration_seed, radius_scale2, *arena, ray_count, frame);
      if (pilot) pilot->observe(Pilot::photons, frame, total_rays() - photon_rays_before);
    }
    acc->add(it, frame, *arena);
    // ---- stop rules: the first reached ends the render ----
    uint32_t done = acc->iterations();
    double elapsed = io::seconds_since(t0);
    bool stop = false;
    if (done % 2 == 0 && done > 0) {  // the error and time rules stop on even counts
      if (options.rel_error > 0 && done >= std::max(2u, options.min_samples)) {
        rel_error = acc->rel_error();
        if (rel_error <= options.rel_error) stop = true, stopped_by = StopRule::rel_error;
      }
      if (!stop && options.max_seconds > 0 && elapsed >= options.max_seconds)
        stop = true, stopped_by = StopRule::max_seconds;
    }
    if (!stop && options.samples > 0 && done >= options.samples)
      stop = true, stopped_by = StopRule::samples;
    if (progress)
      progress({done, options.samples, rel_error, options.rel_error, elapsed, options.max_seconds,
                total_rays()});
    if (stop) break;
    // ---- the automatic choice: bidirectional path tracing restarts the render ----
    if (pilot) {
      if (std::optional<Estimator> chosen = pilot->step(acc->iterations())) {
        report = pilot->report();
        pilot.reset();
        estimator = *chosen;
        if (estimator == Estimator::bdpt) {
          report.dropped_iterations = acc->iterations();
          acc = std::make_unique<Accumulator>(pixels, class_mask);
          radius_scale2 = 1;
          it = std::numeric_limits<uint32_t>::max();  // the next iteration is 0
        }
      }
    }
  }

  if (pilot) report = pilot->report();  // the render ended while the pilot still ran

  // ---- resolve ----
  ReferenceResult result;
  result.samples = acc->iterations();
  result.photon_paths = photons ? photons->photon_paths : 0;
  result.seed = options.seed;
  result.rel_error = acc->rel_error();
  result.stopped_by = stopped_by;
  result.estimator = estimator;
  result.pilot = report;
  result.rays = total_rays();
  result.seconds = io::seconds_since(t0);
  for (size_t j = 0; j < acc->classes().size(); ++j) {
    ReferenceImage& img = result.classes[acc->classes()[j]];
    acc->resolve(j, width, height, img);
    img.samples = result.samples;
    img.seed = options.seed;
    img.seconds = result.seconds;
    img.rel_error = result.rel_error;
    img.stopped_by = stopped_by;
    img.max_bounces = options.max_bounces;
    img.estimator = estimator;
  }
  return result;
}

ReferenceImage render_reference(const scene::Scene& scene, const scene::FrameState& state,
                                PathClass path_class, int width, int height,
                                const ReferenceOptions& options, const ProgressFn& progress) {
  EmbreeScene world(scene, state, one_frame_options());
  ReferenceResult r =
      render_reference_classes(world, width, height, class_bit(path_class), options, progress);
  return std::move(r.classes[int(path_class)]);
}

}  // namespace pb::trace
