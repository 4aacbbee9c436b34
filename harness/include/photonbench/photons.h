// The photon tracer as technique plugins see it: the photon record, the settings and policies of a
// trace (where photons leave the lights, what happens at each surface interaction), whole light
// paths for reuse across frames, and the emission-density hook of adaptive emission.
//
// The tracer runs on the CPU over the World's Embree scene (src/trace/), multi-threaded with oneTBB
// and deterministic for a given seed whatever the thread count: path i always uses sample index i
// of an Owen-scrambled Sobol sequence, and photons come back in path order.
//
// Units: positions in metres, power in watts per photon (RGB). Summing the power of every photon
// stored at first hits gives the power the lights deliver to the scene (tests/unit/trace_test.cpp
// checks this).
#pragma once

#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <memory>
#include <optional>
#include <span>
#include <vector>

namespace pb::trace {

#include "photonbench/photon_layout.h"

static_assert(sizeof(PhotonRecord) == 96, "std430 size of PhotonRecord");
static_assert(offsetof(PhotonRecord, position) == 0 && offsetof(PhotonRecord, triangle) == 12);
static_assert(offsetof(PhotonRecord, power) == 16 && offsetof(PhotonRecord, path) == 28);
static_assert(offsetof(PhotonRecord, direction) == 32 && offsetof(PhotonRecord, bounce) == 44);
static_assert(offsetof(PhotonRecord, normal) == 48 && offsetof(PhotonRecord, specular_mask) == 60);
static_assert(offsetof(PhotonRecord, footprint_u) == 64 && offsetof(PhotonRecord, light) == 76);
static_assert(offsetof(PhotonRecord, footprint_v) == 80 && offsetof(PhotonRecord, flags) == 92);

// Photons are classified by the light path expression from the light to the stored (diffuse) hit,
// in Heckbert's notation read from the light: S is any non-diffuse interaction (mirror, smooth or
// rough dielectric, rough conductor), D a diffuse one (diffuse and emissive materials). Photons are
// stored on diffuse surfaces only. The four kinds partition all stored photons.
enum PhotonKind : uint32_t {
  kDirectPhotons = 1u << 0,           // L D: the first hit (left out where direct light is shaded)
  kCausticPhotons = 1u << 1,          // L S+ D: the caustic map
  kIndirectPhotons = 1u << 2,         // L D (D|S)* D: first hit diffuse, at least one more bounce
  kCausticIndirectPhotons = 1u << 3,  // L S+ D (D|S)* D: first hit specular, a diffuse hit between
  kAllPhotons = 15u,
  kAllButDirectPhotons = kCausticPhotons | kIndirectPhotons | kCausticIndirectPhotons,
};

// The kind of a photon with `specular_mask` stored at interaction `bounce`.
inline PhotonKind photon_kind(uint32_t specular_mask, uint32_t bounce) {
  if (bounce == 0) return kDirectPhotons;
  uint32_t before = specular_mask & ((bounce >= 32 ? 0u : (1u << bounce)) - 1u);
  bool first_specular = (specular_mask & 1u) != 0;
  bool all_specular = before == ((bounce >= 32 ? 0u : (1u << bounce)) - 1u);
  if (first_specular) return all_specular ? kCausticPhotons : kCausticIndirectPhotons;
  return kIndirectPhotons;
}
inline PhotonKind photon_kind(const PhotonRecord& p) {
  return photon_kind(p.specular_mask, p.bounce);
}

// A 2D density over a light's emission domain [0,1]^2 (a technique's adaptive emission: a
// ray-density texture, a target distribution map): photons are emitted with probability
// proportional to the texel value, and their power is divided by that probability, so the
// expected power per texel is unchanged --
// except in texels of density 0, which emit nothing (their share of the light is dropped on
// purpose). The domain of each light type is equal-measure (uniform (u,v) emits power uniformly):
//   point: direction, z = 1 - 2u, phi = 2 pi v (equal-area sphere);
//   spot: direction in the outer cone, cos(theta) = 1 - u (1 - cos(outer)), phi = 2 pi v;
//   directional: the ray origin on a square perpendicular to the light covering the scene bounds;
//   quad: the point position + u edge_u + v edge_v (directions cosine-distributed);
//   disc: the point at radius sqrt(u) R, angle 2 pi v from its first radius (cosine directions);
//   emissive object: a point on its surface, u chooses the triangle by area.
// Rows run along v (texel (i, j) covers u in [i/width, (i+1)/width), v in [j/height,
// (j+1)/height)).
struct EmissionDensity {
  int width = 0, height = 0;
  std::vector<float> texels;  // width * height, row-major by v; non-negative, not all zero
};

// ---- Tracer policies: what a technique decides about its photons, while the tracer keeps the
// physics (BSDF sampling, Fresnel weights, Russian roulette, the transfer of ray differentials).
// A technique that needs another emission or another rule at a vertex supplies a policy from its
// own folder; the tracer names no technique.

// What the tracer emits from, in emission order: the scene's lights, then each emissive object.
enum class EmitterKind : uint32_t { point, spot, directional, quad, disc, mesh };
struct EmitterInfo {
  EmitterKind kind = EmitterKind::point;
  glm::vec3 power{0.0f};  // W (RGB), this frame
};

// One photon leaving a light, as an emission sampler places it.
struct EmissionPoint {
  uint32_t light = 0;
  glm::vec2 uv{0.5f};         // the point of the light's emission domain (see EmissionDensity)
  glm::vec2 direction{0.5f};  // surface emitters: the sample of the cosine-distributed direction
  // Photons this light emits per unit of its emission domain at `uv` (N times the density's pdf):
  // the photon carries the light's power divided by it, and its footprint is scaled by the photon
  // spacing 1 / sqrt(photon_density). 0: nothing is emitted (no ray, no photon; a kept path of
  // its light vertex alone), so a sampler can trace a subset of its emissions while each keeps its
  // index, and with it the samples its bounces draw.
  float photon_density = 1;
  uint32_t id = 0;  // PhotonRecord::path of the photons this emission stores
};

// The whole trace's context an emission sampler is prepared with.
struct EmissionFrame {
  std::span<const EmitterInfo> emitters;
  uint32_t frame = 0;
  // A seed axis' cell's scramble (none outside a seed axis): a sampler with no randomness of its
  // own hashes it in, so that the seeds of a seed axis see other photons.
  std::optional<uint32_t> seed_scramble;
};

// Where photons leave the lights: a sampler lists one trace's emissions. Without one the tracer
// emits `TraceSettings::paths` paths shared among the lights by power, each from an Owen-scrambled
// Sobol point, through the light's EmissionDensity where one is set.
class EmissionSampler {
 public:
  virtual ~EmissionSampler() = default;
  // Called once per trace, before any emission(): the number of photons to emit. Throws
  // InputError for lights it cannot emit from.
  virtual uint64_t prepare(const EmissionFrame& frame) = 0;
  // The i-th emission, i < prepare()'s count; called from many threads at once.
  virtual EmissionPoint emission(uint64_t i) const = 0;
};

// What a surface does to a photon, by the path-expression letter it adds: D (diffuse, emissive),
// or S (a perfect mirror, a smooth dielectric, or a rough lobe: glossy).
enum class SurfaceKind : uint32_t { diffuse, mirror, dielectric, glossy };

// How a photon leaves a vertex.
enum class Scatter : uint32_t {
  end,      // absorbed here (nothing traced further)
  sample,   // importance-sample the BSDF; Russian roulette from TraceSettings::rr_start
  reflect,  // the specular reflection, carrying its Fresnel share (mirror, smooth dielectric)
  refract,  // the specular refraction, carrying its share (total internal reflection reflects)
  split,    // both reflect and refract, each a part of its own that traces on with the decision's
            // state (the refracted part first); never roulette
};

// A photon's footprint: its ray differentials with respect to the two emission-domain coordinates,
// and the photon spacing that scales them (PhotonRecord::footprint_u = dp_du * spacing).
struct Footprint {
  glm::vec3 dp_du{0.0f}, dp_dv{0.0f}, dd_du{0.0f}, dd_dv{0.0f};
  float spacing = 0;
};

struct TraceSettings;

// A photon arriving at surface interaction `index`, as a vertex policy sees it.
struct Interaction {
  uint32_t index = 0;  // 0: the first hit from the light
  uint32_t light = 0;
  SurfaceKind surface = SurfaceKind::diffuse;
  uint32_t specular_mask = 0;            // interactions 0..index-1 (bit i: S), as in PhotonRecord
  Scatter arrived_by = Scatter::sample;  // how it left the vertex before (sample at emission)
  uint32_t state = 0;  // the policy's own bits, carried along the path (0 at emission)
  glm::vec3 position{0.0f}, normal{0.0f}, direction{0.0f}, power{0.0f};
  const Footprint* footprint = nullptr;  // arriving differentials, transferred to this hit
                                         // (null unless TraceSettings::footprints)
  const TraceSettings* settings = nullptr;
};

struct VertexDecision {
  bool store = false;         // store a photon here (diffuse surfaces only)
  uint32_t photon_flags = 0;  // its PhotonRecord::flags
  Scatter scatter = Scatter::sample;
  uint32_t state = 0;  // carried to the next interaction (of every part)
};

// The tracer's own decision, which a policy may start from: store where the photon's kind
// (photon_kind) is in `settings.store`; scatter by sampling while a photon can still be stored.
inline VertexDecision default_decision(const Interaction& at, uint32_t store, uint32_t max_bounces);

// A technique's rule at each surface interaction, and optionally how footprints start and change
// where the tracer has no one answer (a point light's emission, a diffuse bounce, roulette).
class VertexPolicy {
 public:
  virtual ~VertexPolicy() = default;
  virtual VertexDecision decide(const Interaction& at) const = 0;
  // Footprint hooks, called only when shapes_footprints(). Without them: differentials of the
  // emission domain's (u, v) at emission, restarted after a diffuse bounce from the finite
  // differences of the cosine map with spacing 1 / sqrt(N), untouched by roulette.
  virtual bool shapes_footprints() const { return false; }
  // At emission from `kind`, travelling `direction`.
  virtual void emitted(EmitterKind /*kind*/, const glm::vec3& /*direction*/,
                       Footprint& /*f*/) const {}
  // After a diffuse bounce about `normal` into `direction`; `f` holds the arriving positional
  // differentials (transferred to the hit), its directional ones are to be set.
  virtual void scattered_diffusely(const glm::vec3& /*normal*/, const glm::vec3& /*direction*/,
                                   Footprint& /*f*/) const {}
  // After surviving Russian roulette with probability `survival` < 1.
  virtual void survived_roulette(float /*survival*/, Footprint& /*f*/) const {}
};

struct TraceSettings {
  uint32_t paths = 100000;     // light paths emitted per trace, shared among lights by power
  uint32_t photon_target = 0;  // > 0: emit more paths until this many photons are stored (Paper I
      // §5); `paths` is then the first wave, and at most max_paths are used
  uint32_t max_paths = 1u << 26;
  uint32_t max_bounces = 8;  // surface interactions per path (stored or not), at most 31
  uint32_t store = kAllButDirectPhotons;  // PhotonKind mask (the default decision's)
  uint32_t rr_start = 1;  // Russian roulette from this interaction on (0 = the first hit)
  uint32_t seed = 1;
  bool seed_per_frame = true;  // true: the sequence is scrambled with hash(seed, frame) (fresh
                               // photons each frame); false: identical photons every frame
  // Keep whole light paths (PhotonBatch::paths) for the path-reuse service (retrace_invalid,
  // verify_paths): with the tracer's own decisions only. With an emission sampler, path i is
  // emission i (LightPath::sample = i) and its bounces draw the samples of index i, so the caller
  // can re-trace any subset and get the same paths (toolkit/selective_emission.h); the reuse
  // service re-validates only the tracer's own emission and traces a sampler's paths afresh.
  bool keep_light_paths = false;
  // Carry ray differentials along the paths (Igehy 1999) and store each photon's footprint
  // (PhotonRecord::footprint_u/v; Interaction::footprint for the policy). Off, footprints are zero,
  // Interaction::footprint is null, and the trace skips the differentials' transfer and scattering
  // (on cornell-box about a tenth of its time, bench_trace). A policy that shapes_footprints()
  // implies it.
  bool footprints = false;
  // The technique's policies (owned by it, alive through the trace; null: the tracer's own).
  // With an emission sampler, `paths`, `photon_target` and the seed are unused.
  EmissionSampler* emission = nullptr;
  const VertexPolicy* policy = nullptr;
};

// Can a photon still be stored after interaction k, given the path's mask with k's letter in it?
inline bool storable_after(uint32_t mask, uint32_t k, uint32_t store) {
  if (!(mask & 1u)) return (store & kIndirectPhotons) != 0;
  const uint32_t all = k >= 31 ? ~0u : ((1u << (k + 1)) - 1u);
  const bool all_specular = (mask & all) == all;
  return (store & (kCausticIndirectPhotons | (all_specular ? uint32_t(kCausticPhotons) : 0u))) != 0;
}

inline VertexDecision default_decision(const Interaction& at, uint32_t store,
                                       uint32_t max_bounces) {
  const bool diffuse = at.surface == SurfaceKind::diffuse;
  const uint32_t mask = at.specular_mask | (diffuse ? 0u : 1u << at.index);
  VertexDecision d;
  d.store = diffuse && (photon_kind(at.specular_mask, at.index) & store);
  d.scatter = at.index + 1 < max_bounces && storable_after(mask, at.index, store) ? Scatter::sample
                                                                                  : Scatter::end;
  return d;
}

// How verify_paths decides that a kept segment is still valid (Paper II §3.2-3.3).
enum class ReuseRule : uint32_t {
  exact,        // a ray wherever a moved object's box touches the segment; a path is invalid from
                // the first segment whose hit changed (retrace_invalid: equals a fresh trace)
  naive,        // §3.2: invalid from the first segment that touches a moved object's box or ends
                // on a moved object; no ray is traced to decide
  error_based,  // §3.3, Algorithm 1: a visibility ray along each suspect segment; a moved hit is
                // kept when the energy reflected towards the path's next vertex stays within
                // energy_threshold of the original, and the path re-traced from it otherwise
};
struct ReuseSettings {
  ReuseRule rule = ReuseRule::exact;
  float energy_threshold = 1e-3f;  // T of Eq. 2, a fraction of the original energy, per channel
  // §3.1: keep the paths of a moved light by moving their origins (point, spot: the new position,
  // the direction towards the kept primary hit, a visibility ray to it; quad: the kept direction
  // met with the moved light's plane). false: a moved light's paths are re-emitted whole.
  bool update_origins = false;
};

struct TraceStats {
  uint64_t paths = 0;           // light paths emitted (or re-validated)
  uint64_t rays = 0;            // rays traced: path segments, plus visibility rays of re-validation
  uint64_t photons = 0;         // photons stored
  uint64_t paths_retraced = 0;  // retrace_invalid: paths re-traced from some segment
  uint64_t segments_retraced = 0;  // retrace_invalid: segments replaced
  double seconds = 0;
  // Path verification (verify_paths / retrace_marked).
  uint64_t visibility_rays = 0;    // rays traced to re-validate segments (counted in `rays` too)
  uint64_t paths_kept = 0;         // paths that needed no re-traced segment
  uint64_t paths_moved = 0;        // error_based: paths kept with a vertex moved within T
  uint64_t full_retrace_rays = 0;  // segments of the resulting paths: what tracing all would cost
  double mrays_per_second() const { return seconds > 0 ? rays / seconds * 1e-6 : 0.0; }
};

// One vertex of a stored light path: vertex 0 lies on the light, vertex k > 0 is the k-th surface
// hit. The outgoing fields describe the segment that leaves the vertex; re-tracing from vertex k
// restarts from them, so a re-traced path continues exactly as a fresh trace would.
struct PathVertex {
  glm::vec3 position{0.0f};
  uint32_t object = ~0u;       // Scene::objects index; ~0u on the light
  glm::vec3 direction{0.0f};   // outgoing unit direction (unused on the last vertex)
  uint32_t specular_mask = 0;  // interactions 0..k-1 (bit i: interaction i was S)
  glm::vec3 power{0.0f};       // power carried by the outgoing segment, W
  uint32_t flags = 0;          // PathVertex::kStored | kEscapes | kTerminated
  glm::vec3 normal{0.0f};      // geometric normal (vertex 0: the light's, or 0 for a point light)
  float spacing = 0;           // photon spacing in the emission domain, 1 / sqrt(N density)
  glm::vec3 dp_du{0.0f}, dp_dv{0.0f}, dd_du{0.0f}, dd_dv{0.0f};  // outgoing ray differentials
  // The Russian-roulette survival probability R with which the outgoing segment was kept (`power`
  // is already divided by it; 1 where no roulette was played): power * survival is the energy
  // reflected towards the next vertex, what Paper II's Eq. 2 compares.
  float survival = 1.0f;
  static constexpr uint32_t kStored = 1;      // a photon was stored at this vertex
  static constexpr uint32_t kEscapes = 2;     // the outgoing segment left the scene (hit nothing)
  static constexpr uint32_t kTerminated = 4;  // the path ends here (absorbed, roulette, bounce cap)
};

struct LightPath {
  uint32_t light = 0;
  uint32_t sample = 0;          // sample index within its light (an emission sampler's index)
  glm::vec2 emission_uv{0.0f};  // where in the light's emission domain it started
  uint32_t first_vertex = 0, vertex_count = 0;
  uint32_t first_photon = 0, photon_count = 0;
  // verify_paths' verdict: kKeep, kReemit (the light changed: the whole path is traced afresh), or
  // the segment to re-trace from (segment s leaves vertex s; vertices 0..s are kept).
  uint32_t restart = kKeep;
  static constexpr uint32_t kKeep = ~0u, kReemit = ~0u - 1;
  // kRefill: re-emitted from the given emission sample (emission_uv, emission_dir) instead of the
  // path's own: Paper II's fill step samples the light inside one distribution-map cell.
  static constexpr uint32_t kRefill = ~0u - 2;
  glm::vec2 emission_dir{0.0f};  // surface emitters: the point that chose the direction (cosine)
};

// Whole light paths of one trace, with a snapshot of the world they were traced in, so that
// retrace_invalid can find what moved since. Photons of path p are PhotonBatch::photons
// [paths[p].first_photon, + photon_count).
struct LightPaths {
  std::vector<LightPath> paths;
  std::vector<PathVertex> vertices;
  // Opaque snapshot (the tracer's business): object transforms, light state, settings.
  std::vector<glm::mat4> object_to_world;
  std::vector<glm::vec4> light_state;
  std::vector<uint32_t> paths_per_light;
  uint32_t seed = 0, max_bounces = 0, store = 0, rr_start = 0;
  bool empty() const { return paths.empty(); }
};

struct PhotonBatch {
  std::vector<PhotonRecord> photons;  // in path order
  LightPaths paths;                   // filled when TraceSettings::keep_light_paths
  TraceStats stats;
  // With an emission sampler: the power each emission left its light with (mean over RGB, W), in
  // emission order (a spot light's falloff included). Empty for other traces.
  std::vector<float> emitted_power;
};

// The tracer of one World. It reads the World's current frame (lights, transforms) at each call, so
// the runner's world.update(state) is all it needs between frames. Calls are not re-entrant.
class PhotonTracer {
 public:
  virtual ~PhotonTracer() = default;
  // Lights in emission order: Scene lights, then each object with an emissive material.
  virtual uint32_t light_count() const = 0;
  virtual EmitterInfo light(uint32_t light) const = 0;
  // Power of light `i` this frame, W (RGB).
  virtual glm::vec3 light_power(uint32_t light) const = 0;
  // Emission density of light `i` (null: uniform). The tracer keeps its own copy.
  virtual void set_emission_density(uint32_t light, const EmissionDensity* density) = 0;
  // Traces `settings.paths` fresh light paths (or until photon_target) in the current frame.
  virtual TraceStats trace(const TraceSettings& settings, PhotonBatch& out) = 0;
  // Path verification (Paper II §3.2): tests every segment of the paths in `batch` (from a trace
  // with keep_light_paths) against what moved since they were traced and re-traces each path from
  // its first invalid segment; valid prefixes and their photons are kept. A path whose light
  // changed is re-traced whole; if the settings or the lights' power split changed, everything is
  // traced afresh. Re-traced parts continue the path's own sample sequence, so the result equals
  // a fresh trace with the seed the paths were first traced with.
  virtual TraceStats retrace_invalid(const TraceSettings& settings, PhotonBatch& batch) = 0;
  // Path verification in the two steps Paper II Fig. 8 times apart. verify_paths ("dynamic
  // occlusion") sets LightPath::restart of every path in `batch` by `reuse.rule`; error_based also
  // moves the vertices (and their photons) it keeps within the threshold. retrace_marked ("photon
  // trace") re-traces each marked path from its restart segment and takes the new world snapshot.
  // retrace_invalid is the two with ReuseRule::exact. If the settings or the lights' power split
  // changed, verify_paths traces everything afresh and marks nothing.
  virtual TraceStats verify_paths(const TraceSettings& settings, const ReuseSettings& reuse,
                                  PhotonBatch& batch) = 0;
  // The origin updates of §3.1 alone (reuse.update_origins), before verify_paths, so that they
  // are timed apart and the distribution map sees the moved origins (Fig. 8: update-origins with
  // compute-dm). Sets LightPath::restart to kReemit where an origin cannot be kept (kKeep
  // elsewhere) and moves emission_uv / emission_dir with the origins; verify_paths then uses these
  // updates instead of making its own.
  virtual TraceStats update_origins(const TraceSettings& settings, const ReuseSettings& reuse,
                                    PhotonBatch& batch) = 0;
  virtual TraceStats retrace_marked(const TraceSettings& settings, PhotonBatch& batch) = 0;
  // Aimed emission, a density policy for techniques that keep only photons whose first interaction
  // is specular (caustic and caustic-indirect kinds): per light, in emission order, a density that
  // is 1 on every texel of the emission domain whose rays may reach a non-diffuse surface of the
  // current frame and 0 elsewhere, so set_emission_density (or a sampler's own placement) drops
  // only paths that cannot start with a specular hit and keeps the others' expected power. Nothing
  // (uniform emission) for area emitters and lights that reach no specular surface. Decided
  // conservatively from bounding spheres, never by sampling (src/trace/aimed_emission.h). Declared
  // last, so the older methods keep their places in the vtable.
  virtual std::vector<std::optional<EmissionDensity>> aimed_emission_densities() const = 0;
};

// Aimed emission applied: every light's density set to its aimed_emission_densities() entry, and
// reset to uniform where the entry is empty (a light that reaches no specular surface this frame).
inline void aim_emission(PhotonTracer& tracer) {
  const std::vector<std::optional<EmissionDensity>> densities = tracer.aimed_emission_densities();
  for (uint32_t light = 0; light < densities.size(); ++light)
    tracer.set_emission_density(light, densities[light] ? &*densities[light] : nullptr);
}

}  // namespace pb::trace
