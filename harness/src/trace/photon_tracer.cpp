#include "trace/photon_tracer.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "io/clock.h"
#include "photonbench/error.h"
#include "trace/bsdf.h"
#include "trace/lights.h"

namespace pb::trace {
namespace {

constexpr uint32_t kBlockSize = 256;  // paths per parallel task; fixed, so output order is fixed

float max3(const glm::vec3& v) { return std::max(v.x, std::max(v.y, v.z)); }
float mean3(const glm::vec3& v) { return (v.x + v.y + v.z) / 3.f; }

struct Context {
  const EmbreeScene* world = nullptr;
  const LightSet* lights = nullptr;
  const std::vector<std::shared_ptr<const Distribution2D>>* densities = nullptr;
  uint32_t seed = 0, max_bounces = 0, store = 0, rr_start = 0;
  const std::vector<uint32_t>* emission_count =
      nullptr;  // N used for each emitter's power and spacing
};

struct PathTask {
  uint32_t light, sample;
};

struct BlockOutput {
  std::vector<LightPath> paths;
  std::vector<PathVertex> vertices;
  std::vector<PhotonRecord> photons;
  uint64_t rays = 0, paths_retraced = 0, segments_retraced = 0;
};

glm::vec3 spawn_origin(const PathVertex& v) {
  if (v.normal == glm::vec3(0.f)) return v.position;
  float eps = EmbreeScene::ray_epsilon(v.position);
  return v.position + v.normal * (glm::dot(v.direction, v.normal) >= 0 ? eps : -eps);
}

// Derivative of the interpolated shading normal for a displacement dp in the triangle's plane
// (Igehy 1999 §3.2): solve dp = db1 e1 + db2 e2 in the least-squares sense, then differentiate
// N/|N|.
glm::vec3 normal_derivative(const Triangle& tri, glm::vec2 bary, const glm::vec3& dp) {
  glm::vec3 n_raw = (1.f - bary.x - bary.y) * tri.n[0] + bary.x * tri.n[1] + bary.y * tri.n[2];
  float len = glm::length(n_raw);
  if (len <= 0) return glm::vec3(0.f);
  glm::vec3 e1 = tri.p[1] - tri.p[0], e2 = tri.p[2] - tri.p[0];
  float a11 = glm::dot(e1, e1), a12 = glm::dot(e1, e2), a22 = glm::dot(e2, e2);
  float det = a11 * a22 - a12 * a12;
  if (std::abs(det) <= 0) return glm::vec3(0.f);
  float r1 = glm::dot(dp, e1), r2 = glm::dot(dp, e2);
  float db1 = (a22 * r1 - a12 * r2) / det, db2 = (a11 * r2 - a12 * r1) / det;
  glm::vec3 dn = db1 * (tri.n[1] - tri.n[0]) + db2 * (tri.n[2] - tri.n[0]);
  glm::vec3 ns = n_raw / len;
  return (dn - ns * glm::dot(ns, dn)) / len;
}

// Transfers a ray differential (dp, dd) along a segment of length t to the plane of the hit with
// normal ng (Igehy 1999 eq. 10).
glm::vec3 transfer_differential(const glm::vec3& dir, const glm::vec3& ng, float t,
                                const glm::vec3& dp, const glm::vec3& dd) {
  float d_dot_n = glm::dot(dir, ng);
  glm::vec3 q = dp + t * dd;
  return d_dot_n != 0 ? q - dir * (glm::dot(q, ng) / d_dot_n) : q;
}

// The direction differential after a delta reflection or refraction `s` at `hit`, for the
// incoming direction `dir` and its differentials (dp on the surface, dd): Igehy eq. 14 for
// reflection, eq. 18-19 for refraction, with the derivative of the interpolated normal.
glm::vec3 scatter_differential(const Triangle& tri, const Hit& hit, const BsdfSample& s,
                               const glm::vec3& dir, const glm::vec3& dp, const glm::vec3& dd) {
  float flip = glm::dot(s.normal, hit.shading_normal) >= 0 ? 1.f : -1.f;
  const glm::vec3 n = s.normal;
  glm::vec3 dn = flip * normal_derivative(tri, hit.barycentric, dp);
  if (!s.transmitted)
    return dd - 2.f * (glm::dot(dir, n) * dn + (glm::dot(dd, n) + glm::dot(dir, dn)) * n);
  // eta = eta_i / eta_t and n facing the incoming side.
  float eta = s.eta, cos_i = -glm::dot(dir, n), cos_t = -glm::dot(s.wi, n);
  if (cos_t <= 1e-6f) return dd;
  float k_coef = eta * cos_i - cos_t;
  float dcos_i = -(glm::dot(dd, n) + glm::dot(dir, dn));
  float dcos_t = eta * eta * cos_i * dcos_i / cos_t;
  float dk = eta * dcos_i - dcos_t;
  return eta * dd + dk * n + k_coef * dn;
}

// Can a photon still be stored after interaction k, given the path so far (`mask` includes bit k)?
bool storable_later(uint32_t mask, uint32_t k, uint32_t store) {
  if (!(mask & 1u)) return (store & kIndirectPhotons) != 0;
  uint32_t all = k >= 31 ? ~0u : ((1u << (k + 1)) - 1u);
  bool all_specular = (mask & all) == all;
  return (store & (kCausticIndirectPhotons | (all_specular ? uint32_t(kCausticPhotons) : 0u))) != 0;
}

// Vertex 0 of path `task`: emission. `fixed`: the emission sample (uv, direction point) to use
// instead of the path's own (Paper II's fill step); it is taken as drawn uniformly, so a light with
// an emission density uses that density's pdf at it.
PathVertex emit(const Context& c, const PathTask& task, glm::vec2* uv_out,
                glm::vec2* dir_out = nullptr, const glm::vec4* fixed = nullptr) {
  uint32_t seed_l = hash_combine(c.seed, task.light);
  glm::vec4 xi = fixed ? *fixed : sobol_group(task.sample, 0, seed_l);
  glm::vec2 uv{xi.x, xi.y};
  float pdf = 1;
  const auto& density = (*c.densities)[task.light];
  if (density) {
    if (fixed)
      pdf = density->pdf(uv);
    else
      uv = density->sample(uv, &pdf);
  }
  EmissionRay r = c.lights->emit(task.light, uv, {xi.z, xi.w});
  float n = float(std::max(1u, (*c.emission_count)[task.light]));
  PathVertex v;
  v.position = r.origin;
  v.object = kNoObject;
  v.direction = r.direction;
  v.normal = r.normal;
  v.power = pdf > 0 ? r.power / (n * pdf) : glm::vec3(0.f);
  v.spacing = pdf > 0 ? 1.f / std::sqrt(n * pdf) : 0.f;
  v.dp_du = r.dp_du, v.dp_dv = r.dp_dv, v.dd_du = r.dd_du, v.dd_dv = r.dd_dv;
  if (!(max3(v.power) > 0)) v.flags = PathVertex::kTerminated;
  if (uv_out) *uv_out = uv;
  if (dir_out) *dir_out = {xi.z, xi.w};
  return v;
}

// Continues a path from its last vertex, which holds the outgoing state, until it terminates.
// Appends vertices and the photons stored on the way; returns the number of segments traced.
// `first_hit`: the hit of the first segment, already traced (path verification hands over its
// visibility ray, Paper II §3.3); it is counted here as a traced segment.
uint64_t continue_path(const Context& c, const PathTask& task, uint32_t path_index,
                       std::vector<PathVertex>& verts, std::vector<PhotonRecord>& photons,
                       const Hit* first_hit = nullptr) {
  const EmbreeScene& world = *c.world;
  const scene::Scene& scene = world.scene();
  uint32_t seed_l = hash_combine(c.seed, task.light);
  float restart_spacing = 1.f / std::sqrt(float(std::max(1u, (*c.emission_count)[task.light])));
  uint64_t rays = 0;
  for (;;) {
    const PathVertex v = verts.back();
    if (v.flags & PathVertex::kTerminated) return rays;
    uint32_t k = uint32_t(verts.size()) - 1;  // index of the interaction this segment leads to
    if (k >= c.max_bounces) {
      verts.back().flags |= PathVertex::kTerminated;
      return rays;
    }
    const glm::vec3 dir = v.direction;
    Hit hit;
    ++rays;
    bool handed_over = first_hit != nullptr;
    if (handed_over) hit = *first_hit, first_hit = nullptr;
    bool any = handed_over ? hit.object != kNoObject
                           : world.intersect(spawn_origin(v), dir, kUnboundedRay, hit);
    if (!any) {
      verts.back().flags |= PathVertex::kEscapes | PathVertex::kTerminated;
      return rays;
    }
    PathVertex next;
    next.position = hit.position;
    next.object = hit.object;
    glm::vec3 ng =
        glm::dot(hit.geometric_normal, dir) > 0 ? -hit.geometric_normal : hit.geometric_normal;
    next.normal = ng;
    next.spacing = v.spacing;
    next.specular_mask = v.specular_mask;
    glm::vec3 dp_du = transfer_differential(dir, ng, hit.t, v.dp_du, v.dd_du);
    glm::vec3 dp_dv = transfer_differential(dir, ng, hit.t, v.dp_dv, v.dd_dv);
    if (world.is_light_object(hit.object)) {  // a luminaire absorbs what reaches it
      next.flags = PathVertex::kTerminated;
      verts.push_back(next);
      return rays;
    }
    const scene::Material& material = scene.materials[hit.material];
    Bsdf bsdf(material, hit);
    bool diffuse = bsdf.is_diffuse();
    uint32_t mask = v.specular_mask;
    if (diffuse && (photon_kind(mask, k) & c.store)) {
      PhotonRecord p{};
      p.position = hit.position;
      p.object = hit.object;
      p.power = v.power;
      p.path = path_index;
      p.direction = dir;
      p.bounce = k;
      p.normal = ng;
      p.specular_mask = mask;
      p.footprint_u = dp_du * v.spacing;
      p.footprint_v = dp_dv * v.spacing;
      p.light = task.light;
      p.flags = 0;
      photons.push_back(p);
      next.flags |= PathVertex::kStored;
    }
    if (!diffuse) mask |= 1u << k;
    next.specular_mask = mask;
    bool alive = k + 1 < c.max_bounces && storable_later(mask, k, c.store);
    if (alive) {
      glm::vec4 xi = sobol_group(task.sample, 1 + k, seed_l);
      BsdfSample s;
      alive = bsdf.sample(-dir, {xi.x, xi.y, xi.z}, Transport::importance, s);
      glm::vec3 power = alive ? v.power * s.weight : glm::vec3(0.f);
      alive = alive && max3(power) > 0 && std::isfinite(max3(power));
      float survival = 1.f;
      if (alive && k >= c.rr_start) {
        // Paper I §5: survive with R = min(1, Phi'/Phi), then Phi = Phi'/R.
        survival = std::min(1.f, max3(power) / max3(v.power));
        if (xi.w >= survival)
          alive = false;
        else
          power /= survival;
      }
      if (alive) {
        next.direction = s.wi;
        next.power = power;
        next.survival = survival;
        if (diffuse) {
          // The new direction depends on this bounce's two sample dimensions only: restart the
          // differentials from the cosine map (finite differences) about this point.
          const float h = 1e-3f;
          glm::vec2 u = glm::clamp(glm::vec2(xi.x, xi.y), glm::vec2(h), glm::vec2(1.f - h));
          Frame f(s.normal);
          next.dp_du = next.dp_dv = glm::vec3(0.f);
          next.dd_du = f.to_world(cosine_hemisphere(u + glm::vec2(h, 0)) -
                                  cosine_hemisphere(u - glm::vec2(h, 0))) /
                       (2 * h);
          next.dd_dv = f.to_world(cosine_hemisphere(u + glm::vec2(0, h)) -
                                  cosine_hemisphere(u - glm::vec2(0, h))) /
                       (2 * h);
          next.spacing = restart_spacing;
        } else {
          Triangle tri = world.triangle(hit.object, hit.primitive);
          next.dp_du = dp_du;
          next.dp_dv = dp_dv;
          next.dd_du = scatter_differential(tri, hit, s, dir, dp_du, v.dd_du);
          next.dd_dv = scatter_differential(tri, hit, s, dir, dp_dv, v.dd_dv);
        }
        verts.push_back(next);
        continue;
      }
    }
    next.flags |= PathVertex::kTerminated;
    verts.push_back(next);
    return rays;
  }
}

// Appends one path's vertices and photons (from scratch buffers) to a block's output.
void append_path(BlockOutput& out, const PathTask& task, glm::vec2 uv, glm::vec2 dir, bool keep,
                 const std::vector<PathVertex>& verts, const std::vector<PhotonRecord>& photons) {
  LightPath p;
  p.light = task.light;
  p.sample = task.sample;
  p.emission_uv = uv;
  p.emission_dir = dir;
  p.first_photon = uint32_t(out.photons.size());
  p.photon_count = uint32_t(photons.size());
  out.photons.insert(out.photons.end(), photons.begin(), photons.end());
  if (keep) {
    p.first_vertex = uint32_t(out.vertices.size());
    p.vertex_count = uint32_t(verts.size());
    out.vertices.insert(out.vertices.end(), verts.begin(), verts.end());
    out.paths.push_back(p);
  }
}

// Concatenates block outputs in block order (the fixed partition makes this thread-count
// independent): sizes first, then every block copies itself into place in parallel.
void gather(std::vector<BlockOutput>& blocks, size_t block_count, uint32_t path_offset, bool keep,
            PhotonBatch& out, TraceStats& stats) {
  std::vector<size_t> photon_at(block_count + 1), vertex_at(block_count + 1),
      path_at(block_count + 1);
  photon_at[0] = out.photons.size();
  vertex_at[0] = out.paths.vertices.size();
  path_at[0] = out.paths.paths.size();
  for (size_t b = 0; b < block_count; ++b) {
    photon_at[b + 1] = photon_at[b] + blocks[b].photons.size();
    vertex_at[b + 1] = vertex_at[b] + (keep ? blocks[b].vertices.size() : 0);
    path_at[b + 1] = path_at[b] + (keep ? blocks[b].paths.size() : 0);
    stats.rays += blocks[b].rays;
    stats.paths_retraced += blocks[b].paths_retraced;
    stats.segments_retraced += blocks[b].segments_retraced;
  }
  out.photons.resize(photon_at[block_count]);
  if (keep) {
    out.paths.vertices.resize(vertex_at[block_count]);
    out.paths.paths.resize(path_at[block_count]);
  }
  tbb::parallel_for(tbb::blocked_range<size_t>(0, block_count, 4),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t b = r.begin(); b != r.end(); ++b) {
                        BlockOutput& o = blocks[b];
                        PhotonRecord* ph = out.photons.data() + photon_at[b];
                        for (size_t i = 0; i < o.photons.size(); ++i) {
                          ph[i] = o.photons[i];
                          ph[i].path += path_offset;
                        }
                        if (!keep) continue;
                        std::copy(o.vertices.begin(), o.vertices.end(),
                                  out.paths.vertices.begin() + vertex_at[b]);
                        LightPath* paths = out.paths.paths.data() + path_at[b];
                        for (size_t i = 0; i < o.paths.size(); ++i) {
                          paths[i] = o.paths[i];
                          paths[i].first_photon += uint32_t(photon_at[b]);
                          paths[i].first_vertex += uint32_t(vertex_at[b]);
                        }
                      }
                    });
}

// Block outputs reused from call to call, so their memory is not faulted in again every frame.
void reset_blocks(std::vector<BlockOutput>& blocks, size_t count) {
  if (blocks.size() < count) blocks.resize(count);
  for (size_t b = 0; b < count; ++b) {
    blocks[b].paths.clear();
    blocks[b].vertices.clear();
    blocks[b].photons.clear();
    blocks[b].rays = blocks[b].paths_retraced = blocks[b].segments_retraced = 0;
  }
}

// The world as a path set remembers it: per emitter, what decides where its photons start.
std::vector<glm::vec4> light_state(const EmbreeScene& world, const LightSet& lights,
                                   const std::vector<uint32_t>& density_version) {
  std::vector<glm::vec4> state;
  for (uint32_t e = 0; e < lights.size(); ++e) {
    const Emitter& em = lights.emitter(e);
    float version = e < density_version.size() ? float(density_version[e]) : 0.f;
    if (em.type == EmitterType::mesh) {
      const glm::mat4& m = world.object_to_world(em.source);
      for (int c = 0; c < 4; ++c) state.push_back(m[c]);
      state.push_back(glm::vec4(em.power, version));
      state.push_back(glm::vec4(0.f));
      continue;
    }
    const scene::Light& l = world.state().lights[em.source];
    state.push_back(glm::vec4(l.position, float(int(l.type))));
    state.push_back(glm::vec4(l.direction, l.spot_inner));
    state.push_back(glm::vec4(l.edge_u, l.spot_outer));
    state.push_back(glm::vec4(l.edge_v, version));
    state.push_back(glm::vec4(em.power, 0.f));
    // A directional light's emission square follows the scene bounds.
    state.push_back(em.type == EmitterType::directional
                        ? glm::vec4(lights.scene_center(), lights.scene_radius())
                        : glm::vec4(0.f));
  }
  return state;
}
constexpr size_t kLightStateSize = 6;

void check_settings(const TraceSettings& s) {
  if (s.max_bounces < 1 || s.max_bounces > 31)
    throw InputError(
        fmt::format("photon tracer: max_bounces {} is outside [1, 31]", s.max_bounces));
  if (s.paths < 1) throw InputError("photon tracer: paths must be at least 1");
  if ((s.store & ~uint32_t(kAllPhotons)) != 0 || s.store == 0)
    throw InputError("photon tracer: store must be a non-empty PhotonKind mask");
}

}  // namespace

std::vector<uint32_t> EmbreePhotonTracer::split_paths(const std::vector<float>& powers,
                                                      uint32_t paths) {
  std::vector<uint32_t> count(powers.size(), 0);
  double total = 0;
  size_t positive = 0;
  for (float p : powers)
    if (p > 0) total += p, ++positive;
  if (total <= 0 || paths == 0) return count;
  // Largest remainder (Hamilton): floor of the exact share, then one more to the largest
  // remainders.
  std::vector<std::pair<double, size_t>> remainders;
  uint32_t used = 0;
  for (size_t i = 0; i < powers.size(); ++i) {
    if (!(powers[i] > 0)) continue;
    double exact = paths * (powers[i] / total);
    count[i] = uint32_t(std::floor(exact));
    used += count[i];
    remainders.push_back({exact - count[i], i});
  }
  std::stable_sort(remainders.begin(), remainders.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  for (size_t r = 0; used < paths && r < remainders.size(); ++r, ++used)
    ++count[remainders[r].second];
  // No emitter with power is left dark while there are paths enough: take one from the largest
  // share.
  if (paths >= positive)
    for (size_t i = 0; i < powers.size(); ++i)
      if (powers[i] > 0 && count[i] == 0) {
        --*std::max_element(count.begin(), count.end());
        count[i] = 1;
      }
  return count;
}

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

// What update_origin did.
enum class OriginUpdate {
  failed,          // the path cannot be kept: re-emit it
  verified,        // segment 0 was traced to the kept primary hit (point, spot)
  moved,           // the origin moved along the kept direction (quad, disc): segment 0 untested
  resample_first,  // as verified, but the primary hit is not diffuse: re-trace from it
};

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
// The result of update_origin for one path, kept from update_origins to verify_paths.
struct OriginResult {
  OriginUpdate update = OriginUpdate::failed;
  Hit hit;
  bool traced = false;  // a visibility ray was traced
};

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
      ph.object = hit.object;
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

struct EmbreePhotonTracer::Scratch {
  std::vector<BlockOutput> blocks;
  // verify_paths -> retrace_marked: the visibility ray's hit of each path's restart segment, so
  // that the re-trace does not trace it twice (Paper II §3.3).
  std::vector<Hit> handover_hit;
  std::vector<char> has_handover;
  TraceStats verify_stats;
  // update_origins -> verify_paths: each path's origin update (§3.1).
  std::vector<OriginResult> origins;
  const PhotonBatch* origins_batch = nullptr;
  TraceStats origin_stats;
};

EmbreePhotonTracer::EmbreePhotonTracer(const EmbreeScene& world,
                                       std::optional<uint32_t> seed_scramble)
    : world_(world), seed_scramble_(seed_scramble), scratch_(std::make_unique<Scratch>()) {}

uint32_t EmbreePhotonTracer::path_seed(const TraceSettings& settings) const {
  return seed_scramble_ ? hash_combine(settings.seed, *seed_scramble_) : settings.seed;
}
EmbreePhotonTracer::~EmbreePhotonTracer() = default;

uint32_t EmbreePhotonTracer::light_count() const { return LightSet(world_).size(); }

glm::vec3 EmbreePhotonTracer::light_power(uint32_t light) const {
  LightSet lights(world_);
  if (light >= lights.size()) throw Error(fmt::format("photon tracer: no light {}", light));
  return lights.emitter(light).power;
}

void EmbreePhotonTracer::set_emission_density(uint32_t light, const EmissionDensity* density) {
  uint32_t n = light_count();
  if (light >= n)
    throw Error(fmt::format("photon tracer: no light {} (the scene has {})", light, n));
  densities_.resize(std::max<size_t>(densities_.size(), n));
  density_version_.resize(densities_.size(), 0);
  densities_[light] =
      density ? std::make_shared<Distribution2D>(density->width, density->height, density->texels)
              : nullptr;
  ++density_version_[light];
  grid_densities_.resize(densities_.size());
  grid_densities_[light] = density ? *density : EmissionDensity{};
}

TraceStats EmbreePhotonTracer::trace(const TraceSettings& settings, PhotonBatch& out) {
  check_settings(settings);
  if (settings.aaps) return trace_aaps(settings, out);
  auto t0 = std::chrono::steady_clock::now();
  LightSet lights(world_);
  densities_.resize(std::max<size_t>(densities_.size(), lights.size()));
  density_version_.resize(densities_.size(), 0);
  std::vector<float> powers(lights.size());
  for (uint32_t e = 0; e < lights.size(); ++e) powers[e] = mean3(lights.emitter(e).power);

  out.photons.clear();
  out.paths = LightPaths{};
  TraceStats stats;
  uint32_t seed = settings.seed_per_frame ? hash_combine(path_seed(settings), world_.state().frame)
                                          : path_seed(settings);

  std::vector<uint32_t> emitted(lights.size(), 0);  // paths emitted so far per light
  std::vector<uint32_t> emission_count = split_paths(powers, settings.paths);
  for (auto& n : emission_count) n = std::max(n, 1u);
  Context c{&world_,        &lights,           &densities_,    seed, settings.max_bounces,
            settings.store, settings.rr_start, &emission_count};
  bool keep = settings.keep_paths;
  uint32_t wave = settings.paths, total = 0;
  for (;;) {
    std::vector<uint32_t> alloc = split_paths(powers, wave);
    std::vector<PathTask> tasks;
    tasks.reserve(wave);
    for (uint32_t e = 0; e < lights.size(); ++e)
      for (uint32_t j = 0; j < alloc[e]; ++j) tasks.push_back({e, emitted[e] + j});
    uint32_t blocks = uint32_t((tasks.size() + kBlockSize - 1) / kBlockSize);
    std::vector<BlockOutput>& outputs = scratch_->blocks;
    reset_blocks(outputs, blocks);
    tbb::parallel_for(
        tbb::blocked_range<uint32_t>(0, blocks, 1), [&](const tbb::blocked_range<uint32_t>& r) {
          std::vector<PathVertex> verts;
          std::vector<PhotonRecord> photons;
          for (uint32_t b = r.begin(); b != r.end(); ++b) {
            BlockOutput& o = outputs[b];
            uint32_t end = std::min<uint32_t>(uint32_t(tasks.size()), (b + 1) * kBlockSize);
            for (uint32_t t = b * kBlockSize; t < end; ++t) {
              verts.clear();
              photons.clear();
              glm::vec2 uv, dir;
              verts.push_back(emit(c, tasks[t], &uv, &dir));
              uint32_t local =
                  t - b * kBlockSize;  // path index within the wave, fixed up in gather
              o.rays += continue_path(c, tasks[t], b * kBlockSize + local, verts, photons);
              append_path(o, tasks[t], uv, dir, keep, verts, photons);
            }
          }
        });
    gather(outputs, blocks, total, keep, out, stats);
    for (uint32_t e = 0; e < lights.size(); ++e) emitted[e] += alloc[e];
    total += uint32_t(tasks.size());
    if (settings.photon_target == 0 || out.photons.size() >= settings.photon_target ||
        total >= settings.max_paths || tasks.empty())
      break;
    // Next wave: enough paths for the photons still missing at the rate seen so far, plus 10%.
    double rate = double(out.photons.size()) / std::max<uint32_t>(total, 1);
    double need = (settings.photon_target - out.photons.size()) / std::max(rate, 1e-3) * 1.1 + 64;
    wave = uint32_t(std::min<double>(need, double(settings.max_paths - total)));
    if (wave == 0) break;
  }
  // Photon-target mode: power and spacing were set for the first wave's path count; rescale to the
  // final count of each emitter.
  for (uint32_t e = 0; e < lights.size(); ++e) {
    if (emitted[e] == emission_count[e] || emitted[e] == 0) continue;
    float power_scale = float(emission_count[e]) / emitted[e];
    float spacing_scale = std::sqrt(power_scale);
    for (auto& p : out.photons)
      if (p.light == e)
        p.power *= power_scale, p.footprint_u *= spacing_scale, p.footprint_v *= spacing_scale;
    for (auto& path : out.paths.paths) {
      if (path.light != e) continue;
      for (uint32_t v = 0; v < path.vertex_count; ++v) {
        PathVertex& pv = out.paths.vertices[path.first_vertex + v];
        pv.power *= power_scale;
        pv.spacing *= spacing_scale;
      }
    }
  }
  if (keep) {
    LightPaths& lp = out.paths;
    lp.object_to_world.resize(world_.object_count());
    for (uint32_t o = 0; o < world_.object_count(); ++o)
      lp.object_to_world[o] = world_.object_to_world(o);
    lp.light_state = light_state(world_, lights, density_version_);
    lp.paths_per_light = emitted;
    lp.seed = seed;
    lp.max_bounces = settings.max_bounces;
    lp.store = settings.store;
    lp.rr_start = settings.rr_start;
  }
  stats.paths = total;
  stats.photons = out.photons.size();
  stats.seconds = io::seconds_since(t0);
  out.stats = stats;
  return stats;
}

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
  Scratch& scratch = *scratch_;
  scratch.verify_stats = TraceStats{};
  if (!motion.compatible) {
    TraceSettings fresh = settings;
    fresh.keep_paths = true;
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
  Scratch& scratch = *scratch_;
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
  Scratch& scratch = *scratch_;
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
  Context c{&world_,         &lights,   &densities_,  old.seed,
            old.max_bounces, old.store, old.rr_start, &emission_count};
  uint32_t blocks = (n_paths + kBlockSize - 1) / kBlockSize;
  std::vector<BlockOutput>& outputs = scratch.blocks;
  reset_blocks(outputs, blocks);
  const std::vector<PhotonRecord>& old_photons = batch.photons;
  tbb::parallel_for(
      tbb::blocked_range<uint32_t>(0, blocks, 1), [&](const tbb::blocked_range<uint32_t>& r) {
        std::vector<PathVertex> verts;
        std::vector<PhotonRecord> photons;
        for (uint32_t b = r.begin(); b != r.end(); ++b) {
          BlockOutput& o = outputs[b];
          uint32_t end = std::min(n_paths, (b + 1) * kBlockSize);
          for (uint32_t pi = b * kBlockSize; pi < end; ++pi) {
            const LightPath& path = old.paths[pi];
            PathTask task{path.light, path.sample};
            const PathVertex* pv = &old.vertices[path.first_vertex];
            auto first_photon = old_photons.begin() + path.first_photon;
            verts.clear();
            photons.clear();
            glm::vec2 uv = path.emission_uv, dir = path.emission_dir;
            uint32_t restart = path.restart;
            if (restart == LightPath::kKeep) {  // still valid: kept as it was (or moved within T)
              verts.assign(pv, pv + path.vertex_count);
              photons.assign(first_photon, first_photon + path.photon_count);
            } else if (restart == LightPath::kReemit) {
              verts.push_back(emit(c, task, &uv, &dir));
            } else if (restart == LightPath::kRefill) {
              glm::vec4 fixed{uv, dir};
              verts.push_back(emit(c, task, &uv, &dir, &fixed));
            } else {  // keep vertices 0..restart and the photons stored on them
              verts.assign(pv, pv + restart + 1);
              verts.back().flags &= ~(PathVertex::kEscapes | PathVertex::kTerminated);
              photons.assign(first_photon, first_photon + photon_at_vertex(pv, restart + 1));
            }
            for (auto& ph : photons) ph.path = pi;
            if (restart != LightPath::kKeep) {
              // A handed-over hit belongs to a restart segment (not to a path re-emitted since).
              bool segment = restart < LightPath::kRefill;
              const Hit* hit =
                  segment && scratch.has_handover[pi] ? &scratch.handover_hit[pi] : nullptr;
              uint64_t rays = continue_path(c, task, pi, verts, photons, hit);
              o.rays += rays, o.segments_retraced += rays, ++o.paths_retraced;
            }
            append_path(o, task, uv, dir, true, verts, photons);
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
  gather(outputs, blocks, 0, true, next, stats);
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

// ---- AAPS (seed 004 §1.4-1.5) -------------------------------------------------------------------

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

glm::vec2 GridEmission::jittered(const Task& t) const {
  uint32_t h = hash_combine(t.texel, t.cell, t.m);
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
                lights.emit(e, settings.aaps_jitter ? grid.jittered(cell) : cell.uv, {0.5f, 0.5f});
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

std::unique_ptr<PhotonTracer> make_photon_tracer(const EmbreeScene& world,
                                                 std::optional<uint32_t> seed_scramble) {
  return std::make_unique<EmbreePhotonTracer>(world, seed_scramble);
}

}  // namespace pb::trace
