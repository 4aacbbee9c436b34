// Paper II's reuse steps over the light paths of the previous frame: the origin update of moved
// lights (§3.1), the verification of each kept path's segments (§3.2, naive, and error_based's
// Algorithm 1, §3.3), and the re-trace of what failed, from the failed segment on.
#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "io/clock.h"
#include "photonbench/error.h"
#include "trace/bsdf.h"
#include "trace/photon_paths.h"
#include "trace/photon_tracer.h"

namespace pb::trace {

using namespace detail;

namespace {

// What moved since a LightPaths snapshot was taken (Paper II §3.2): objects whose transform
// changed or that deformed (and the objects of quad and disc lights that moved), with their current
// bounds, and the emitters whose state changed.
struct Motion {
  bool compatible = false;  // false: the settings or the power split changed, trace afresh
  std::vector<char> moved;  // per object index (Hit::object)
  std::vector<Aabb> moved_boxes;
  std::vector<uint32_t> box_object;  // the object of each box
  std::vector<char> light_changed;   // per emitter
  std::vector<glm::vec4> now_state;
  // `own`: an object whose box is not tested (the moved area light a first segment leaves).
  bool touches(const glm::vec3& origin, const glm::vec3& dir, float length,
               uint32_t own = kNoObject) const {
    for (size_t i = 0; i < moved_boxes.size(); ++i)
      if (box_object[i] != own && moved_boxes[i].intersects(origin, dir, length)) return true;
    return false;
  }
  bool moved_object(uint32_t object) const { return object < moved.size() && moved[object]; }
};

// (Sizes the tracer's per-light density tables to the lights first.) `path_seed`: the seed
// settings would trace new paths with (EmbreePhotonTracer::path_seed).
Motion find_motion(const EmbreeScene& world, const LightSet& lights, const LightPaths& old,
                   const TraceSettings& settings, uint32_t path_seed,
                   std::vector<std::shared_ptr<const Distribution2D>>& densities,
                   std::vector<uint32_t>& density_version) {
  densities.resize(std::max<size_t>(densities.size(), lights.size()));
  density_version.resize(densities.size(), 0);
  Motion m;
  m.now_state = light_state(world, lights, density_version);
  uint32_t n_emitters = lights.size();
  m.compatible = !old.empty() && old.max_bounces == settings.max_bounces &&
                 old.store == settings.store && old.rr_start == settings.rr_start &&
                 old.paths_per_light.size() == n_emitters &&
                 old.object_to_world.size() == world.object_count() &&
                 old.light_state.size() == m.now_state.size() &&
                 (settings.seed_per_frame || old.seed == path_seed);
  // The split of paths among emitters depends on their power: a power change means a fresh trace.
  for (uint32_t e = 0; m.compatible && e < n_emitters; ++e)
    m.compatible = glm::vec3(old.light_state[e * kLightStateSize + 4]) ==
                   glm::vec3(m.now_state[e * kLightStateSize + 4]);
  if (!m.compatible) return m;
  uint32_t n_objects = world.object_count();
  const auto& lights_now = world.state().lights;
  m.moved.assign(n_objects + lights_now.size(), 0);
  const auto& deformed = world.state().deformed_objects;
  for (uint32_t o = 0; o < n_objects; ++o) {
    m.moved[o] = old.object_to_world[o] != world.object_to_world(o) ||
                 std::find(deformed.begin(), deformed.end(), o) != deformed.end();
    if (m.moved[o]) m.moved_boxes.push_back(world.object_bounds(o)), m.box_object.push_back(o);
  }
  m.light_changed.assign(n_emitters, 0);
  for (uint32_t e = 0; e < n_emitters; ++e) {
    for (size_t k = 0; k < kLightStateSize; ++k)
      m.light_changed[e] |=
          old.light_state[e * kLightStateSize + k] != m.now_state[e * kLightStateSize + k];
    const Emitter& em = lights.emitter(e);
    if (m.light_changed[e] && em.type != EmitterType::mesh && lights.has_area(e) &&
        world.is_light_object(world.light_object(em.source))) {
      uint32_t obj = world.light_object(em.source);
      if (obj < m.moved.size()) {
        m.moved[obj] = 1;
        m.moved_boxes.push_back(light_bounds(lights_now[em.source]));
        m.box_object.push_back(obj);
      }
    }
  }
  return m;
}

// The inverse of concentric_disk (sampling.h): the unit-square point that maps to disk point `d`.
glm::vec2 concentric_disk_inverse(glm::vec2 d) {
  float r = glm::length(d);
  if (r == 0) return {0.5f, 0.5f};
  float phi = std::atan2(d.y, d.x);  // (-pi, pi]
  const float quarter = kPi / 4;
  glm::vec2 o;
  if (std::abs(phi) <= quarter) {  // |o.x| >= |o.y|, o.x > 0
    o = {r, r * phi / quarter};
  } else if (std::abs(phi) >= 3 * quarter) {  // o.x < 0: phi = theta + pi
    float theta = phi > 0 ? phi - kPi : phi + kPi;
    o = {-r, -r * theta / quarter};
  } else if (phi > 0) {  // o.y > 0: phi = pi/2 - pi/4 o.x / o.y
    o = {r * (kPi / 2 - phi) / quarter, r};
  } else {  // o.y < 0: phi = theta - pi
    float theta = phi + kPi;
    o = {-r * (kPi / 2 - theta) / quarter, -r};
  }
  return glm::clamp((o + 1.f) * 0.5f, glm::vec2(0.f), glm::vec2(std::nextafter(1.f, 0.f)));
}

// (u, v) of the equal-area sphere or cone map (lights.cpp's sphere_direction) that gives local
// direction `d`, for a cone of cos_max (-1: the whole sphere).
glm::vec2 sphere_direction_inverse(const glm::vec3& d, float cos_max) {
  float u = (1.f - d.z) / (1.f - cos_max);
  float v = std::atan2(d.y, d.x) / (2.f * kPi);
  if (v < 0) v += 1.f;
  return glm::clamp(glm::vec2(u, v), glm::vec2(0.f), glm::vec2(std::nextafter(1.f, 0.f)));
}

// Paper II §3.1: moves the origin of a path whose light moved. Point and spot lights: the new
// position, the direction towards the kept primary hit and a visibility ray to it (the paper uses
// the light's shadow map); a spot light's falloff in the new direction rescales the path's power.
// Quad and disc lights: the kept direction met with the moved light's plane, which must fall
// inside the light.
// The emission sample (LightPath::emission_uv, emission_dir) follows, so the distribution map
// can place the path. `hit`: the visibility ray's hit; `traced` is set when that ray was traced
// (whatever the update's outcome: a failed visibility test is a ray traced too).
OriginUpdate update_origin(const EmbreeScene& world, const LightSet& lights,
                           const std::vector<glm::vec4>& old_state, LightPath& path, PathVertex* pv,
                           PhotonRecord* photons, Hit& hit, bool& traced) {
  traced = false;
  const Emitter& em = lights.emitter(path.light);
  if (em.type == EmitterType::mesh || em.type == EmitterType::directional)
    return OriginUpdate::failed;
  const scene::Light& light = world.state().lights[em.source];
  PathVertex& v0 = pv[0];
  if (path.vertex_count < 2) return OriginUpdate::failed;  // escaped at once: nothing anchors it
  const PathVertex& v1 = pv[1];
  if (em.type == EmitterType::quad || em.type == EmitterType::disc) {
    glm::vec3 n = light.normal(), d = v0.direction;
    float cos_out = glm::dot(d, n);
    if (!(cos_out > 0)) return OriginUpdate::failed;
    float t = glm::dot(v1.position - light.position, n) / cos_out;
    if (!(t > 0)) return OriginUpdate::failed;
    glm::vec3 origin = v1.position - t * d;
    glm::vec3 q = origin - light.position;
    glm::vec2 ab;
    if (em.type == EmitterType::disc) {
      // The inverse of Light::surface_point's polar map: q = rho (cos phi edge_u + sin phi
      // edge_v), the edges orthogonal radii; u = rho^2, v = phi / 2 pi.
      glm::vec2 p{glm::dot(q, light.edge_u) / glm::dot(light.edge_u, light.edge_u),
                  glm::dot(q, light.edge_v) / glm::dot(light.edge_v, light.edge_v)};
      float v = std::atan2(p.y, p.x) / (2.f * kPi);
      ab = {glm::dot(p, p), v < 0 ? v + 1.f : v};
      if (ab.x >= 1) return OriginUpdate::failed;
      ab.y = std::min(ab.y, std::nextafter(1.f, 0.f));
    } else {
      // Solve q = a edge_u + b edge_v (least squares: the edges need not be orthogonal).
      float uu = glm::dot(light.edge_u, light.edge_u), uv = glm::dot(light.edge_u, light.edge_v);
      float vv = glm::dot(light.edge_v, light.edge_v), det = uu * vv - uv * uv;
      if (!(std::abs(det) > 0)) return OriginUpdate::failed;
      float qu = glm::dot(q, light.edge_u), qv = glm::dot(q, light.edge_v);
      ab = {(vv * qu - uv * qv) / det, (uu * qv - uv * qu) / det};
      if (ab.x < 0 || ab.x >= 1 || ab.y < 0 || ab.y >= 1) return OriginUpdate::failed;
    }
    v0.position = light.surface_point(ab, &v0.dp_du, &v0.dp_dv);  // = origin, to rounding
    v0.normal = n;
    path.emission_uv = ab;
    glm::vec3 local = Frame(n).to_local(d);
    path.emission_dir = concentric_disk_inverse({local.x, local.y});
    return OriginUpdate::moved;
  }
  // Point and spot.
  glm::vec3 to_hit = v1.position - light.position;
  float distance = glm::length(to_hit);
  if (!(distance > 0)) return OriginUpdate::failed;
  glm::vec3 d = to_hit / distance;
  glm::vec2 uv;
  if (em.type == EmitterType::spot) {
    float ci = std::cos(light.spot_inner), co = std::cos(light.spot_outer);
    if (ci < co) std::swap(ci, co);
    Frame f(glm::normalize(light.direction));
    glm::vec3 local = f.to_local(d);
    if (local.z <= co) return OriginUpdate::failed;  // left the cone
    const glm::vec4* old = &old_state[path.light * kLightStateSize];
    float old_cos = glm::dot(v0.direction, glm::normalize(glm::vec3(old[1])));
    float old_falloff = spot_falloff(old_cos, ci, co);
    float new_falloff = spot_falloff(local.z, ci, co);
    if (!(old_falloff > 0) || !(new_falloff > 0)) return OriginUpdate::failed;
    float scale = new_falloff / old_falloff;
    if (scale != 1.f) {
      for (uint32_t v = 0; v < path.vertex_count; ++v) pv[v].power *= scale;
      for (uint32_t p = 0; p < path.photon_count; ++p) photons[p].power *= scale;
    }
    uv = sphere_direction_inverse(local, co);
  } else {
    uv = sphere_direction_inverse(d, -1.f);
  }
  // The visibility ray towards the kept primary hit.
  traced = true;
  bool any = world.intersect(light.position, d, kUnboundedRay, hit);
  if (!any || hit.object != v1.object || std::abs(hit.t - distance) > 1e-4f * (1.f + distance))
    return OriginUpdate::failed;
  v0.position = light.position;
  v0.direction = d;
  path.emission_uv = uv;
  if (v1.flags & PathVertex::kStored) photons[0].direction = d;  // its incoming direction
  bool diffuse = !(v1.specular_mask & 1u);
  return diffuse ? OriginUpdate::verified : OriginUpdate::resample_first;
}

// The verdict on one kept path.
struct PathVerdict {
  uint32_t restart = LightPath::kKeep;
  bool handover = false;  // `hit` is the restart segment's hit (object kNoObject: it escapes)
  bool moved_vertex = false;
  uint64_t visibility_rays = 0;
  Hit hit;
};

// Index, among the path's photons, of the photon stored at vertex v (kStored set).
uint32_t photon_at_vertex(const PathVertex* pv, uint32_t v) {
  uint32_t index = 0;
  for (uint32_t i = 1; i < v; ++i) index += (pv[i].flags & PathVertex::kStored) ? 1 : 0;
  return index;
}

// Tests the segments of one path in order from the light (Paper II §3.2) and decides from which
// segment it must be re-traced. error_based (§3.3, Algorithm 1) may move vertices in `pv` and the
// photons stored on them (`photons`: the path's own) instead.

// `pre`: the path's origin update, done already (update_origins); null: done here.
PathVerdict verify_path(const EmbreeScene& world, const LightSet& lights, const Motion& m,
                        const LightPaths& old, const ReuseSettings& reuse, LightPath& path,
                        PathVertex* pv, PhotonRecord* photons, const OriginResult* pre) {
  PathVerdict out;
  auto restart_with = [&](uint32_t s, bool any, const Hit& hit) {
    out.restart = s;
    out.handover = true;
    out.hit = any ? hit : Hit{};
    return out;
  };
  // Algorithm 1's gap (digest §7.3): once a segment's origin moved, the next segment is traced
  // whatever its box tests say.
  bool origin_moved = false;
  uint32_t first = 0;  // the first segment still to test
  uint32_t own_light = kNoObject;
  if (m.light_changed[path.light]) {
    if (!reuse.update_origins || reuse.rule == ReuseRule::exact) {
      out.restart = LightPath::kReemit;
      return out;
    }
    Hit hit;
    bool traced = false;
    OriginUpdate update =
        pre ? pre->update
            : update_origin(world, lights, old.light_state, path, pv, photons, hit, traced);
    if (pre) hit = pre->hit, traced = pre->traced;
    // Every ray traced counts, a failed visibility test's too (Paper II counts rays traced); the
    // one exception is the ray whose hit starts the re-trace of a non-diffuse primary hit, which
    // the re-trace counts as its first segment.
    if (traced && update != OriginUpdate::resample_first) ++out.visibility_rays;
    if (update == OriginUpdate::failed) {
      out.restart = LightPath::kReemit;
      return out;
    }
    if (update == OriginUpdate::resample_first) return restart_with(0, true, hit);
    out.moved_vertex = true;
    if (update == OriginUpdate::verified) first = 1;
    // An area light's path leaves the light's own (moved) box, which its first segment does not
    // test. Its origin moved along the kept direction, but neither rule traces that segment unless
    // a moved object touches it: Algorithm 1 skips segments no moved object intersects (line 2),
    // and §3.1 keeps the direction "to avoid tracing visibility rays towards each primary photon".
    const Emitter& em = lights.emitter(path.light);
    if (update == OriginUpdate::moved) own_light = world.light_object(em.source);
  }
  for (uint32_t s = first; s < path.vertex_count; ++s) {
    const PathVertex& a = pv[s];
    bool last = s + 1 == path.vertex_count;
    if (last && !(a.flags & PathVertex::kEscapes)) break;  // no outgoing segment
    glm::vec3 origin = spawn_origin(a);
    float length = kUnboundedRay;
    uint32_t dest_object = kNoObject;
    if (!last) {
      dest_object = pv[s + 1].object;
      length = glm::dot(pv[s + 1].position - origin, a.direction);
    }
    // A stale vertex: the segment ends on an object that moved (away, perhaps: then the box
    // test alone would miss it, digest §7.3).
    bool stale = m.moved_object(dest_object);
    bool touched = m.touches(origin, a.direction, length, s == 0 ? own_light : kNoObject);
    if (reuse.rule == ReuseRule::naive) {
      if (stale || touched) {
        out.restart = s;
        return out;
      }
      continue;
    }
    if (reuse.rule == ReuseRule::exact && stale) {
      out.restart = s;
      return out;
    }
    if (!stale && !touched && !origin_moved) continue;
    Hit hit;
    bool any = world.intersect(origin, a.direction, kUnboundedRay, hit);
    bool same = last ? !any
                     : any && hit.object == dest_object &&
                           std::abs(hit.t - length) <= 1e-4f * (1.f + length);
    if (same && !stale) {
      ++out.visibility_rays;
      origin_moved = false;
      continue;
    }
    if (reuse.rule == ReuseRule::exact || last || !any || world.is_light_object(hit.object))
      return restart_with(s, any, hit);
    // error_based: the segment now ends at `hit`. Keep the rest of the path if the energy
    // reflected there towards the next vertex stays within T of the original (Eq. 2).
    const PathVertex& old_dest = pv[s + 1];
    Bsdf bsdf(world.scene().materials[hit.material], hit);
    bool was_diffuse = !(old_dest.specular_mask & (1u << s));
    if (bsdf.is_diffuse() != was_diffuse) return restart_with(s, any, hit);
    bool dest_last = s + 2 == path.vertex_count;
    bool has_next = !dest_last || (old_dest.flags & PathVertex::kEscapes);
    glm::vec3 next_dir = old_dest.direction;
    if (has_next) {
      if (!dest_last) next_dir = glm::normalize(pv[s + 2].position - hit.position);
      float pdf = bsdf.pdf(-a.direction, next_dir);
      if (!(pdf > 0)) return restart_with(s, any, hit);
      // Eq. 2's E_N: the energy reflected at the new hit towards the next vertex, Phi f cos / p,
      // before the Russian roulette. E_O is the same quantity at the original hit: the power the
      // path carried on, times the probability with which it survived there (PathVertex::survival;
      // 1 before rr_start). Comparing the powers after the roulette instead would compare
      // rho / max(rho) and miss an albedo that changed in magnitude alone (a dark grey hit where a
      // bright grey one was).
      glm::vec3 energy = a.power * bsdf.eval(-a.direction, next_dir, Transport::importance) / pdf;
      // Always against the original energy, so that errors do not accumulate over frames.
      glm::vec3 original = old_dest.power * old_dest.survival;
      if (glm::any(
              glm::greaterThan(glm::abs(energy - original), reuse.energy_threshold * original)))
        return restart_with(s, any, hit);
    }
    PathVertex& d = pv[s + 1];
    glm::vec3 ng = glm::dot(hit.geometric_normal, a.direction) > 0 ? -hit.geometric_normal
                                                                   : hit.geometric_normal;
    d.position = hit.position;
    d.object = hit.object;
    d.normal = ng;
    d.direction =
        next_dir;  // its power stays the original (§3.3: the new energy is not propagated)
    if (d.flags & PathVertex::kStored) {
      PhotonRecord& ph = photons[photon_at_vertex(pv, s + 1)];
      ph.position = hit.position;
      ph.triangle = world.scene_triangle(hit.object, hit.primitive);
      ph.normal = ng;
    }
    if (!dest_last && (pv[s + 2].flags & PathVertex::kStored))
      photons[photon_at_vertex(pv, s + 2)].direction = next_dir;  // its incoming direction
    out.moved_vertex = true;
    ++out.visibility_rays;
    origin_moved = true;
  }
  return out;
}

// Runs f(block, path) over paths [0, n_paths) in the tracer's fixed blocks, blocks in parallel.
template <class F>
void for_each_path(uint32_t n_paths, F&& f) {
  uint32_t blocks = (n_paths + kBlockSize - 1) / kBlockSize;
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, blocks, 1),
                    [&](const tbb::blocked_range<uint32_t>& r) {
                      for (uint32_t b = r.begin(); b != r.end(); ++b) {
                        uint32_t end = std::min(n_paths, (b + 1) * kBlockSize);
                        for (uint32_t pi = b * kBlockSize; pi < end; ++pi) f(b, pi);
                      }
                    });
}

// Segments of a traced path (the rays a fresh trace of it costs).
uint64_t path_segments(const LightPath& path, const std::vector<PathVertex>& vertices) {
  if (path.vertex_count == 0) return 0;
  bool escapes = vertices[path.first_vertex + path.vertex_count - 1].flags & PathVertex::kEscapes;
  return path.vertex_count - 1 + (escapes ? 1 : 0);
}

}  // namespace

TraceStats EmbreePhotonTracer::retrace_invalid(const TraceSettings& settings, PhotonBatch& batch) {
  verify_paths(settings, ReuseSettings{ReuseRule::exact}, batch);
  return retrace_marked(settings, batch);
}

TraceStats EmbreePhotonTracer::verify_paths(const TraceSettings& settings,
                                            const ReuseSettings& reuse, PhotonBatch& batch) {
  check_settings(settings);
  auto t0 = std::chrono::steady_clock::now();
  LightPaths& old = batch.paths;
  LightSet lights(world_);
  Motion motion =
      find_motion(world_, lights, old, settings, path_seed(settings), densities_, density_version_);
  TracerScratch& scratch = *scratch_;
  scratch.verify_stats = TraceStats{};
  if (!motion.compatible) {
    TraceSettings fresh = settings;
    fresh.keep_light_paths = true;
    TraceStats stats = trace(fresh, batch);
    for (const LightPath& path : batch.paths.paths)
      stats.full_retrace_rays += path_segments(path, batch.paths.vertices);
    stats.paths_retraced = stats.paths;
    scratch.handover_hit.clear();
    scratch.has_handover.clear();
    scratch.verify_stats = stats;
    batch.stats = stats;
    return stats;
  }
  uint32_t n_paths = uint32_t(old.paths.size());
  bool origins_done = scratch.origins.size() == n_paths && scratch.origins_batch == &batch;
  scratch.handover_hit.assign(n_paths, Hit{});
  scratch.has_handover.assign(n_paths, 0);
  uint32_t blocks = (n_paths + kBlockSize - 1) / kBlockSize;
  std::vector<uint64_t> visibility(blocks, 0), moved(blocks, 0);
  for_each_path(n_paths, [&](uint32_t b, uint32_t pi) {
    LightPath& path = old.paths[pi];
    const OriginResult* pre = origins_done ? &scratch.origins[pi] : nullptr;
    PathVerdict v = verify_path(world_, lights, motion, old, reuse, path,
                                old.vertices.data() + path.first_vertex,
                                batch.photons.data() + path.first_photon, pre);
    path.restart = v.restart;
    scratch.has_handover[pi] = v.handover;
    if (v.handover) scratch.handover_hit[pi] = v.hit;
    visibility[b] += v.visibility_rays;
    moved[b] += v.moved_vertex && v.restart == LightPath::kKeep;
  });
  TraceStats stats;
  for (uint32_t b = 0; b < blocks; ++b)
    stats.visibility_rays += visibility[b], stats.paths_moved += moved[b];
  stats.rays = stats.visibility_rays;
  stats.paths = n_paths;
  stats.seconds = io::seconds_since(t0);
  if (origins_done) {  // update_origins' rays and time belong to the verification
    stats.seconds += scratch.origin_stats.seconds;
    scratch.origins.clear();
  }
  scratch.verify_stats = stats;
  return stats;
}

TraceStats EmbreePhotonTracer::update_origins(const TraceSettings& settings,
                                              const ReuseSettings& reuse, PhotonBatch& batch) {
  check_settings(settings);
  auto t0 = std::chrono::steady_clock::now();
  LightPaths& old = batch.paths;
  LightSet lights(world_);
  Motion motion =
      find_motion(world_, lights, old, settings, path_seed(settings), densities_, density_version_);
  TracerScratch& scratch = *scratch_;
  scratch.origins.clear();
  TraceStats stats;
  if (!motion.compatible || !reuse.update_origins || reuse.rule == ReuseRule::exact) return stats;
  uint32_t n_paths = uint32_t(old.paths.size());
  scratch.origins.assign(n_paths, OriginResult{});
  scratch.origins_batch = &batch;
  uint32_t blocks = (n_paths + kBlockSize - 1) / kBlockSize;
  std::vector<uint64_t> visibility(blocks, 0);
  for_each_path(n_paths, [&](uint32_t b, uint32_t pi) {
    LightPath& path = old.paths[pi];
    path.restart = LightPath::kKeep;
    if (!motion.light_changed[path.light]) return;
    OriginResult& o = scratch.origins[pi];
    o.update = update_origin(world_, lights, old.light_state, path,
                             old.vertices.data() + path.first_vertex,
                             batch.photons.data() + path.first_photon, o.hit, o.traced);
    if (o.update == OriginUpdate::failed) path.restart = LightPath::kReemit;
    // As verify_path counts them (resample_first's ray is a segment).
    visibility[b] += o.traced && o.update != OriginUpdate::resample_first;
  });
  for (uint64_t v : visibility) stats.visibility_rays += v;
  stats.rays = stats.visibility_rays;
  stats.paths = n_paths;
  stats.seconds = io::seconds_since(t0);
  scratch.origin_stats = stats;
  return stats;
}

TraceStats EmbreePhotonTracer::retrace_marked(const TraceSettings& settings, PhotonBatch& batch) {
  TracerScratch& scratch = *scratch_;
  LightPaths& old = batch.paths;
  uint32_t n_paths = uint32_t(old.paths.size());
  TraceStats verified = scratch.verify_stats;
  if (scratch.has_handover.size() != n_paths) {  // verify_paths traced afresh: nothing is marked
    if (old.empty() || verified.paths != n_paths)
      throw Error("photon tracer: retrace_marked without verify_paths on this batch");
    verified.seconds = 0;
    return verified;
  }
  check_settings(settings);
  auto t0 = std::chrono::steady_clock::now();
  LightSet lights(world_);
  std::vector<uint32_t> emission_count = old.paths_per_light;
  // No differentials here; sample_seeds are filled by prepare_sample_seeds.
  Context c{&world_,   &lights,      &densities_,     old.seed, old.max_bounces,
            old.store, old.rr_start, &emission_count, nullptr,  nullptr,
            {}};
  // The reuse service re-validates the tracer's own decisions only (no policy): footprints where
  // the trace asks for them.
  c.differentials = settings.footprints;
  prepare_sample_seeds(c, lights.size());
  uint32_t blocks = (n_paths + kBlockSize - 1) / kBlockSize;
  std::vector<BlockOutput>& outputs = scratch.blocks;
  reset_blocks(outputs, blocks);
  const std::vector<PhotonRecord>& old_photons = batch.photons;
  tbb::parallel_for(
      tbb::blocked_range<uint32_t>(0, blocks, 1), [&](const tbb::blocked_range<uint32_t>& r) {
        std::vector<PathVertex> verts;
        for (uint32_t b = r.begin(); b != r.end(); ++b) {
          BlockOutput& o = outputs[b];
          std::vector<PhotonRecord>& photons = o.photons;
          uint32_t end = std::min(n_paths, (b + 1) * kBlockSize);
          for (uint32_t pi = b * kBlockSize; pi < end; ++pi) {
            const LightPath& path = old.paths[pi];
            PathTask task{path.light, path.sample};
            const PathVertex* pv = &old.vertices[path.first_vertex];
            auto first_photon = old_photons.begin() + path.first_photon;
            verts.clear();
            const size_t path_photons = photons.size();
            glm::vec2 uv = path.emission_uv, dir = path.emission_dir;
            uint32_t restart = path.restart;
            if (restart == LightPath::kKeep) {  // still valid: kept as it was (or moved within T)
              verts.assign(pv, pv + path.vertex_count);
              photons.insert(photons.end(), first_photon, first_photon + path.photon_count);
            } else if (restart == LightPath::kReemit) {
              verts.push_back(emit(c, task, &uv, &dir));
            } else if (restart == LightPath::kRefill) {
              glm::vec4 fixed{uv, dir};
              verts.push_back(emit(c, task, &uv, &dir, &fixed));
            } else {  // keep vertices 0..restart and the photons stored on them
              verts.assign(pv, pv + restart + 1);
              verts.back().flags &= ~(PathVertex::kEscapes | PathVertex::kTerminated);
              photons.insert(photons.end(), first_photon,
                             first_photon + photon_at_vertex(pv, restart + 1));
            }
            for (size_t i = path_photons; i < photons.size(); ++i) photons[i].path = pi;
            if (restart != LightPath::kKeep) {
              // A handed-over hit belongs to a restart segment (not to a path re-emitted since).
              bool segment = restart < LightPath::kRefill;
              const Hit* hit =
                  segment && scratch.has_handover[pi] ? &scratch.handover_hit[pi] : nullptr;
              uint64_t rays = continue_path(c, task, pi, verts, photons, hit);
              o.rays += rays, o.segments_retraced += rays, ++o.paths_retraced;
            }
            append_path(o, task, uv, dir, true, verts, path_photons);
          }
        }
      });
  // A restart segment's visibility ray was traced by verify_paths and handed over; a path the
  // prune or fill then replaced (kReemit, kRefill) starts from the light instead and does not use
  // it, so it is counted here, as a visibility ray.
  uint64_t unused_handovers = 0;
  for (uint32_t pi = 0; pi < n_paths; ++pi)
    unused_handovers += scratch.has_handover[pi] && old.paths[pi].restart >= LightPath::kRefill &&
                        old.paths[pi].restart != LightPath::kKeep;
  PhotonBatch next;
  TraceStats stats;
  next.photons.resize(gather(outputs, blocks, 0, true, next.photons.size(), next, stats));
  uint32_t n_objects = world_.object_count();
  next.paths.object_to_world.resize(n_objects);
  for (uint32_t ob = 0; ob < n_objects; ++ob)
    next.paths.object_to_world[ob] = world_.object_to_world(ob);
  next.paths.light_state = light_state(world_, lights, density_version_);
  next.paths.paths_per_light = old.paths_per_light;
  next.paths.seed = old.seed;
  next.paths.max_bounces = old.max_bounces;
  next.paths.store = old.store;
  next.paths.rr_start = old.rr_start;
  for (uint32_t pi = 0; pi < n_paths; ++pi) {
    next.paths.paths[pi].restart = old.paths[pi].restart;
    stats.full_retrace_rays += path_segments(next.paths.paths[pi], next.paths.vertices);
  }
  stats.paths = n_paths;
  stats.paths_kept = n_paths - stats.paths_retraced;
  stats.photons = next.photons.size();
  stats.seconds = io::seconds_since(t0);
  // The verification's rays and time belong to this re-validation too.
  stats.visibility_rays = verified.visibility_rays + unused_handovers;
  stats.paths_moved = verified.paths_moved;
  stats.rays += verified.rays + unused_handovers;
  stats.seconds += verified.seconds;
  next.stats = stats;
  batch = std::move(next);
  scratch.has_handover.clear();
  scratch.handover_hit.clear();
  return stats;
}

}  // namespace pb::trace
