// What a technique sees of the harness: the GPU, the frame being rendered, named pass scopes,
// counters, warnings, the shared passes (G-buffer, shadow-mapped direct light, final shading, the
// scene's triangles and a raster pass that draws them into the technique's own targets), the photon
// and camera-path tracers, and the images it hands back to be scored.
// It never reaches into the harness's internals; everything it needs is here.
#pragma once

#include <glm/glm.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "photonbench/camera_paths.h"
#include "photonbench/gpu.h"
#include "photonbench/photons.h"
#include "photonbench/scene_triangles.h"

namespace pb {

// Pass scopes: `auto scope = ctx.pass("splat");` times everything recorded and done until the scope
// ends, on the GPU (a timestamp pair bracketed by full barriers) and on the CPU (a monotonic
// clock). Scopes nest; a nested pass is reported as "outer/inner".
class PassRecorder {
 public:
  virtual ~PassRecorder() = default;
  virtual int begin_pass(std::string_view name) = 0;
  virtual void end_pass(int pass) = 0;
};

class PassScope {
 public:
  PassScope(PassRecorder* recorder, int pass) : recorder_(recorder), pass_(pass) {}
  PassScope(PassScope&& other) noexcept : recorder_(other.recorder_), pass_(other.pass_) {
    other.recorder_ = nullptr;
  }
  PassScope(const PassScope&) = delete;
  PassScope& operator=(const PassScope&) = delete;
  ~PassScope() { end(); }
  void end() {
    if (recorder_) recorder_->end_pass(pass_);
    recorder_ = nullptr;
  }

 private:
  PassRecorder* recorder_;
  int pass_;
};

// A per-frame counter, declared once where it is counted:
//   constexpr pb::Counter kPhotonsRead{"photons_read", pb::CounterKind::work, "photons"};
//   ctx.count(kPhotonsRead, n);
// The kind says how frames combine (work adds up over frames; a size is a level each frame has; a
// ratio is a fraction of the frame's work, averaged, never added);
// the unit names what is counted. Both are recorded with the cell (cell.json "counters"); one name
// declared with two kinds or units in a cell fails it.
enum class CounterKind {
  work,   // done this frame: photons read, jobs run, overflows
  size,   // held this frame: bytes of a structure, nodes of a hierarchy, photons stored
  ratio,  // a fraction of this frame's work: idle lanes
};
struct Counter {
  std::string_view name;  // snake_case, unique within a technique
  CounterKind kind;
  std::string_view unit;  // "photons", "bytes", "nodes", ...
};

struct CameraView {
  glm::mat4 view, projection, view_projection, inverse_view_projection;
  glm::vec3 position;
  float fov_y;  // radians, vertical
};

struct FrameInfo {
  uint32_t index;  // frame number in the animation (warm-up frames come first)
  float time;      // seconds, = index / fps
  bool warmup;     // warm-up frames are rendered but never counted
  uint32_t width, height;
  CameraView camera;
};

// The G-buffer: RGBA32F images, one texel per pixel.
//   position: world xyz, w = distance to the camera (0: background)
//   normal:   world shading normal facing the camera, w = material index
//   albedo:   diffuse albedo rgb, w = material type (PB_MATERIAL_* of photonbench/scene_layout.h)
struct GBuffer {
  const gpu::Image* position;
  const gpu::Image* normal;
  const gpu::Image* albedo;
  const gpu::Image* depth;
};

// The shared passes' shadow settings until a technique's setup calls configure_shadows: the one
// source of the shadow parameter rows' defaults (photonbench/toolkit/technique.h).
inline constexpr uint32_t kDefaultShadowMapSize = 512;       // texels per tile side
inline constexpr double kDefaultShadowRelativeBias = 0.01;   // fraction of the light-space depth
inline constexpr double kDefaultShadowNormalOffsetM = 0.01;  // metres along the normal

// How the shared direct-light pass lights each G-buffer sample (the toolkit's direct-light rows,
// photonbench/toolkit/technique.h). shadow_maps: every light and emissive triangle, each shadowed
// by its cube of shadow-map tiles (the GPU pass). nee: the many-light next-event estimator of
// Papers III and IV of seed 002 (harness/src/trace/nee.h): per sample, one light chosen by
// `sampler` (`importance` weighs the light BVH's walk), a shadow ray, and with `mis` one BSDF
// sample weighed by the power heuristic; traced on the CPU (Embree stands in for DXR's ray
// generation) and uploaded into the same direct image.
enum class DirectLightMethod : uint32_t { shadow_maps, nee };
enum class NeeSampler : uint32_t { uniform, power, bvh };
enum class NeeImportance : uint32_t { d, df, dfb, dfbo };
enum class NeeLevels : uint32_t { one, two };
enum class NeeUpdate : uint32_t { rebuild, refit };
struct DirectLightSettings {
  DirectLightMethod method = DirectLightMethod::shadow_maps;
  NeeSampler sampler = NeeSampler::bvh;
  NeeImportance importance = NeeImportance::dfbo;
  uint32_t light_samples = 1;  // light samples per G-buffer sample (and as many BSDF samples)
  bool mis = true;
  NeeLevels levels = NeeLevels::one;      // bvh: one tree, or a tree per emitter under a top tree
  NeeUpdate update = NeeUpdate::rebuild;  // bvh: when lights move, rebuild or refit the trees
};

// Passes every technique reuses. Each records its own named pass scope.
class SharedPasses {
 public:
  virtual ~SharedPasses() = default;
  virtual void gbuffer() = 0;  // pass "gbuffer"
  // pass "direct-light" (shadow maps nested)
  virtual void direct_light() = 0;
  // pass "shade": final = emitted + direct + indirect
  virtual void shade(const gpu::Image* indirect_radiance) = 0;
  // Shadow-map resolution (texels per tile side) and biases; call in setup to change the defaults.
  virtual void configure_shadows(uint32_t map_size, float relative_bias, float normal_offset_m) = 0;
  virtual GBuffer gbuffer_images() const = 0;
  virtual const gpu::Image& direct_image() const = 0;
  // Bindable scene data for a technique's own shaders (layouts in photonbench/scene_layout.h).
  virtual const gpu::Buffer& frame_buffer() const = 0;     // GpuFrame
  virtual const gpu::Buffer& material_buffer() const = 0;  // GpuMaterial[]
  virtual const gpu::Buffer& light_buffer() const = 0;     // GpuLight[]
  // The scene's triangles in world space (photonbench/scene_triangles.h); built on first call.
  virtual SceneTriangles scene_triangles() = 0;
  // Pass "draw-scene": rasterises the scene's triangles into the technique's `target`, seen with
  // `view_projection` (a light's, an unwrap's; Vulkan clip space, y down) or the frame's camera.
  virtual void draw_scene(const SceneTarget& target,
                          std::optional<glm::mat4> view_projection = std::nullopt) = 0;
  // How direct_light() lights (DirectLightSettings); call in setup. Declared last so that the
  // slots of the calls above stay where modules built before it expect them.
  virtual void configure_direct_light(const DirectLightSettings& settings) = 0;
};

class Context {
 public:
  virtual ~Context() = default;
  virtual gpu::Device& gpu() = 0;
  // The frame's command buffer, recording. The harness submits it after render() and waits for it.
  virtual vk::CommandBuffer cmd() = 0;
  // Submits what is recorded so far, with every GPU write made visible to the host, and waits; then
  // continues recording in a fresh buffer: for a technique that reads GPU results (counters in a
  // host-visible buffer) on the CPU within a frame.
  virtual void flush() = 0;
  virtual PassScope pass(std::string_view name) = 0;
  // Counters are per frame (see Counter). Warnings are recorded on the cell with the frame.
  virtual void count(const Counter& counter, double value) = 0;
  virtual void warn(std::string_view message) = 0;
  virtual const FrameInfo& frame() const = 0;
  virtual SharedPasses& shared() = 0;
  // The photon tracer (Embree, CPU, multi-threaded) over this frame's scene. Built on first use,
  // then kept in step with the animation as part of the "scene-update" pass.
  virtual trace::PhotonTracer& photon_tracer() = 0;
  // The image the harness reads back and scores: RGBA32F, linear radiance. shade() writes it.
  virtual const gpu::Image& output() = 0;
  // One path per pixel of this frame's camera, through specular vertices to the first diffuse one
  // (photonbench/camera_paths.h), traced over the photon tracer's Embree scene; fills `out`,
  // reusing its storage. Call it from render(): the paths follow the frame's camera.
  virtual void camera_paths(const trace::CameraPathSettings& settings,
                            trace::CameraPathBatch& out) = 0;
  // The technique's estimate of one path class alone ("direct", "indirect", "caustics",
  // "indirect_caustics", "specular", or its light path expression), scored against that class's
  // reference beside the combined output: an RGBA32F storage image of the frame's size, made and
  // cleared to 0 on the first call for the class and kept for the cell. The harness reads it back
  // at each metric frame, outside the timed region, and scores its rgb as it is (metrics.csv rows
  // with path_class = the class); for the technique's own class it replaces the estimate handed to
  // shade(). The combined output stays what shade() writes. "combined" or an unknown name throws
  // pb::Error naming the classes.
  virtual const gpu::Image& class_output(std::string_view path_class) = 0;
};

// The photon techniques' first two passes: traces `settings` with the frame's tracer in pass
// "photon-trace" (counter "photons_stored"), then copies the records into `photons`, a host-visible
// storage buffer made or grown as needed (named `buffer_name`), in pass "photon-upload". Returns
// the number of photons stored; `batch` keeps them for the technique's own CPU-side use.
uint32_t trace_and_upload_photons(Context& ctx, const trace::TraceSettings& settings,
                                  trace::PhotonBatch& batch, gpu::Buffer& photons,
                                  std::string_view buffer_name);

// The same two passes for camera paths: ctx.camera_paths(settings, batch) in pass "camera-paths",
// then the records into `paths` (a host-visible storage buffer made or grown as needed, named
// `buffer_name`) in pass "camera-path-upload". Returns the number of paths (one per pixel).
uint32_t trace_and_upload_camera_paths(Context& ctx, const trace::CameraPathSettings& settings,
                                       trace::CameraPathBatch& batch, gpu::Buffer& paths,
                                       std::string_view buffer_name);

}  // namespace pb
