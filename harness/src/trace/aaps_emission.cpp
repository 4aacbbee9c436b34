// AAPS's emission (seed 004 §1.4-1.5): photons emitted from the task buffer's density texture in
// the order of a sum-quadtree walk, each traced by the thesis's rules.
#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "io/clock.h"
#include "photonbench/error.h"
#include "trace/bsdf.h"
#include "trace/photon_paths.h"
#include "trace/photon_tracer.h"

namespace pb::trace {

using namespace detail;

namespace {

// Interleaves the bits of x (even bits) and y (odd bits): the order in which a sum quadtree with
// children (0,0), (1,0), (0,1), (1,1) lists its leaves.
uint32_t morton_xy(uint32_t x, uint32_t y) {
  uint32_t code = 0;
  for (uint32_t b = 0; b < 16; ++b)
    code |= ((x >> b) & 1u) << (2 * b) | ((y >> b) & 1u) << (2 * b + 1);
  return code;
}

enum class Interaction { none, reflect, refract };

// One part of an AAPS photon: its state leaving interaction k - 1.
struct AapsPart {
  PathVertex v;
  uint32_t k = 0;  // interactions so far
  Interaction last = Interaction::none;
  bool split = false;
  bool refracted_half = false;  // the refracted part of the split (PhotonRecord::flags)
};

// Traces one AAPS photon from `start` by the thesis's rules (TraceSettings::aaps), appending the
// photons its parts store; returns the rays traced.
uint64_t trace_aaps_photon(const EmbreeScene& world, const PathVertex& start, uint32_t light,
                           uint32_t task, uint32_t max_bounces,
                           std::vector<PhotonRecord>& photons) {
  const scene::Scene& scene = world.scene();
  AapsPart stack[2];  // a photon splits once, so at most one part waits
  int waiting = 0;
  stack[waiting++].v = start;
  uint64_t rays = 0;
  while (waiting > 0) {
    AapsPart p = stack[--waiting];
    while (p.k < max_bounces) {
      const glm::vec3 dir = p.v.direction;
      Hit hit;
      ++rays;
      if (!world.intersect(spawn_origin(p.v), dir, kUnboundedRay, hit)) break;
      if (world.is_light_object(hit.object)) break;
      glm::vec3 ng =
          glm::dot(hit.geometric_normal, dir) > 0 ? -hit.geometric_normal : hit.geometric_normal;
      // The differentials follow the main ray's triangle even where they would miss it (§3.3.2).
      glm::vec3 dp_du = transfer_differential(dir, ng, hit.t, p.v.dp_du, p.v.dd_du);
      glm::vec3 dp_dv = transfer_differential(dir, ng, hit.t, p.v.dp_dv, p.v.dd_dv);
      const scene::Material& material = scene.materials[hit.material];
      Bsdf bsdf(material, hit);
      if (bsdf.is_diffuse()) {
        if (p.k == 0) break;  // L D: not a caustic photon
        PhotonRecord r{};
        r.position = hit.position;
        r.object = hit.object;
        r.power = p.v.power;
        r.path = task;
        r.direction = dir;
        r.bounce = p.k;
        r.normal = ng;
        r.specular_mask = p.v.specular_mask;
        r.footprint_u = dp_du * p.v.spacing;
        r.footprint_v = dp_dv * p.v.spacing;
        r.light = light;
        r.flags = p.refracted_half ? PB_PHOTON_REFRACTED_HALF : 0u;
        photons.push_back(r);
        break;
      }
      const bool dielectric = material.type == scene::MaterialType::dielectric;
      const bool mirror = material.type == scene::MaterialType::mirror;
      if (p.k == 0 && !dielectric) break;  // §1.5: the first hit must be a dielectric
      if (!dielectric && !mirror) break;   // glossy surfaces end the photon
      Triangle tri = world.triangle(hit.object, hit.primitive);
      // The part leaving this hit by reflection or refraction (refraction under total internal
      // reflection reflects), its power scaled by the Fresnel weight of that part.
      auto advance = [&](bool reflect, AapsPart& q) {
        BsdfSample s;
        bool ok = bsdf.sample(-dir, {0.5f, 0.5f, reflect ? 0.f : 1.f}, Transport::importance, s);
        if (!ok && !reflect) ok = bsdf.sample(-dir, {0.5f, 0.5f, 0.f}, Transport::importance, s);
        if (!ok) return false;
        q = p;
        q.v.power = p.v.power * s.weight * (dielectric ? s.pdf : 1.f);
        if (!(max3(q.v.power) > 0)) return false;
        q.v.position = hit.position;
        q.v.normal = ng;
        q.v.direction = s.wi;
        q.v.object = hit.object;
        q.v.specular_mask |= 1u << p.k;
        q.v.dp_du = dp_du;
        q.v.dp_dv = dp_dv;
        q.v.dd_du = scatter_differential(tri, hit, s, dir, dp_du, p.v.dd_du);
        q.v.dd_dv = scatter_differential(tri, hit, s, dir, dp_dv, p.v.dd_dv);
        q.k = p.k + 1;
        q.last = s.transmitted ? Interaction::refract : Interaction::reflect;
        return true;
      };
      AapsPart next;
      if (dielectric && !p.split) {  // §3.3.1: split once, both parts marked as split
        AapsPart reflected, refracted;
        bool has_reflected = advance(true, reflected), has_refracted = advance(false, refracted);
        reflected.split = refracted.split = true;
        refracted.refracted_half = refracted.last == Interaction::refract;
        if (has_reflected && has_refracted) stack[waiting++] = reflected;
        if (!has_reflected && !has_refracted) break;
        next = has_refracted ? refracted : reflected;
      } else if (!advance(mirror || p.last != Interaction::refract, next)) {
        break;  // then repeat the last interaction
      }
      p = next;
    }
  }
  return rays;
}

}  // namespace

GridEmission::GridEmission(const EmissionDensity& counts) {
  int side = counts.width;
  if (side <= 0 || counts.height != side || (side & (side - 1)) != 0 || side > 65536 ||
      counts.texels.size() != size_t(side) * side)
    throw InputError(fmt::format(
        "photon tracer: AAPS emission needs a square density of power-of-two side, not {}x{}",
        counts.width, counts.height));
  side_ = uint32_t(side);
  size_t n = size_t(side) * side;
  texel_.resize(n), first_.resize(n), m_.resize(n);
  for (uint32_t y = 0; y < side_; ++y)
    for (uint32_t x = 0; x < side_; ++x) texel_[morton_xy(x, y)] = y * side_ + x;
  uint64_t sum = 0;
  for (size_t k = 0; k < n; ++k) {
    float d = counts.texels[texel_[k]];
    uint32_t m = d >= 1 ? uint32_t(std::floor(std::sqrt(double(d)))) : 0;  // n = floor(sqrt(D))^2
    m_[k] = m;
    first_[k] = uint32_t(sum);
    sum += uint64_t(m) * m;
    if (sum > std::numeric_limits<uint32_t>::max())
      throw InputError("photon tracer: AAPS emission density asks for more than 2^32 photons");
  }
  total_ = uint32_t(sum);
}

GridEmission::Task GridEmission::locate(uint32_t task) const {
  // The last texel whose first task is at most `task`: texels of no photons share their successor's
  // first task, so this is the one that holds it.
  size_t k = size_t(std::upper_bound(first_.begin(), first_.end(), task) - first_.begin()) - 1;
  Task t;
  t.texel = texel_[k];
  t.m = m_[k];
  t.cell = task - first_[k];
  float x = float(t.texel % side_), y = float(t.texel / side_);
  t.uv = glm::vec2((x + (float(t.cell % t.m) + 0.5f) / float(t.m)) / float(side_),
                   (y + (float(t.cell / t.m) + 0.5f) / float(t.m)) / float(side_));
  return t;
}

glm::vec2 GridEmission::jittered(const Task& t, std::optional<uint32_t> seed_scramble) const {
  uint32_t h = hash_combine(t.texel, t.cell, t.m);
  if (seed_scramble) h = hash_combine(h, *seed_scramble);
  glm::vec2 u(float(h & 0xffffu) / 65536.f, float(h >> 16) / 65536.f);
  float x = float(t.texel % side_), y = float(t.texel / side_);
  return glm::vec2((x + (float(t.cell % t.m) + u.x) / float(t.m)) / float(side_),
                   (y + (float(t.cell / t.m) + u.y) / float(t.m)) / float(side_));
}

TraceStats EmbreePhotonTracer::trace_aaps(const TraceSettings& settings, PhotonBatch& out) {
  if (settings.keep_paths)
    throw InputError("photon tracer: TraceSettings::aaps does not keep light paths (keep_paths)");
  auto t0 = std::chrono::steady_clock::now();
  LightSet lights(world_);
  grid_densities_.resize(std::max<size_t>(grid_densities_.size(), lights.size()));
  std::vector<GridEmission> grids;
  std::vector<uint32_t> first_task;  // per light, then the total
  uint64_t total = 0;
  for (uint32_t e = 0; e < lights.size(); ++e) {
    EmitterType type = lights.emitter(e).type;
    if (type != EmitterType::point && type != EmitterType::spot && type != EmitterType::directional)
      throw InputError(fmt::format(
          "photon tracer: AAPS emits from point, spot and directional lights only, light {} is an "
          "area light (seed 004 §4.5.3: its task buffer would need four dimensions)",
          e));
    if (grid_densities_[e].texels.empty())
      throw InputError(fmt::format("photon tracer: AAPS emission needs a density for light {}", e));
    grids.emplace_back(grid_densities_[e]);
    first_task.push_back(uint32_t(total));
    total += mean3(lights.emitter(e).power) > 0 ? grids.back().tasks() : 0;
    if (total > std::numeric_limits<uint32_t>::max())
      throw InputError("photon tracer: AAPS emission asks for more than 2^32 photons");
  }
  first_task.push_back(uint32_t(total));
  out.photons.clear();
  out.paths = LightPaths{};
  // Each task's emitted power (mean over RGB), summed per texel below in task order: a texel's
  // tasks are consecutive, so the sums are the same whatever the thread count.
  std::vector<float> task_power(total, 0.f);
  uint32_t blocks = uint32_t((total + kBlockSize - 1) / kBlockSize);
  std::vector<BlockOutput>& outputs = scratch_->blocks;
  reset_blocks(outputs, blocks);
  tbb::parallel_for(
      tbb::blocked_range<uint32_t>(0, blocks, 1), [&](const tbb::blocked_range<uint32_t>& r) {
        for (uint32_t b = r.begin(); b != r.end(); ++b) {
          BlockOutput& o = outputs[b];
          uint32_t end = uint32_t(std::min<uint64_t>(total, (b + 1) * kBlockSize));
          for (uint32_t g = b * kBlockSize; g < end; ++g) {
            uint32_t e = uint32_t(std::upper_bound(first_task.begin(), first_task.end(), g) -
                                  first_task.begin()) -
                         1;
            uint32_t task = g - first_task[e];
            const GridEmission& grid = grids[e];
            GridEmission::Task cell = grid.locate(task);
            EmissionRay ray =
                lights.emit(e, settings.aaps_jitter ? grid.jittered(cell, seed_scramble_) : cell.uv,
                            {0.5f, 0.5f});
            PathVertex v;
            v.position = ray.origin;
            v.direction = ray.direction;
            v.normal = ray.normal;
            // §3.2.1: light power / texels / photons in the texel.
            v.power = ray.power /
                      (float(grid.side()) * float(grid.side()) * float(cell.m) * float(cell.m));
            task_power[g] = mean3(v.power);
            v.spacing = 1.f / (float(grid.side()) * float(cell.m));
            v.dp_du = ray.dp_du, v.dp_dv = ray.dp_dv;
            v.dd_du = ray.dd_du, v.dd_dv = ray.dd_dv;
            o.rays += trace_aaps_photon(world_, v, e, task, settings.max_bounces, o.photons);
          }
        }
      });
  out.texel_power.assign(lights.size(), {});
  for (uint32_t e = 0; e < lights.size(); ++e) {
    out.texel_power[e].assign(size_t(grids[e].side()) * grids[e].side(), 0.f);
    for (uint32_t g = first_task[e]; g < first_task[e + 1]; ++g)
      out.texel_power[e][grids[e].locate(g - first_task[e]).texel] += task_power[g];
  }
  TraceStats stats;
  gather(outputs, blocks, 0, false, out, stats);
  stats.paths = total;
  stats.photons = out.photons.size();
  stats.seconds = io::seconds_since(t0);
  out.stats = stats;
  return stats;
}

}  // namespace pb::trace
