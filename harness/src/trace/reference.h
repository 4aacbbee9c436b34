// The reference renderer: converged images of one frame, split by path class, for scoring
// techniques on exactly what they estimate.
//
// Two unbiased/consistent estimators share the work, each on its own part of path space, so the sum
// converges to the full solution with nothing counted twice:
//   * path tracing with next-event estimation and MIS (power heuristic, Veach 1997 ch. 9) for every
//   path
//     whose vertex next to the light is diffuse, or that has no diffuse vertex at all;
//   * stochastic progressive photon mapping (Hachisuka & Jensen 2009) for every path with a diffuse
//     vertex whose vertex next to the light is specular (L S ... ): the caustic-type paths that a
//     path tracer cannot sample when the light is a point and the S a perfect mirror or glass.
//     Visible points are the first diffuse camera vertex (C S* D), photons are those whose first
//     interaction was specular (PhotonKind caustic and caustic_indirect).
//
// Path classes (light path expressions read from the camera, S any non-diffuse interaction
// including rough GGX, D diffuse or emissive, L an emitter). They partition all paths, so
//   direct + indirect + caustics + indirect_caustics + specular = combined:
//   direct            C L | C D L                       emitters seen directly and direct light
//   indirect          C D (D|S)* D (D|S)* L             first hit diffuse, at least one more
//   diffuse
//                                                       vertex (indirect diffuse; includes caustics
//                                                       seen via diffuse interreflection, C D D S+
//                                                       L)
//   caustics          C D S+ L                          caustics seen directly
//   indirect_caustics C S+ D S+ L                       caustics seen through specular surfaces
//   specular          C S+ L | C S+ D L | C S+ D (D|S)* D (D|S)* L
//                                                       the rest of what is first seen through a
//                                                       specular surface (reflections and
//                                                       refractions of emitters, of direct and of
//                                                       indirect light)
// (Caustics in the wide sense, `C S* D S+ L`, are caustics + indirect_caustics.)
//
// Camera: the pinhole of scene::Camera (view = lookAtRH(position, target, up), vertical fov_y),
// pixel (x, y) with y = 0 the top row covers [x, x+1) x [y, y+1) and its value is the box-filtered
// mean over the pixel (samples jittered uniformly inside it), so pixel centres are at x + 0.5, y +
// 0.5.
//
// Sampling: independent PCG32 streams per pixel and iteration, so the error estimate (sample
// variance of the path-traced part) is valid; the photons of SPPM come from the photon tracer.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "io/image.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"

namespace pb::trace {

enum class PathClass : uint8_t {
  direct,
  indirect,
  caustics,
  indirect_caustics,
  specular,
  combined
};
inline constexpr int kPathClassCount = 6;
inline constexpr uint32_t kAllPathClasses = (1u << kPathClassCount) - 1u;
inline constexpr uint32_t class_bit(PathClass c) { return 1u << uint32_t(c); }

std::string_view path_class_name(PathClass c);        // "direct", "indirect_caustics", ...
std::string_view path_class_expression(PathClass c);  // "C D S+ L", ...
std::optional<PathClass> parse_path_class(std::string_view name);
std::vector<PathClass> all_path_classes();

// Bumped whenever a change alters what the renderer converges to or how it samples (part of the
// cache key, so old references are not reused by mistake).
inline constexpr int kReferenceRendererVersion = 1;

struct ReferenceOptions {
  uint32_t samples = 256;          // path-traced samples per pixel (= iterations)
  uint32_t sppm_iterations = 0;    // 0: as many as `samples`
  uint32_t sppm_photons = 200000;  // photon paths per SPPM iteration
  float sppm_alpha = 2.f / 3.f;    // radius reduction (Hachisuka & Jensen 2009, eq. 9)
  float sppm_radius = 0;           // initial radius, m; 0: 3 pixel footprints at the visible point
  float rel_error = 0;      // > 0: stop once the estimated relative RMS error of the path-traced
                            // part (all requested classes) is below this (checked from 16 spp)
  double max_seconds = 0;   // > 0: stop after this long (the image is still unbiased)
  uint32_t max_depth = 64;  // camera path vertices (Russian roulette ends most paths first)
  uint32_t seed = 1;
  int threads = 0;  // 0: all cores
};

struct ReferenceProgress {
  uint32_t iteration = 0, total = 0;
  double rel_error = 0;  // estimate for the path-traced part, 0 until known
  double seconds = 0;
  uint64_t rays = 0;
};
using ProgressFn = std::function<void(const ReferenceProgress&)>;

struct ReferenceResult {
  std::array<io::Image, kPathClassCount> images;  // the requested classes; others are empty
  uint32_t samples = 0, sppm_iterations = 0;
  uint64_t rays = 0, photon_paths = 0;
  double seconds = 0, rel_error = 0;
  uint32_t seed = 0;
  double mrays_per_second() const { return seconds > 0 ? rays / seconds * 1e-6 : 0.0; }
};

// Renders the classes in `class_mask` (class_bit(...) | ...) of the world's current frame.
ReferenceResult render_reference_classes(const EmbreeScene& world, int width, int height,
                                         uint32_t class_mask, const ReferenceOptions& options,
                                         const ProgressFn& progress = {});

// One class of one frame (builds the Embree scene for `state`).
io::Image render_reference(const scene::Scene& scene, const scene::FrameState& state,
                           PathClass path_class, int width, int height,
                           const ReferenceOptions& options, const ProgressFn& progress = {});

// Camera ray through pixel position (px, py) in pixel units (px in [0, width), y down).
struct CameraRay {
  glm::vec3 origin, direction;
};
CameraRay camera_ray(const scene::Camera& camera, int width, int height, float px, float py);

// ---- the content-addressed cache ---------------------------------------------------------------

// <dir>/<key>.exr plus <dir>/<key>.json (samples, seed, time, scene, frame, class, ...). The key
// hashes the scene file's bytes and the resolved scene (meshes, materials), the frame state (time,
// camera, lights, transforms), the resolution, the class, max_depth and kReferenceRendererVersion.
// Writes are atomic (temporary file, then rename), so an interrupted render leaves no entry behind.
class ReferenceCache {
 public:
  explicit ReferenceCache(std::filesystem::path dir);
  const std::filesystem::path& dir() const { return dir_; }

  std::string key(const scene::Scene& scene, const scene::FrameState& state, PathClass path_class,
                  int width, int height, const ReferenceOptions& options) const;
  // An entry exists with at least options.samples samples, or one that met options.rel_error.
  bool has(const scene::Scene& scene, const scene::FrameState& state, PathClass path_class,
           int width, int height, const ReferenceOptions& options) const;
  std::optional<io::Image> get(const scene::Scene& scene, const scene::FrameState& state,
                               PathClass path_class, int width, int height,
                               const ReferenceOptions& options) const;
  io::Image get_or_render(const scene::Scene& scene, const scene::FrameState& state,
                          PathClass path_class, int width, int height,
                          const ReferenceOptions& options, const ProgressFn& progress = {});
  // Renders every class of `class_mask` missing from the cache in one pass (they share the paths)
  // and stores each; returns how many classes were rendered.
  int render_missing(const scene::Scene& scene, const scene::FrameState& state, uint32_t class_mask,
                     int width, int height, const ReferenceOptions& options,
                     const ProgressFn& progress = {});

 private:
  std::filesystem::path dir_;
  std::string scene_file_digest(const scene::Scene& scene) const;
  mutable std::vector<std::pair<std::string, std::string>> file_digests_;  // path -> digest
};

// What the `reference` command and the runner call: every frame in [first, last] of `scene`, the
// classes of `class_mask`, through the cache. `log` receives one line per frame and progress lines.
struct ReferenceJobReport {
  int rendered = 0, cached = 0;
  double seconds = 0;
};
ReferenceJobReport render_references(const scene::Scene& scene, uint32_t first_frame,
                                     uint32_t last_frame, uint32_t class_mask, int width,
                                     int height, const ReferenceOptions& options,
                                     ReferenceCache& cache,
                                     const std::function<void(const std::string&)>& log);

}  // namespace pb::trace
