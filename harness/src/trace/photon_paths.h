// What the photon tracer's parts share (photon_tracer.cpp: emission and scattering, with a
// technique's policies; path_verification.cpp: the reuse steps of kept light paths):
// the fixed blocks paths are traced in, emission of a path's vertex 0, the continuation of a path
// to its end, the gather of block outputs into a batch, and the snapshot of the lights a path set
// remembers. Internal to src/trace.
#pragma once

#include <algorithm>
#include <cstdint>
#include <memory>
#include <vector>

#include "photonbench/photons.h"
#include "trace/bsdf.h"
#include "trace/embree_scene.h"
#include "trace/lights.h"
#include "trace/sampling.h"

namespace pb::trace {
namespace detail {

constexpr uint32_t kBlockSize = 256;  // paths per parallel task; fixed, so output order is fixed

inline float max3(const glm::vec3& v) { return std::max(v.x, std::max(v.y, v.z)); }
inline float mean3(const glm::vec3& v) { return (v.x + v.y + v.z) / 3.f; }

struct PathTask {
  uint32_t light, sample;
};

struct Context {
  const EmbreeScene* world = nullptr;
  const LightSet* lights = nullptr;
  const std::vector<std::shared_ptr<const Distribution2D>>* densities = nullptr;
  uint32_t seed = 0, max_bounces = 0, store = 0, rr_start = 0;
  const std::vector<uint32_t>* emission_count =
      nullptr;                           // N used for each emitter's power and spacing
  const VertexPolicy* policy = nullptr;  // the technique's (TraceSettings::policy), or null
  const TraceSettings* settings = nullptr;
  // Each light's sobol_group seeds for groups 0..max_bounces (prepare_sample_seeds), so that a
  // vertex's sample hashes no seed: [light * (max_bounces + 1) + group].
  std::vector<SobolGroupSeeds> sample_seeds;
  // Carry ray differentials along the paths and store footprints (TraceSettings::footprints, or a
  // policy that shapes them); off, both stay zero and their bookkeeping is skipped.
  bool differentials = false;
  // The 4D sample of `group` (0: emission, 1 + k: interaction k) of the path `task`.
  glm::vec4 sample(const PathTask& task, uint32_t group) const {
    return sobol_group(task.sample, sample_seeds[task.light * (max_bounces + 1) + group]);
  }
};

// Fills c.sample_seeds for lights 0..lights-1 (each light's paths draw from hash(seed, light)).
inline void prepare_sample_seeds(Context& c, uint32_t lights) {
  c.sample_seeds.resize(size_t(lights) * (c.max_bounces + 1));
  for (uint32_t l = 0; l < lights; ++l)
    for (uint32_t g = 0; g <= c.max_bounces; ++g)
      c.sample_seeds[l * (c.max_bounces + 1) + g] = sobol_group_seeds(g, hash_combine(c.seed, l));
}

// Parts of one path a vertex policy's splits may leave waiting at once.
constexpr int kMaxSplitParts = 8;

inline SurfaceKind surface_kind(scene::MaterialType type, bool diffuse) {
  if (diffuse) return SurfaceKind::diffuse;
  if (type == scene::MaterialType::mirror) return SurfaceKind::mirror;
  if (type == scene::MaterialType::dielectric) return SurfaceKind::dielectric;
  return SurfaceKind::glossy;
}

inline EmitterKind emitter_kind(EmitterType type) {
  switch (type) {
    case EmitterType::point:
      return EmitterKind::point;
    case EmitterType::spot:
      return EmitterKind::spot;
    case EmitterType::directional:
      return EmitterKind::directional;
    case EmitterType::quad:
      return EmitterKind::quad;
    case EmitterType::disc:
      return EmitterKind::disc;
    case EmitterType::mesh:
      return EmitterKind::mesh;
  }
  return EmitterKind::point;
}

inline Footprint footprint_of(const PathVertex& v) {
  return {v.dp_du, v.dp_dv, v.dd_du, v.dd_dv, v.spacing};
}
inline void set_footprint(PathVertex& v, const Footprint& f) {
  v.dp_du = f.dp_du, v.dp_dv = f.dp_dv, v.dd_du = f.dd_du, v.dd_dv = f.dd_dv;
  v.spacing = f.spacing;
}

struct BlockOutput {
  std::vector<LightPath> paths;
  std::vector<PathVertex> vertices;
  std::vector<PhotonRecord> photons;
  uint64_t rays = 0, paths_retraced = 0, segments_retraced = 0;
};

glm::vec3 spawn_origin(const PathVertex& v);

// Transfers a ray differential (dp, dd) along a segment of length t to the plane of the hit with
// normal ng (Igehy 1999 eq. 10).
glm::vec3 transfer_differential(const glm::vec3& dir, const glm::vec3& ng, float t,
                                const glm::vec3& dp, const glm::vec3& dd);

// The direction differential after a delta reflection or refraction `s` at `hit`, for the
// incoming direction `dir` and its differentials (dp on the surface, dd): Igehy eq. 14 for
// reflection, eq. 18-19 for refraction, with the derivative of the interpolated normal.
glm::vec3 scatter_differential(const Triangle& tri, const Hit& hit, const BsdfSample& s,
                               const glm::vec3& dir, const glm::vec3& dp, const glm::vec3& dd);

// Vertex 0 of path `task`: emission. `fixed`: the emission sample (uv, direction point) to use
// instead of the path's own (Paper II's fill step); it is taken as drawn uniformly, so a light with
// an emission density uses that density's pdf at it.
PathVertex emit(const Context& c, const PathTask& task, glm::vec2* uv_out,
                glm::vec2* dir_out = nullptr, const glm::vec4* fixed = nullptr);

// Vertex 0 of a path leaving `light` along `ray` with `photon_density` photons per unit of the
// emission domain: power and spacing from it, footprints through the policy's hook.
PathVertex start_vertex(const Context& c, uint32_t light, const EmissionRay& ray,
                        float photon_density);

// Continues a path from its last vertex, which holds the outgoing state, until it terminates.
// Appends vertices (`verts` holds this path's alone: its size is the interaction count) and the
// photons stored on the way (`photons` may be a block's whole output: they are appended where they
// will stay); returns the number of segments traced.
// `first_hit`: the hit of the first segment, already traced (path verification hands over its
// visibility ray, Paper II §3.3); it is counted here as a traced segment.
uint64_t continue_path(const Context& c, const PathTask& task, uint32_t path_index,
                       std::vector<PathVertex>& verts, std::vector<PhotonRecord>& photons,
                       const Hit* first_hit = nullptr);

// Records one path in a block's output: its photons are out.photons[first_photon, end), written
// there as they were stored; its vertices (a scratch buffer) are copied where paths are kept.
void append_path(BlockOutput& out, const PathTask& task, glm::vec2 uv, glm::vec2 dir, bool keep,
                 const std::vector<PathVertex>& verts, size_t first_photon);

// Concatenates block outputs in block order (the fixed partition makes this thread-count
// independent): sizes first, then every block copies itself into place in parallel. The photons go
// to out.photons from index `photons_before` on (what earlier waves gathered); the vector grows
// only where it is shorter than that (a batch traced into again keeps its last trace's size, and
// its memory need not be zeroed and faulted in again). Returns the photon count after it; the
// caller trims out.photons to its final count.
size_t gather(std::vector<BlockOutput>& blocks, size_t block_count, uint32_t path_offset, bool keep,
              size_t photons_before, PhotonBatch& out, TraceStats& stats);

// Empties a batch's light paths for a new trace; where `keep`, their vectors' memory (faulted in by
// the last trace) is kept for the new paths.
void reset_paths(LightPaths& paths, bool keep);

// Block outputs reused from call to call, so their memory is not faulted in again every frame.
void reset_blocks(std::vector<BlockOutput>& blocks, size_t count);

// The world as a path set remembers it: per emitter, what decides where its photons start.
std::vector<glm::vec4> light_state(const EmbreeScene& world, const LightSet& lights,
                                   const std::vector<uint32_t>& density_version);
constexpr size_t kLightStateSize = 6;

// Throws InputError for settings the tracer cannot trace.
void check_settings(const TraceSettings& s);

// What update_origin did.
enum class OriginUpdate {
  failed,          // the path cannot be kept: re-emit it
  verified,        // segment 0 was traced to the kept primary hit (point, spot)
  moved,           // the origin moved along the kept direction (quad, disc): segment 0 untested
  resample_first,  // as verified, but the primary hit is not diffuse: re-trace from it
};

// The result of update_origin for one path, kept from update_origins to verify_paths.
struct OriginResult {
  OriginUpdate update = OriginUpdate::failed;
  Hit hit;
  bool traced = false;  // a visibility ray was traced
};

// What one EmbreePhotonTracer keeps from call to call: block outputs (their memory reused), and
// what one reuse step hands the next.
struct TracerScratch {
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

}  // namespace detail

}  // namespace pb::trace
