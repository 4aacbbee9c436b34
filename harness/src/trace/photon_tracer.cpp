#include "trace/photon_tracer.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>

#include "io/clock.h"
#include "photonbench/error.h"
#include "trace/aimed_emission.h"
#include "trace/bsdf.h"
#include "trace/lights.h"
#include "trace/photon_paths.h"

namespace pb::trace {

using namespace detail;

namespace {

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

// Four lanes of floats (GCC/Clang vector extensions) for cosine_hemisphere4.
using Float4 = float __attribute__((vector_size(16)));

// cosine_hemisphere of four points at once: per lane the very operations of concentric_disk,
// cos_sin_quarter and cosine_hemisphere (sampling.h), in the same order, so each lane gives the
// same bits as the scalar call; the differentials of a diffuse bounce need four of them.
std::array<glm::vec3, 4> cosine_hemisphere4(const Float4& ux, const Float4& uy) {
  const Float4 ox = 2.f * ux - 1.f, oy = 2.f * uy - 1.f;
  const Float4 zero = {0.f, 0.f, 0.f, 0.f}, one = {1.f, 1.f, 1.f, 1.f};
  const auto x_major = (ox < zero ? -ox : ox) > (oy < zero ? -oy : oy);
  const Float4 r = x_major ? ox : oy, minor = x_major ? oy : ox;
  const Float4 phi = (kPi / 4) * (minor / (r != zero ? r : one));
  const Float4 x2 = phi * phi;
  const Float4 sin_phi =
      phi * (1.f + x2 * (-1.f / 6 + x2 * (1.f / 120 + x2 * (-1.f / 5040 + x2 / 362880))));
  const Float4 cos_phi =
      1.f +
      x2 * (-1.f / 2 + x2 * (1.f / 24 + x2 * (-1.f / 720 + x2 * (1.f / 40320 - x2 / 3628800))));
  const Float4 dx = r * (x_major ? cos_phi : sin_phi), dy = r * (x_major ? sin_phi : cos_phi);
  const Float4 z2 = 1.f - dx * dx - dy * dy;
  std::array<glm::vec3, 4> out;
  for (int i = 0; i < 4; ++i) out[i] = {dx[i], dy[i], std::sqrt(std::max(0.f, z2[i]))};
  return out;
}

}  // namespace

namespace detail {

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

glm::vec3 spawn_origin(const PathVertex& v) {
  if (v.normal == glm::vec3(0.f)) return v.position;
  float eps = EmbreeScene::ray_epsilon(v.position);
  return v.position + v.normal * (glm::dot(v.direction, v.normal) >= 0 ? eps : -eps);
}

PathVertex emit(const Context& c, const PathTask& task, glm::vec2* uv_out, glm::vec2* dir_out,
                const glm::vec4* fixed) {
  glm::vec4 xi = fixed ? *fixed : c.sample(task, 0);
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
  PathVertex v = start_vertex(c, task.light, r, n * pdf);
  if (uv_out) *uv_out = uv;
  if (dir_out) *dir_out = {xi.z, xi.w};
  return v;
}

PathVertex start_vertex(const Context& c, uint32_t light, const EmissionRay& r,
                        float photon_density) {
  PathVertex v;
  v.position = r.origin;
  v.object = kNoObject;
  v.direction = r.direction;
  v.normal = r.normal;
  v.power = photon_density > 0 ? r.power / photon_density : glm::vec3(0.f);
  v.spacing = photon_density > 0 ? 1.f / std::sqrt(photon_density) : 0.f;
  v.dp_du = r.dp_du, v.dp_dv = r.dp_dv, v.dd_du = r.dd_du, v.dd_dv = r.dd_dv;
  if (c.policy && c.policy->shapes_footprints()) {
    Footprint f = footprint_of(v);
    c.policy->emitted(emitter_kind(c.lights->emitter(light).type), r.direction, f);
    set_footprint(v, f);
  }
  if (!(max3(v.power) > 0)) v.flags = PathVertex::kTerminated;
  return v;
}

uint64_t continue_path(const Context& c, const PathTask& task, uint32_t path_index,
                       std::vector<PathVertex>& verts, std::vector<PhotonRecord>& photons,
                       const Hit* first_hit) {
  const EmbreeScene& world = *c.world;
  const scene::Scene& scene = world.scene();
  float restart_spacing = 1.f / std::sqrt(float(std::max(1u, (*c.emission_count)[task.light])));
  const VertexPolicy* policy = c.policy;
  const bool footprint_hooks = policy && policy->shapes_footprints();
  const bool differentials = c.differentials;
  // The part being traced: its interaction count, the policy's bits, how it left its last vertex.
  // A split leaves its other part waiting (a part splits at most once per vertex; a policy that
  // splits again at a later vertex keeps one waiting part per split).
  struct Part {
    uint32_t k = 0;
    uint32_t state = 0;
    Scatter arrived_by = Scatter::sample;
    PathVertex vertex;
  };
  // Left uninitialised (a Part's vertex would otherwise be zeroed kMaxSplitParts times a path):
  // most paths never split.
  union WaitingPart {
    Part part;
    WaitingPart() {}
  };
  WaitingPart waiting[kMaxSplitParts];
  int waiting_count = 0;
  uint32_t k = uint32_t(verts.size()) - 1;  // index of the interaction the next segment leads to
  uint32_t state = 0;
  Scatter arrived_by = Scatter::sample;
  uint64_t rays = 0;
  for (;;) {
    // The path's last vertex, read in place: nothing is appended to `verts` before its last use.
    const PathVertex& v = verts.back();
    if ((v.flags & PathVertex::kTerminated) || k >= c.max_bounces) {
      if (!(v.flags & PathVertex::kTerminated)) verts.back().flags |= PathVertex::kTerminated;
      if (waiting_count == 0) return rays;
      const Part& part = waiting[--waiting_count].part;
      k = part.k, state = part.state, arrived_by = part.arrived_by;
      verts.push_back(part.vertex);
      continue;
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
      continue;
    }
    PathVertex next;
    next.position = hit.position;
    next.object = hit.object;
    glm::vec3 ng =
        glm::dot(hit.geometric_normal, dir) > 0 ? -hit.geometric_normal : hit.geometric_normal;
    next.normal = ng;
    next.spacing = v.spacing;
    next.specular_mask = v.specular_mask;
    glm::vec3 dp_du(0.f), dp_dv(0.f);
    if (differentials) {
      dp_du = transfer_differential(dir, ng, hit.t, v.dp_du, v.dd_du);
      dp_dv = transfer_differential(dir, ng, hit.t, v.dp_dv, v.dd_dv);
    }
    if (world.is_light_object(hit.object)) {  // a luminaire absorbs what reaches it
      next.flags = PathVertex::kTerminated;
      verts.push_back(next);
      ++k;
      continue;
    }
    const scene::Material& material = scene.materials[hit.material];
    Bsdf bsdf(material, hit);
    bool diffuse = bsdf.is_diffuse();
    uint32_t mask = v.specular_mask;
    VertexDecision decision;
    Footprint arriving;
    if (policy) {
      arriving = {dp_du, dp_dv, v.dd_du, v.dd_dv, v.spacing};
      Interaction at;
      at.index = k;
      at.light = task.light;
      at.surface = surface_kind(material.type, diffuse);
      at.specular_mask = mask;
      at.arrived_by = arrived_by;
      at.state = state;
      at.position = hit.position, at.normal = ng, at.direction = dir, at.power = v.power;
      at.footprint = differentials ? &arriving : nullptr;
      at.settings = c.settings;
      decision = policy->decide(at);
      decision.store = decision.store && diffuse;
    } else {
      decision.store = diffuse && (photon_kind(mask, k) & c.store);
    }
    if (decision.store) {
      PhotonRecord p{};
      p.position = hit.position;
      p.triangle = world.scene_triangle(hit.object, hit.primitive);
      p.power = v.power;
      p.path = path_index;
      p.direction = dir;
      p.bounce = k;
      p.normal = ng;
      p.specular_mask = mask;
      p.footprint_u = dp_du * v.spacing;
      p.footprint_v = dp_dv * v.spacing;
      p.light = task.light;
      p.flags = decision.photon_flags;
      photons.push_back(p);
      next.flags |= PathVertex::kStored;
    }
    if (!diffuse) mask |= 1u << k;
    next.specular_mask = mask;
    const Scatter scatter =
        policy ? decision.scatter
               : (k + 1 < c.max_bounces && storable_after(mask, k, c.store) ? Scatter::sample
                                                                            : Scatter::end);
    if (scatter == Scatter::reflect || scatter == Scatter::refract || scatter == Scatter::split) {
      // The deterministic specular continuations: the chosen lobe of a mirror or smooth
      // dielectric, its power scaled by that lobe's Fresnel share; no roulette.
      const bool dielectric = material.type == scene::MaterialType::dielectric;
      const bool delta = dielectric || material.type == scene::MaterialType::mirror;
      Triangle tri =
          delta && differentials ? world.triangle(hit.object, hit.primitive) : Triangle{};
      auto leave = [&](bool reflect, PathVertex& out, Scatter& left_by) {
        BsdfSample s;
        bool ok = bsdf.sample(-dir, {0.5f, 0.5f, reflect ? 0.f : 1.f}, Transport::importance, s);
        if (!ok && !reflect) ok = bsdf.sample(-dir, {0.5f, 0.5f, 0.f}, Transport::importance, s);
        if (!ok) return false;
        out = next;
        out.power = v.power * s.weight * (dielectric ? s.pdf : 1.f);
        if (!(max3(out.power) > 0)) return false;
        out.direction = s.wi;
        if (differentials) {
          out.dp_du = dp_du;
          out.dp_dv = dp_dv;
          out.dd_du = scatter_differential(tri, hit, s, dir, dp_du, v.dd_du);
          out.dd_dv = scatter_differential(tri, hit, s, dir, dp_dv, v.dd_dv);
        }
        left_by = s.transmitted ? Scatter::refract : Scatter::reflect;
        return true;
      };
      PathVertex reflected, refracted;
      Scatter reflected_by = Scatter::reflect, refracted_by = Scatter::refract;
      bool has_reflected = false, has_refracted = false;
      if (delta && scatter != Scatter::refract)
        has_reflected = leave(true, reflected, reflected_by);
      if (delta && scatter != Scatter::reflect)
        has_refracted = leave(false, refracted, refracted_by);
      if (has_reflected && has_refracted) {
        if (waiting_count == kMaxSplitParts)
          throw Error("photon tracer: a policy split one path more than " +
                      std::to_string(kMaxSplitParts) + " times");
        waiting[waiting_count++].part = {k + 1, decision.state, reflected_by, reflected};
      }
      if (has_reflected || has_refracted) {
        verts.push_back(has_refracted ? refracted : reflected);
        arrived_by = has_refracted ? refracted_by : reflected_by;
        state = decision.state;
        ++k;
        continue;
      }
    } else if (scatter == Scatter::sample) {
      glm::vec4 xi = c.sample(task, 1 + k);
      BsdfSample s;
      bool alive = bsdf.sample(-dir, {xi.x, xi.y, xi.z}, Transport::importance, s);
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
        if (diffuse && footprint_hooks) {
          Footprint f = arriving;
          policy->scattered_diffusely(s.normal, s.wi, f);
          set_footprint(next, f);
        } else if (!differentials) {
          // Nothing to carry: the vertex's differentials stay zero.
        } else if (diffuse) {
          // The new direction depends on this bounce's two sample dimensions only: restart the
          // differentials from the cosine map (finite differences) about this point.
          const float h = 1e-3f;
          glm::vec2 u = glm::clamp(glm::vec2(xi.x, xi.y), glm::vec2(h), glm::vec2(1.f - h));
          Frame f(s.normal);
          next.dp_du = next.dp_dv = glm::vec3(0.f);
          // u + (h, 0), u - (h, 0), u + (0, h), u - (0, h).
          const std::array<glm::vec3, 4> d =
              cosine_hemisphere4(Float4{u.x + h, u.x - h, u.x + 0.f, u.x - 0.f},
                                 Float4{u.y + 0.f, u.y - 0.f, u.y + h, u.y - h});
          next.dd_du = f.to_world(d[0] - d[1]) / (2 * h);
          next.dd_dv = f.to_world(d[2] - d[3]) / (2 * h);
          next.spacing = restart_spacing;
        } else {
          Triangle tri = world.triangle(hit.object, hit.primitive);
          next.dp_du = dp_du;
          next.dp_dv = dp_dv;
          next.dd_du = scatter_differential(tri, hit, s, dir, dp_du, v.dd_du);
          next.dd_dv = scatter_differential(tri, hit, s, dir, dp_dv, v.dd_dv);
        }
        if (footprint_hooks && survival < 1.f) {
          Footprint f = footprint_of(next);
          policy->survived_roulette(survival, f);
          set_footprint(next, f);
        }
        verts.push_back(next);
        arrived_by = Scatter::sample;
        state = decision.state;
        ++k;
        continue;
      }
    }
    next.flags |= PathVertex::kTerminated;
    verts.push_back(next);
    ++k;
  }
}

void append_path(BlockOutput& out, const PathTask& task, glm::vec2 uv, glm::vec2 dir, bool keep,
                 const std::vector<PathVertex>& verts, size_t first_photon) {
  if (keep) {
    LightPath p;
    p.light = task.light;
    p.sample = task.sample;
    p.emission_uv = uv;
    p.emission_dir = dir;
    p.first_photon = uint32_t(first_photon);
    p.photon_count = uint32_t(out.photons.size() - first_photon);
    p.first_vertex = uint32_t(out.vertices.size());
    p.vertex_count = uint32_t(verts.size());
    out.vertices.insert(out.vertices.end(), verts.begin(), verts.end());
    out.paths.push_back(p);
  }
}

// Resizes `v` to n; past its capacity, with an eighth more room. The number of photons a trace
// stores varies from frame to frame: with an exact fit the whole batch moved to fresh memory (and
// faulted it in) whenever a trace stored a few more than any before, which on cornell-glass (1.3
// million photons) cost 0.37 s, twice the trace itself (bench_trace).
template <class T>
void resize_with_room(std::vector<T>& v, size_t n) {
  if (n > v.capacity()) v.reserve(n + n / 8);
  v.resize(n);
}

size_t gather(std::vector<BlockOutput>& blocks, size_t block_count, uint32_t path_offset, bool keep,
              size_t photons_before, PhotonBatch& out, TraceStats& stats) {
  std::vector<size_t> photon_at(block_count + 1), vertex_at(block_count + 1),
      path_at(block_count + 1);
  photon_at[0] = photons_before;
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
  if (out.photons.size() < photon_at[block_count]) {
    // Past the capacity the vector moves: carry the photons gathered so far, not the rest of the
    // last trace's.
    if (photon_at[block_count] > out.photons.capacity()) out.photons.resize(photons_before);
    resize_with_room(out.photons, photon_at[block_count]);
  }
  if (keep) {
    resize_with_room(out.paths.vertices, vertex_at[block_count]);
    resize_with_room(out.paths.paths, path_at[block_count]);
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
  return photon_at[block_count];
}

void reset_paths(LightPaths& paths, bool keep) {
  std::vector<LightPath> kept_paths;
  std::vector<PathVertex> kept_vertices;
  if (keep) {
    kept_paths = std::move(paths.paths);
    kept_vertices = std::move(paths.vertices);
    kept_paths.clear();
    kept_vertices.clear();
  }
  paths = LightPaths{};
  paths.paths = std::move(kept_paths);
  paths.vertices = std::move(kept_vertices);
}

void reset_blocks(std::vector<BlockOutput>& blocks, size_t count) {
  if (blocks.size() < count) blocks.resize(count);
  for (size_t b = 0; b < count; ++b) {
    blocks[b].paths.clear();
    blocks[b].vertices.clear();
    blocks[b].photons.clear();
    blocks[b].rays = blocks[b].paths_retraced = blocks[b].segments_retraced = 0;
  }
}

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

void check_settings(const TraceSettings& s) {
  if (s.max_bounces < 1 || s.max_bounces > 31)
    throw InputError(
        fmt::format("photon tracer: max_bounces {} is outside [1, 31]", s.max_bounces));
  if (s.paths < 1) throw InputError("photon tracer: paths must be at least 1");
  if ((s.store & ~uint32_t(kAllPhotons)) != 0 || s.store == 0)
    throw InputError("photon tracer: store must be a non-empty PhotonKind mask");
  if (s.keep_light_paths && s.policy)
    throw InputError(
        "photon tracer: keep_light_paths goes with the tracer's own decisions only (a kept path "
        "is re-traced by them)");
  if (s.photon_target > 0 && (s.emission || s.policy))
    throw InputError(
        "photon tracer: photon_target goes with the tracer's own emission and decisions only (its "
        "waves rescale power and footprints after the trace, which a policy's flags cannot "
        "follow)");
}

}  // namespace detail

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

EmbreePhotonTracer::EmbreePhotonTracer(const EmbreeScene& world,
                                       std::optional<uint32_t> seed_scramble)
    : world_(world), seed_scramble_(seed_scramble), scratch_(std::make_unique<TracerScratch>()) {}

uint32_t EmbreePhotonTracer::path_seed(const TraceSettings& settings) const {
  return seed_scramble_ ? hash_combine(settings.seed, *seed_scramble_) : settings.seed;
}
EmbreePhotonTracer::~EmbreePhotonTracer() = default;

uint32_t EmbreePhotonTracer::frame_seed(const TraceSettings& settings) const {
  return settings.seed_per_frame ? hash_combine(path_seed(settings), world_.state().frame)
                                 : path_seed(settings);
}

Context EmbreePhotonTracer::trace_context(const TraceSettings& settings, const LightSet& lights,
                                          uint32_t seed,
                                          const std::vector<uint32_t>& emission_count) const {
  Context c{&world_,
            &lights,
            &densities_,
            seed,
            settings.max_bounces,
            settings.store,
            settings.rr_start,
            &emission_count,
            settings.policy,
            &settings,
            {}};
  c.differentials =
      settings.footprints || (settings.policy && settings.policy->shapes_footprints());
  prepare_sample_seeds(c, lights.size());
  return c;
}

uint32_t EmbreePhotonTracer::light_count() const { return LightSet(world_).size(); }

glm::vec3 EmbreePhotonTracer::light_power(uint32_t light) const {
  LightSet lights(world_);
  if (light >= lights.size()) throw Error(fmt::format("photon tracer: no light {}", light));
  return lights.emitter(light).power;
}

EmitterInfo EmbreePhotonTracer::light(uint32_t light) const {
  LightSet lights(world_);
  if (light >= lights.size()) throw Error(fmt::format("photon tracer: no light {}", light));
  return {emitter_kind(lights.emitter(light).type), lights.emitter(light).power};
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
}

std::vector<std::optional<EmissionDensity>> EmbreePhotonTracer::aimed_emission_densities() const {
  return trace::aimed_emission_densities(world_);
}

TraceStats EmbreePhotonTracer::trace_sampled(const TraceSettings& settings, PhotonBatch& out) {
  auto t0 = std::chrono::steady_clock::now();
  LightSet lights(world_);
  std::vector<EmitterInfo> emitters(lights.size());
  for (uint32_t e = 0; e < lights.size(); ++e)
    emitters[e] = {emitter_kind(lights.emitter(e).type), lights.emitter(e).power};
  EmissionSampler& sampler = *settings.emission;
  const uint64_t total = sampler.prepare({emitters, world_.state().frame, seed_scramble_});
  if (total > std::numeric_limits<uint32_t>::max())
    throw InputError(
        fmt::format("photon tracer: an emission sampler asks for {} photons, more "
                    "than 2^32",
                    total));
  reset_paths(out.paths, settings.keep_light_paths);
  out.emitted_power.assign(total, 0.f);
  // A sampled emission draws no random numbers at emission; its interactions draw from the
  // Sobol sequence of its index, as a path of the tracer's own emission does.
  std::vector<uint32_t> emission_count(lights.size(), 1u);
  Context c = trace_context(settings, lights, frame_seed(settings), emission_count);
  const uint32_t blocks = uint32_t((total + kBlockSize - 1) / kBlockSize);
  std::vector<BlockOutput>& outputs = scratch_->blocks;
  reset_blocks(outputs, blocks);
  const bool keep = settings.keep_light_paths;
  tbb::parallel_for(
      tbb::blocked_range<uint32_t>(0, blocks, 1), [&](const tbb::blocked_range<uint32_t>& r) {
        std::vector<PathVertex> verts;
        for (uint32_t b = r.begin(); b != r.end(); ++b) {
          BlockOutput& o = outputs[b];
          const uint32_t end = uint32_t(std::min<uint64_t>(total, uint64_t(b + 1) * kBlockSize));
          for (uint32_t i = b * kBlockSize; i < end; ++i) {
            const EmissionPoint point = sampler.emission(i);
            if (point.light >= lights.size())
              throw Error(fmt::format("photon tracer: emission {} names light {} of {}", i,
                                      point.light, lights.size()));
            const EmissionRay ray = lights.emit(point.light, point.uv, point.direction);
            const PathTask task{point.light, i};
            verts.clear();
            const size_t first_photon = o.photons.size();
            verts.push_back(start_vertex(c, point.light, ray, point.photon_density));
            out.emitted_power[i] = mean3(verts.back().power);
            o.rays += continue_path(c, task, point.id, verts, o.photons);
            append_path(o, task, point.uv, point.direction, keep, verts, first_photon);
          }
        }
      });
  TraceStats stats;
  out.photons.resize(gather(outputs, blocks, 0, keep, 0, out, stats));
  if (keep) {  // the snapshot; no paths_per_light: these are not the tracer's own emissions
    LightPaths& lp = out.paths;
    lp.object_to_world.resize(world_.object_count());
    for (uint32_t o = 0; o < world_.object_count(); ++o)
      lp.object_to_world[o] = world_.object_to_world(o);
    lp.light_state = light_state(world_, lights, density_version_);
    lp.seed = c.seed;
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

TraceStats EmbreePhotonTracer::trace(const TraceSettings& settings, PhotonBatch& out) {
  check_settings(settings);
  if (settings.emission) return trace_sampled(settings, out);
  auto t0 = std::chrono::steady_clock::now();
  LightSet lights(world_);
  densities_.resize(std::max<size_t>(densities_.size(), lights.size()));
  density_version_.resize(densities_.size(), 0);
  std::vector<float> powers(lights.size());
  for (uint32_t e = 0; e < lights.size(); ++e) powers[e] = mean3(lights.emitter(e).power);

  bool keep = settings.keep_light_paths;
  reset_paths(out.paths, keep);
  size_t stored = 0;  // photons gathered so far (out.photons is trimmed to it after the waves)
  TraceStats stats;
  const uint32_t seed = frame_seed(settings);

  std::vector<uint32_t> emitted(lights.size(), 0);  // paths emitted so far per light
  std::vector<uint32_t> emission_count = split_paths(powers, settings.paths);
  for (auto& n : emission_count) n = std::max(n, 1u);
  Context c = trace_context(settings, lights, seed, emission_count);
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
          for (uint32_t b = r.begin(); b != r.end(); ++b) {
            BlockOutput& o = outputs[b];
            uint32_t end = std::min<uint32_t>(uint32_t(tasks.size()), (b + 1) * kBlockSize);
            for (uint32_t t = b * kBlockSize; t < end; ++t) {
              verts.clear();
              const size_t first_photon = o.photons.size();
              glm::vec2 uv, dir;
              verts.push_back(emit(c, tasks[t], &uv, &dir));
              uint32_t local =
                  t - b * kBlockSize;  // path index within the wave, fixed up in gather
              o.rays += continue_path(c, tasks[t], b * kBlockSize + local, verts, o.photons);
              append_path(o, tasks[t], uv, dir, keep, verts, first_photon);
            }
          }
        });
    stored = gather(outputs, blocks, total, keep, stored, out, stats);
    for (uint32_t e = 0; e < lights.size(); ++e) emitted[e] += alloc[e];
    total += uint32_t(tasks.size());
    if (settings.photon_target == 0 || stored >= settings.photon_target ||
        total >= settings.max_paths || tasks.empty())
      break;
    // Next wave: enough paths for the photons still missing at the rate seen so far, plus 10%.
    double rate = double(stored) / std::max<uint32_t>(total, 1);
    double need = (settings.photon_target - stored) / std::max(rate, 1e-3) * 1.1 + 64;
    wave = uint32_t(std::min<double>(need, double(settings.max_paths - total)));
    if (wave == 0) break;
  }
  out.photons.resize(stored);
  // Photon-target mode: power and spacing were set for the first wave's path count; rescale to the
  // final count of each emitter.
  for (uint32_t e = 0; e < lights.size(); ++e) {
    if (emitted[e] == emission_count[e] || emitted[e] == 0) continue;
    float power_scale = float(emission_count[e]) / emitted[e];
    float spacing_scale = std::sqrt(power_scale);
    for (auto& p : out.photons)
      if (p.light == e) {
        p.power *= power_scale, p.footprint_u *= spacing_scale, p.footprint_v *= spacing_scale;
      }
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

std::unique_ptr<PhotonTracer> make_photon_tracer(const EmbreeScene& world,
                                                 std::optional<uint32_t> seed_scramble) {
  return std::make_unique<EmbreePhotonTracer>(world, seed_scramble);
}

}  // namespace pb::trace
