// The harness's many-light next-event estimator (`direct_light: nee`, photonbench/context.h): the
// camera side of Papers III and IV of seed 002. For every G-buffer sample it chooses a light with
// one of the samplers of trace/light_bvh.h (uniform, power, or the light BVH's walk weighed by
// `importance`), a uniform point on it (Paper III: p = 1/A), and traces a shadow ray; with `mis`,
// one BSDF-sampled ray besides, both weighed by the power heuristic (Veach 1997 §9.2.4), as Paper
// III's ray generation shader does. Rays go to Embree: the CPU stands in for DXR's ray generation,
// so every sampler shares one substrate and the walk is timed beside the rays it feeds.
//
// Lights: every emissive triangle (Phi = pi A L, zero flux culled: scene/emissive_triangles.h), the
// scene's quad and disc lights (area lights, uniform on their surface), point and spot lights
// (delta lights: no BSDF sample can reach them). Directional lights have no position and stay
// outside the tree: each G-buffer sample shadow-tests every one of them.
//
// The three phases are the passes "nee/sample", "nee/trace" and "nee/shade"; the light set and its
// sampler are "light-bvh/build" (or "light-bvh/refit").
#pragma once

#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

#include "photonbench/context.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"
#include "trace/light_bvh.h"

namespace pb::trace {

// One light of the estimator's set.
struct NeeLight {
  enum class Shape : uint8_t { triangle, quad, disc, point, spot };
  Shape shape = Shape::point;
  glm::vec3 origin{0.0f};  // triangle: vertex 0; quad: a corner; disc: the centre; point, spot
  glm::vec3 edge_u{0.0f}, edge_v{0.0f};  // triangle: p1 - p0, p2 - p0; quad: edges; disc: radii
  glm::vec3 normal{0.0f};                // area: the emitting side; spot: its axis
  glm::vec3 radiance{0.0f};              // area: L, W/(m^2 sr); point, spot: intensity, W/sr
  float area = 0;                        // m^2 (area lights)
  float cos_outer = -1, cos_inner = -1;  // spot
  bool area_light() const {
    return shape == Shape::triangle || shape == Shape::quad || shape == Shape::disc;
  }
};

// A uniform point on area light `l` for u in [0,1)^2 (Paper III: density 1/area).
glm::vec3 area_point(const NeeLight& l, glm::vec2 u);

// The lights of one frame, with their sampler primitives and where a BSDF ray that hits an emitter
// finds its light.
struct NeeLightSet {
  std::vector<NeeLight> lights;
  std::vector<LightPrimitive> primitives;  // one per light, for the samplers
  std::vector<uint32_t> directional;       // scene light indices of the directional lights
  std::vector<uint32_t> group;  // per light: its emissive object (or scene light), for two levels
  uint32_t culled = 0;          // emissive triangles of zero flux left out
  // Emitter hit -> light: (object << 32 | triangle) for emissive triangles; the Embree light
  // object of a quad or disc.
  std::unordered_map<uint64_t, uint32_t> by_hit;
  uint32_t find(uint32_t object, uint32_t primitive, const EmbreeScene& world) const;
};
NeeLightSet gather_nee_lights(const scene::Scene& scene, const scene::FrameState& state);

// The G-buffer as the estimator reads it (photonbench/context.h's GBuffer, read back: RGBA per
// pixel).
struct GBufferSamples {
  const std::vector<float>* position = nullptr;
  const std::vector<float>* normal = nullptr;
  uint32_t width = 0, height = 0;
  glm::vec3 camera{0.0f};
  glm::vec3 point(uint32_t pixel) const {
    const float* v = position->data() + size_t(pixel) * 4;
    return {v[0], v[1], v[2]};
  }
  glm::vec3 unit_normal(uint32_t pixel) const {
    const float* v = normal->data() + size_t(pixel) * 4;
    return glm::normalize(glm::vec3(v[0], v[1], v[2]));
  }
  uint32_t material(uint32_t pixel) const { return uint32_t((*normal)[size_t(pixel) * 4 + 3]); }
};

// Per-frame work of the estimator, for counters.
struct NeeStats {
  uint64_t samples = 0;        // light samples taken (G-buffer samples x light_samples)
  uint64_t nodes_visited = 0;  // light-BVH nodes whose importance the walks evaluated
  uint64_t shadow_rays = 0;    // to chosen lights and directional ones
  uint64_t occluded = 0;       // of those, blocked
  uint64_t bsdf_rays = 0;
};

class NextEventEstimator {
 public:
  NextEventEstimator(const DirectLightSettings& settings, const LightBvhOptions& bvh);

  // The frame's lights and their sampler ("light-bvh/build").
  void build(const scene::Scene& scene, const scene::FrameState& state);
  // The lights moved ("light-bvh/refit" where refit_possible()): with `update: refit` and as many
  // lights as before, the trees are refit (Paper IV; the top level rebuilt); else rebuilt.
  void update(const scene::Scene& scene, const scene::FrameState& state);
  bool refit_possible() const;
  // Light and BSDF choices for every sample; `seed` makes the frame's random streams.
  void sample(const scene::Scene& scene, const GBufferSamples& gbuffer, uint64_t seed);
  void trace(const EmbreeScene& world);
  // Outgoing direct radiance per pixel into `rgba` (width x height x 4; alpha 1 on surfaces).
  void shade(const scene::Scene& scene, const EmbreeScene& world, std::vector<float>& rgba);

  const NeeLightSet& lights() const { return set_; }
  const LightSampler* sampler() const { return sampler_.get(); }
  const LightBvh* bvh() const { return bvh_; }
  const TwoLevelLightBvh* two_level() const { return two_level_; }
  // Nodes and bytes of the light trees (0 for the flat samplers).
  size_t tree_nodes() const;
  size_t tree_bytes() const;
  const NeeStats& stats() const { return stats_; }

 private:
  struct LightSample {
    uint32_t pixel = 0;
    uint32_t light = ~0u;  // ~0u: none chosen
    float pick_pdf = 0;
    glm::vec3 point{0.0f};  // on the light (delta lights: the light)
    glm::vec3 bsdf_dir{0.0f};
    float bsdf_pdf = 0;           // 0: no BSDF ray
    glm::vec3 bsdf_weight{0.0f};  // f |cos| / pdf
  };
  DirectLightSettings settings_;
  LightBvhOptions bvh_options_;
  NeeLightSet set_;
  std::unique_ptr<LightSampler> sampler_;
  const LightBvh* bvh_ = nullptr;          // sampler_ when it is the light BVH (one level)
  TwoLevelLightBvh* two_level_ = nullptr;  // sampler_ when it is the two-level BVH
  LightBvh* one_level_ = nullptr;
  const GBufferSamples* gbuffer_ = nullptr;
  std::vector<uint32_t> pixels_;  // the surface pixels
  std::vector<LightSample> samples_;
  std::vector<Ray> shadow_rays_, bsdf_rays_, directional_rays_;
  std::vector<uint8_t> blocked_, directional_blocked_, bsdf_found_;
  std::vector<Hit> bsdf_hits_;
  NeeStats stats_;
};

}  // namespace pb::trace
