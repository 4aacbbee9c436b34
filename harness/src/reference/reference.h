// The reference renderer: converged images of one frame, split by path class, for scoring
// techniques on exactly what they estimate.
//
// Two estimators share the work, each on its own part of path space, so the sum converges to the
// full solution with nothing counted twice (the design and its measurements: README.md here):
//   * an unbiased estimator for every path whose vertex next to the light is diffuse, or that has
//     no diffuse vertex at all: path tracing with next-event estimation and MIS (power heuristic,
//     Veach 1997 ch. 9; path_tracing_pass.h), or bidirectional path tracing with MIS (Veach 1997
//     ch. 10, bdpt.h), chosen per render by a pilot (Estimator, estimator_pilot.h);
//   * progressive photon mapping in its probabilistic form (Knaus & Zwicker 2011: every iteration
//     an independent photon-map estimate, the radius shrinking from one iteration to the next;
//     photon_mapping_pass.h) for
//     every path with a diffuse vertex whose vertex next to the light is specular (L S ... ): the
//     caustic-type paths that a path tracer cannot sample when the light is a point and the S a
//     perfect mirror or glass. Visible points are the first diffuse camera vertex (C S* D), photons
//     are those whose first interaction was specular (PhotonKind caustic and caustic_indirect).
// Each iteration adds one camera sample per pixel and one photon pass; the iteration images are
// independent, so per pixel and channel the sample variance over iterations / n is the variance of
// the mean for both parts (photon mapping's blur bias, which shrinks with the radius, is not in
// it).
//
// Error estimate (the rel_error stop rule): for each requested class, the relative RMS error of the
// mean's luminance over the pixels, sqrt(mean(var(L) / (L^2 + f^2))), with the floor f = 1% of the
// class's mean luminance so that dark pixels do not dominate; over several classes, the RMS of the
// classes' errors (a class that is black everywhere is left out). It is checked after every even
// iteration from min_samples on (accumulator.h).
//
// Path classes: path_class.h.
//
// Camera: the pinhole of scene::Camera (view = lookAtRH(position, target, up), vertical fov_y),
// pixel (x, y) with y = 0 the top row covers [x, x+1) x [y, y+1) and its value is the box-filtered
// mean over the pixel (samples jittered uniformly inside it), so pixel centres are at x + 0.5, y +
// 0.5.
//
// Sampling: independent PCG32 streams per pixel and iteration, so the iteration images are
// independent and their spread estimates the variance; the photons come from the photon tracer with
// a fresh scramble every iteration.
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
#include "reference/estimators.h"
#include "reference/options.h"
#include "reference/path_class.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"

namespace pb::trace {

// Bumped whenever a change alters what the renderer converges to or how it samples (part of the
// cache key, so old references are not reused by mistake). 2: mean, variance and halves; photon
// mapping as independent per-iteration estimates; max_bounces counts full-path scattering vertices.
// 3: shadow rays aimed from their offset origin (area lights near surfaces were biased low).
// 4: photon mapping's aimed emission and new default photon counts and radius.
// 5: the automatic choice pilots renders of a fixed number of samples too (bidirectional before).
// 6: path tracing's light choice (LightSelection: by power, or through the light BVH), in the
// sidecar.
inline constexpr int kReferenceRendererVersion = 6;

// Which stop rule ended a render (the first one reached wins).
enum class StopRule : uint8_t { rel_error, max_seconds, samples };
std::string_view stop_rule_name(StopRule rule);  // "rel_error", "max_seconds", "samples"
std::optional<StopRule> parse_stop_rule(std::string_view name);

// The reference depth that matches a photon technique's `max_bounces: B` parameter
// (TraceSettings::max_bounces in photonbench/photons.h): its light paths make at most B surface
// interactions, photons are stored at diffuse hits among them, and the technique gathers each
// photon at the camera's first hit, which is that photon's own surface interaction. So a full path
// the technique estimates has at most B scattering vertices (C D...D L with B vertices; the direct
// light C D L is 1), which is the reference's max_bounces = B.
inline uint32_t bounces_matching_photon_technique(uint32_t technique_max_bounces) {
  return technique_max_bounces;
}

struct ReferenceProgress {
  uint32_t iteration = 0;    // iterations done
  uint32_t max_samples = 0;  // the samples rule (0: off)
  double rel_error = 0;      // estimate so far, 0 until known
  double target = 0;         // the rel_error rule (0: off)
  double seconds = 0;
  double max_seconds = 0;  // the max_seconds rule (0: off)
  uint64_t rays = 0;
};
using ProgressFn = std::function<void(const ReferenceProgress&)>;

// One reference of one class: the per-pixel per-channel mean over n iterations, the variance of
// that mean (sample variance of the iteration images / n, per pixel and channel), and two
// independent half-estimates, the means of the even (0, 2, ...) and of the odd iterations (each
// ceil(n/2) and floor(n/2) iterations; renders stopped by the error or time rule end on an even
// count, so the halves are equal and mean = (half[0] + half[1]) / 2).
struct ReferenceImage {
  io::Image mean, variance;
  std::array<io::Image, 2> half;
  uint32_t samples = 0;  // iterations
  uint32_t seed = 0;
  double seconds = 0;
  double rel_error = 0;  // the error estimate reached (over all classes rendered together)
  StopRule stopped_by = StopRule::samples;
  uint32_t max_bounces = 0;             // as requested (0: untruncated)
  Estimator estimator = Estimator::pt;  // the one that rendered it (never automatic)
  bool empty() const { return mean.pixels.empty(); }
};

struct ReferenceResult {
  std::array<ReferenceImage, kPathClassCount> classes;  // the requested classes; others are empty
  uint32_t samples = 0;
  uint64_t rays = 0, photon_paths = 0;
  double seconds = 0, rel_error = 0;
  StopRule stopped_by = StopRule::samples;
  uint32_t seed = 0;
  Estimator estimator = Estimator::pt;  // the one that rendered it (never automatic)
  // How its next-event estimation chose lights (never automatic; bidirectional: power).
  LightSelection light_selection = LightSelection::power;
  PilotReport pilot;
  const io::Image& image(PathClass c) const { return classes[int(c)].mean; }
  double mrays_per_second() const { return seconds > 0 ? rays / seconds * 1e-6 : 0.0; }
};

// Renders the classes in `class_mask` (class_bit(...) | ...) of the world's current frame.
ReferenceResult render_reference_classes(const EmbreeScene& world, int width, int height,
                                         uint32_t class_mask, const ReferenceOptions& options,
                                         const ProgressFn& progress = {});

// One class of one frame (builds the Embree scene for `state`).
ReferenceImage render_reference(const scene::Scene& scene, const scene::FrameState& state,
                                PathClass path_class, int width, int height,
                                const ReferenceOptions& options, const ProgressFn& progress = {});

// Camera ray through pixel position (px, py) in pixel units (px in [0, width), y down).
struct CameraRay {
  glm::vec3 origin, direction;
};
CameraRay camera_ray(const scene::Camera& camera, int width, int height, float px, float py);

// ---- the content-addressed cache ---------------------------------------------------------------

// <dir>/<key>.exr (the mean), <key>.variance.exr, <key>.half0.exr, <key>.half1.exr, plus
// <dir>/<key>.json (samples, seed, seconds, error reached, the stop rule that ended it, scene,
// frame, class, ...). The key hashes the scene file's bytes and the resolved scene (meshes,
// materials), the frame state (time, camera, lights, transforms), the resolution, the class,
// max_bounces and kReferenceRendererVersion. An entry serves a request when it meets any of the
// request's stop rules (its error at or below rel_error, at least `samples` iterations, or at least
// max_seconds of rendering). Writes are atomic (temporary file, then rename; the sidecar last), so
// an interrupted render leaves no entry behind.
class ReferenceCache {
 public:
  explicit ReferenceCache(std::filesystem::path dir);
  const std::filesystem::path& dir() const { return dir_; }

  std::string key(const scene::Scene& scene, const scene::FrameState& state, PathClass path_class,
                  int width, int height, const ReferenceOptions& options) const;
  bool has(const scene::Scene& scene, const scene::FrameState& state, PathClass path_class,
           int width, int height, const ReferenceOptions& options) const;
  // The whole entry: mean, variance, halves and sidecar.
  std::optional<ReferenceImage> get_entry(const scene::Scene& scene, const scene::FrameState& state,
                                          PathClass path_class, int width, int height,
                                          const ReferenceOptions& options) const;
  ReferenceImage get_or_render_entry(const scene::Scene& scene, const scene::FrameState& state,
                                     PathClass path_class, int width, int height,
                                     const ReferenceOptions& options,
                                     const ProgressFn& progress = {});
  // The mean alone.
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

// One progress line: iterations, error against its target, time against its limit, Mrays/s.
std::string describe_progress(const ReferenceProgress& p);

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
