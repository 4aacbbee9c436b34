#include "reference/photon_mapping_pass.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "trace/bsdf.h"
#include "trace/sampling.h"

namespace pb::trace::detail {
namespace {

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

}  // namespace

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

PhotonMappingPass::PhotonMappingPass(const EmbreeScene& world, const Rig& rig,
                                     const PhotonMappingOptions& options, uint32_t wanted,
                                     uint32_t budget)
    : world_(world),
      tracer_(world),
      rig_(rig),
      options_(options),
      wanted_(wanted),
      budget_(budget) {
  pixel_angle_ = 2.f * rig_.tan_half / rig_.height;
  vps_.resize(size_t(rig_.width) * rig_.height);
  radius2_.resize(vps_.size());
}

void PhotonMappingPass::run(uint32_t iteration_seed, double radius_scale2, tbb::task_arena& arena,
                            tbb::combinable<uint64_t>& ray_count, std::vector<glm::vec3>& frame,
                            int stride, uint32_t paths) {
  const int width = rig_.width, height = rig_.height;
  if (!emission_set_ && options_.aimed_emission) aim_emission(arena);
  emission_set_ = true;
  uint32_t vp_seed = hash_combine(iteration_seed, 0x5eedu);
  arena.execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<int>(0, height, 1), [&](const tbb::blocked_range<int>& rows) {
          uint64_t& rays = ray_count.local();
          for (int y = rows.begin(); y != rows.end(); ++y)
            for (int x = 0; x < width; ++x) {
              size_t i = size_t(y) * width + x;
              VisiblePoint& vp = vps_[i];
              vp.valid = false;
              if (!in_grid(x, y, stride)) continue;
              Pcg32 rng(vp_seed, i);
              glm::vec2 j = rng.next_2d();
              // A photon path makes at least one specular interaction before it reaches the
              // visible point, so the camera side may use at most budget_ - 2 specular vertices.
              if (find_visible_point(world_, rig_, x + j.x, y + j.y, rng, budget_ - 1, vp, rays)) {
                float r = options_.radius > 0
                              ? options_.radius
                              : options_.radius_footprints * pixel_angle_ * vp.distance;
                radius2_[i] = float(double(r) * r * radius_scale2);
              }
            }
        });
  });
  double r_sum = 0;
  size_t r_count = 0;
  for (size_t i = 0; i < vps_.size(); ++i)
    if (vps_[i].valid) r_sum += std::sqrt(radius2_[i]), ++r_count;
  if (r_count == 0) return;
  PhotonBatch batch;
  TraceSettings ts;
  ts.paths = paths ? paths : options_.photons;
  // L S+ D photons feed caustics and indirect_caustics; L S+ D (D|S)* D ones indirect and
  // specular.
  ts.store = 0;
  if (wanted_ & (class_bit(PathClass::caustics) | class_bit(PathClass::indirect_caustics)))
    ts.store |= kCausticPhotons;
  if (wanted_ & (class_bit(PathClass::indirect) | class_bit(PathClass::specular)))
    ts.store |= kCausticIndirectPhotons;
  ts.max_bounces = std::min(31u, budget_);
  ts.seed = hash_combine(iteration_seed, 0x9407u);
  ts.seed_per_frame = false;
  ts.rr_start = 0;
  arena.execute([&] { tracer_.trace(ts, batch); });
  photon_rays_ += batch.stats.rays;
  photon_paths_ += batch.stats.paths;
  if (batch.photons.empty()) return;
  PhotonGrid grid(batch.photons, float(kCellPerRadius * r_sum / r_count), arena);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, vps_.size(), 256),
                      [&](const tbb::blocked_range<size_t>& range) {
                        for (size_t i = range.begin(); i != range.end(); ++i)
                          gather(grid, i, frame);
                      });
  });
}

// Aimed emission, the tracer's density policy (PhotonTracer::aimed_emission_densities; README
// "Photon mapping's cost"): valid because every photon this pass stores had a specular first
// interaction (ts.store holds caustic kinds only).
void PhotonMappingPass::aim_emission(tbb::task_arena& arena) {
  arena.execute([&] { trace::aim_emission(tracer_); });
}

void PhotonMappingPass::gather(const PhotonGrid& grid, size_t i,
                               std::vector<glm::vec3>& frame) const {
  const VisiblePoint& vp = vps_[i];
  if (!vp.valid) return;
  float cos_o = glm::dot(vp.wo, vp.normal);
  if (cos_o <= 0) return;
  glm::dvec3 phi[2] = {glm::dvec3(0.0), glm::dvec3(0.0)};   // caustic-indirect, pure caustic
  uint32_t max_photon_hits = budget_ - vp.specular_prefix;  // scattering vertices left for it
  float r2 = radius2_[i];
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

}  // namespace pb::trace::detail
