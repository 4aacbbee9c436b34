#include "reference/path_tracing_pass.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "trace/bsdf.h"
#include "trace/sampling.h"

namespace pb::trace::detail {
namespace {

// Path tracing runs as a wavefront over one image row at a time: the row's paths advance a vertex
// together, so each step's closest-hit rays and each step's shadow rays go to Embree as one stream
// (EmbreeScene::intersect_stream, occluded_stream). The camera's rays of a row, and the shadow rays
// from their first hits to a light, are coherent, and Embree traces them as SIMD packets; that is
// where the wavefront pays (README "Ray throughput": the camera stream alone took bench_trace from
// 0.86x to 0.95x of Embree's tutorial). Each path draws from its own pixel's generator in the
// order a path-by-path loop would, so the image does not depend on the order paths advance in.

// One camera path between two of its vertices: the ray it goes on along, what it carries, and
// what the MIS weight and the classification of its next vertex need to know about this one.
struct CameraPath {
  explicit CameraPath(const Pcg32& generator) : rng(generator) {}
  Ray ray;
  glm::vec3 beta{1.f};
  glm::vec3 prev_position{0.f};
  glm::vec3 prev_normal{0.f};  // the last scattering vertex's geometric normal (the light walk's)
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
  const IncidentLightTree* tree;  // null: lights chosen by power
  uint32_t wanted, budget;
  bool use_nee, use_hits;

  bool sample_incident(const Hit& at, float u_select, glm::vec2 u, IncidentSample& out) const {
    return tree ? tree->sample_incident(at.position, at.geometric_normal, u_select, u, out)
                : lights.sample_incident(at.position, u_select, u, out);
  }
  // The density with which next-event estimation at the path's last vertex would have sampled
  // emitter point y: from that vertex's position and normal, as the walk saw them.
  float pdf_incident(const CameraPath& path, const Hit& y) const {
    return tree ? tree->pdf_incident(path.prev_position, path.prev_normal, y)
                : lights.pdf_incident(path.prev_position, y);
  }
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
        w = power_heuristic(path.prev_pdf, setup.pdf_incident(path, hit));
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
    if (setup.sample_incident(hit, u_select, u, is)) {
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
  path.prev_normal = hit.geometric_normal;
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

}  // namespace

// A row at a time, as one wavefront (above).
void path_tracing_pass(const EmbreeScene& world, const LightSet& lights,
                       const IncidentLightTree* tree, const Rig& rig, LightStrategies strategies,
                       uint32_t wanted, uint32_t budget, uint32_t iteration_seed, int stride,
                       tbb::task_arena& arena, tbb::combinable<uint64_t>& ray_count,
                       std::vector<glm::vec3>& frame) {
  const PathTracingSetup setup{world,
                               lights,
                               tree,
                               wanted,
                               budget,
                               strategies != LightStrategies::bsdf_only,
                               strategies != LightStrategies::nee_only};
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

}  // namespace pb::trace::detail
