// What every photon technique shares, so that each is written once (harness/toolkit/README.md): the
// parameters and their defaults, the trace settings they make, the shadow set-up, storage-range
// checks, sliced dispatch for llvmpipe's loop limit, the G-buffer's bindings, and the frame of a
// splatting technique (trace, upload, G-buffer, direct light, splat and estimate, shade, counters)
// around a Splatter, so that a technique is one Splatter (whose pb::params table declares its own
// parameters, photonbench/param_table.h):
//
//   using Tiled = pb::toolkit::SplatTechnique<pb::toolkit::TiledSplat>;
//   PB_EXPORT_TECHNIQUE(Tiled, "tiled", "indirect", "...", Tiled::kSchema.rows)
//
// A technique with its own photons (path verification's re-validated paths) calls a Splatter's
// render() with its own PhotonSet instead.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>

#include "photonbench/context.h"
#include "photonbench/param_table.h"
#include "photonbench/plugin.h"
#include "photonbench/toolkit/limits.h"

namespace pb::toolkit {

// ---- The parameters every photon technique shares (defaults chosen for lavapipe; Paper I's values
// in the docs). `photons` counts light paths, not stored photons (Paper I §5 counts stored). Each
// shared parameter is declared once, here; a technique whose paper needs another default or range
// lists its row through with_range (its README gives the reason).

// The shared passes' shadow settings (photonbench/context.h holds their defaults).
struct ShadowParams {
  uint32_t map_size = kDefaultShadowMapSize;
  float bias = float(kDefaultShadowRelativeBias);
  float normal_offset = float(kDefaultShadowNormalOffsetM);
};
// clang-format off
inline constexpr auto kShadowParams = pb::params(
    pb::param("shadow_map_size", &ShadowParams::map_size, kDefaultShadowMapSize, {16, 4096},
              "texels", "shadow-map tile side of the direct light"),
    pb::param("shadow_bias", &ShadowParams::bias, kDefaultShadowRelativeBias, {0, 0.2},
              "fraction", "relative depth bias of the shadow test"),
    pb::param("shadow_normal_offset", &ShadowParams::normal_offset, kDefaultShadowNormalOffsetM,
              {0, 1}, "m", "receiver offset along its normal before the shadow test"));
// clang-format on
static_assert(kShadowParams.member_defaults_match());

// The shared direct-light pass's method and the many-light estimator's parameters
// (photonbench/context.h, DirectLightSettings; Papers III and IV of seed 002). A technique lists
// these rows and calls configure_direct_light(ctx, params) in setup.
// clang-format off
inline constexpr auto kDirectLightParams = pb::params(
    pb::param("direct_light", &DirectLightSettings::method, DirectLightMethod::shadow_maps,
              "shadow_maps|nee",
              "direct light: shadow-mapped lights (GPU), or the many-light next-event estimator "
              "(light BVH walk, shadow and BSDF rays through Embree)"),
    pb::param("nee_sampler", &DirectLightSettings::sampler, NeeSampler::bvh, "uniform|power|bvh",
              "nee: how a light is chosen (Paper III: uniform, by flux, by the light BVH's walk)"),
    pb::param("nee_importance", &DirectLightSettings::importance, NeeImportance::dfbo,
              "d|df|dfb|dfbo",
              "nee, bvh: the walk's importance (distance, flux, the n.l bound, orientation cone)"),
    pb::param("light_samples", &DirectLightSettings::light_samples, 1, {1, 64}, "samples",
              "nee: light samples per G-buffer sample (each with one BSDF sample under mis)"),
    pb::param("mis", &DirectLightSettings::mis, true,
              "nee: one BSDF sample per light sample, power heuristic (Paper III)"),
    pb::param("nee_levels", &DirectLightSettings::levels, NeeLevels::one, "one|two",
              "nee, bvh: one tree over every light, or a tree per emissive object or scene light "
              "under a top tree (Paper IV)"),
    pb::param("nee_update", &DirectLightSettings::update, NeeUpdate::rebuild, "rebuild|refit",
              "nee, bvh: when lights move, rebuild the trees or refit them bottom-up (Paper IV; "
              "the top level is rebuilt)"));
// clang-format on
static_assert(kDirectLightParams.member_defaults_match());

// The direct-light rows' values into the shared passes.
void configure_direct_light(Context& ctx, const Params& params);

// The shared rows' values of one cell (kPhotonParams below).
struct PhotonParams {
  uint32_t paths = 100000;
  float radius = 0.05f;
  uint32_t max_bounces = 4;
  uint32_t shadow_map_size = kDefaultShadowMapSize;
  bool store_first_hit = false;

  static PhotonParams read(const Params& params);
  // Paper I's photons (§4.2: "at each bounce (except the first), a photon is stored"), of the
  // `indirect` path class C D (D|S)* D (D|S)* L: without pure caustics L S+ D (stored photons on
  // diffuse surfaces only; Russian roulette from the second hit on, so a stored photon carries the
  // emitted flux times the first hit's albedo).
  trace::TraceSettings trace_settings() const;
};
// clang-format off
inline constexpr auto kPhotonParams = pb::params(
    pb::param("photons", &PhotonParams::paths, 100000, {1, 5e7}, "paths",
              "light paths traced per frame (Paper I counts stored photons; default kept small for "
              "lavapipe)"),
    pb::param("radius", &PhotonParams::radius, 0.05, {1e-5, 1e4}, "m",
              "photon sphere radius, one for every photon (Paper I Table 2 sets it per scene)"),
    pb::param("max_bounces", &PhotonParams::max_bounces, 4, {2, 31}, "hits",
              "surface interactions per light path; photons are stored at hits 2 to max_bounces, "
              "so full paths of 2 to max_bounces surface vertices are estimated (Paper I §4.2: "
              "four bounces)"),
    pb::bind(kShadowParams.row("shadow_map_size"), &PhotonParams::shadow_map_size),
    pb::param("store_first_hit", &PhotonParams::store_first_hit, false,
              "test hook: also store photons at the first hit (L D), so the estimate includes "
              "direct light (checked against closed-form irradiance); Paper I: false"));
// clang-format on
// PhotonParams keeps member initialisers (techniques fill one field by field): they are the
// declaration's.
static_assert(kPhotonParams.member_defaults_match());

// Each shared row by name, for a technique that lists rows one by one.
inline constexpr pb_param_spec kPhotonsParam = kPhotonParams.row("photons");
inline constexpr pb_param_spec kRadiusParam = kPhotonParams.row("radius");
inline constexpr pb_param_spec kMaxBouncesParam = kPhotonParams.row("max_bounces");
inline constexpr pb_param_spec kShadowMapSizeParam = kShadowParams.row("shadow_map_size");
inline constexpr pb_param_spec kShadowBiasParam = kShadowParams.row("shadow_bias");
inline constexpr pb_param_spec kShadowNormalOffsetParam = kShadowParams.row("shadow_normal_offset");
inline constexpr pb_param_spec kStoreFirstHitParam = kPhotonParams.row("store_first_hit");

// A shared row with a technique's own default, range and doc; its name, type and unit stay the
// row's, so one name means one thing in every schema (aaps's max_bounces: 8 in [1, 31]).
constexpr pb_param_spec with_range(pb_param_spec row, double default_value, double min_value,
                                   double max_value, const char* doc) {
  row.default_value = default_value;
  row.min_value = min_value;
  row.max_value = max_value;
  row.doc = doc;
  return row;
}

// ---- Counters the shared frame of a photon technique emits (render_photon_frame): the
// "photon-trace" pass's (photonbench/context.h, trace_and_upload_photons) and the upload's size.
// clang-format off
inline constexpr pb_counter_spec kPhotonsStoredCounter = {
    "photons_stored", PB_COUNTER_SIZE, "photons", "photons the tracer stored this frame"};
inline constexpr pb_counter_spec kBytesPhotonsCounter = {
    "bytes_photons", PB_COUNTER_SIZE, "bytes", "the uploaded photon records (96 bytes each)"};
// clang-format on

// The counters of several parts of a technique as one array, for its descriptor (a name listed
// by two parts, with the same kind and unit, is declared twice: the harness takes it once).
template <size_t... N>
constexpr std::array<pb_counter_spec, (N + ...)> join_counters(
    const std::array<pb_counter_spec, N>&... parts) {
  std::array<pb_counter_spec, (N + ...)> out{};
  size_t at = 0;
  ((std::copy(parts.begin(), parts.end(), out.begin() + at), at += N), ...);
  return out;
}
inline constexpr std::array<pb_counter_spec, 2> kPhotonFrameCounters = {kPhotonsStoredCounter,
                                                                        kBytesPhotonsCounter};

// The budget knobs of a splatting technique (match: in a config): more light paths cost more and
// lower the error; a wider radius costs more (each photon touches more pixels) and trades variance
// for bias.
inline constexpr pb_budget_knob kSplatBudgetKnobs[] = {
    {"photons", PB_COST_GROWS, PB_ERROR_FALLS, PB_SCALE_LOG},
    {"radius", PB_COST_GROWS, PB_ERROR_MIXED, PB_SCALE_LOG},
};

// The shared passes' default shadow biases (photonbench/context.h), with this map size.
void configure_shadows(Context& ctx, uint32_t map_size);

// ---- Device limits. Throws InputError when one binding of `bytes` exceeds the device's
// maxStorageBufferRange (lavapipe: 128 MiB); `what` names the parameter that sized it, e.g. "tiled:
// max_list_entries = 4194304".
void check_storage_range(const gpu::Device& gpu, uint64_t bytes, std::string_view what);

// Dispatches that read lists of up to `longest` entries per invocation in slices of PB_LIST_SLICE
// (llvmpipe's loop limit): `dispatch(first)` records one dispatch over entries [first, first +
// PB_LIST_SLICE) of every list, with a full barrier between slices (later slices add to earlier
// ones' output). At least one slice, so the output is always written.
uint32_t list_slices(uint64_t longest);
void dispatch_slices(vk::CommandBuffer cmd, uint64_t longest,
                     const std::function<void(uint32_t first)>& dispatch);

// The G-buffer in the binding order of toolkit/gbuffer.glsl (position, normal, albedo).
std::array<gpu::Resource, 3> gbuffer_resources(const GBuffer& gbuffer);

// A buffer created for storage, transfer fills and read-backs (tests read toolkit buffers back).
gpu::Buffer storage_buffer(gpu::Device& gpu, std::string name, uint64_t bytes,
                           gpu::Memory memory = gpu::Memory::device_local);

// ---- The photons one frame splats: `records` uploaded into `buffer` (PhotonRecord[]).
struct PhotonSet {
  const gpu::Buffer* buffer = nullptr;
  std::span<const trace::PhotonRecord> records;
  uint32_t count() const { return uint32_t(records.size()); }
};

// A Paper I splatter: the passes between the G-buffer and the shade pass.
class Splatter {
 public:
  virtual ~Splatter() = default;
  // In Technique::setup: reads the splatter's own parameters (its kParams), creates pipelines.
  virtual void setup(Context& ctx, const Params& params, const PhotonParams& photon) = 0;
  // Per frame, after ctx.shared().gbuffer() and direct_light(): records the splat and the radiance
  // estimate of `photons`; returns the indirect radiance image (RGBA32F) for ctx.shared().shade().
  virtual const gpu::Image& render(Context& ctx, const PhotonSet& photons) = 0;
  // After ctx.flush(): this frame's counters and warnings.
  virtual void report(Context& ctx, const PhotonSet& photons) = 0;
};

// One frame of a splatting technique: photon-trace and photon-upload (pb::trace_and_upload_photons
// into `photons`, named "<name>/photons"), gbuffer, direct-light, the splatter, shade; then a
// flush so that the splatter reads its counters, and "bytes_photons".
void render_photon_frame(Context& ctx, const PhotonParams& photon, trace::PhotonBatch& batch,
                         gpu::Buffer& photons, std::string_view name, Splatter& splatter);

// A technique that is one Splatter: S has `static constexpr const char* kName` and S() and the
// Splatter interface.
template <class S>
class SplatTechnique final : public Technique {
 public:
  // The descriptor's counters and check: the shared frame's and the splatter's.
  // The descriptor's rows (the shared ones, then the splatter's), counters and check.
  static constexpr auto kSchema = join_rows(kPhotonParams, kDirectLightParams, S::kParams);
  static constexpr auto kCounters = join_counters(kPhotonFrameCounters, S::kCounters);
  static std::string check(const Params& params) { return S::check(params); }

  void setup(Context& ctx, const Params& params) override {
    photon_ = kPhotonParams.read(params);
    configure_shadows(ctx, photon_.shadow_map_size);
    configure_direct_light(ctx, params);
    splatter_.setup(ctx, params, photon_);
  }
  void render(Context& ctx) override {
    render_photon_frame(ctx, photon_, batch_, photons_, S::kName, splatter_);
  }

 private:
  PhotonParams photon_;
  trace::PhotonBatch batch_;
  gpu::Buffer photons_;
  S splatter_;
};

}  // namespace pb::toolkit
