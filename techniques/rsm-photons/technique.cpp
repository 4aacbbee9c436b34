// rsm-photons: real-time global illumination with photon mapping (seed 000, the thesis behind Ray
// Tracing Gems ch. 24): photons emitted from a reflective shadow map (RSM) by importance sampling,
// traced one bounce on, splatted in screen space as ellipsoid kernels and filtered in time and
// space. Per frame, in the groups of the thesis's Fig. 1.2:
//   rsm           each light's RSM over its emission domain (first hits of a net of rays: depth,
//                 reflectance, normal, incident power), its probability map (Eq. 4.9's survival
//                 times the falloff, zero outside the photon near/far range) and its 2D Haar
//                 transform; the map becomes the light's emission density;
//   photon-trace  the CPU tracer emits the budget (shared by power) from the maps, Russian
//                 roulette at each hit, the first hit not stored; photons kept inside the camera
//                 frustum and facing it, counted per screen tile; one ellipsoid kernel each;
//   estimate      the kernels splatted (instanced proxies, additive blending) at reduced
//                 resolution into irradiance and mean light direction;
//   filters       temporal (alpha = alpha_max w_z w_n) and edge-avoiding a-trous with variance-
//                 clipped details, each switchable;
//   gi-shade      E albedo / pi (with the mean-direction term of Eq. 7.10 when asked), to shade().
// Fails where photon mapping fails: weak or wide lights get few photons (§8.3's moonlight), and a
// light that sees nothing of the view spends its budget unseen. README.md gives the parameters,
// every constant the thesis leaves open and each deviation (the RSM is ray cast, not rasterised;
// the filters run on the CPU; the tracer, not the wavelet warping, draws the photons).
#include "photonbench/toolkit/technique.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <glm/glm.hpp>
#include <string>
#include <vector>

#include "photonbench/error.h"
#include "photonbench/plugin.h"
#include "photonbench/scene_layout.h"
#include "rsm-photons_shaders.h"
#include "rsm_core.h"

namespace {

using pb::gpu::Binding;

// The choices of the enumerated parameters, in their declared order.
enum class Sampler : uint32_t { wavelet, tracer };
enum class SplatScale : uint32_t { full, half, quarter };  // 1, 1/2 and 1/4 of each side
enum class Estimate : uint32_t { splat, gather };

// Every parameter of a cell: the core's kernel, filter and shading parameters (rsm_core.h, whose
// initialisers are the thesis's values) and the technique's own.
struct RsmParams : rsm::KernelParams, rsm::FilterParams, rsm::ShadeParams {
  uint32_t photons;
  uint32_t max_bounces;
  uint32_t rsm_resolution;
  float photon_near, photon_far;
  Sampler sampler;
  bool first_hit_roulette;
  uint32_t tile_size;
  SplatScale splat_scale;
  Estimate estimate;
  uint32_t gather_tile;
  double gather_capacity;
  bool temporal, spatial;
  uint32_t shadow_map_size;
};

// A core struct's field as a field of RsmParams (a row binds the struct it reads into).
template <class F, class Core>
constexpr F RsmParams::*core(F Core::*field) {
  return pb::base_field<RsmParams>(field);
}

// clang-format off
constexpr auto kParams = pb::params(
    pb::bind(pb::toolkit::with_range(pb::toolkit::kPhotonsParam, 100000, 1, 5e7,
                                     "photons emitted per frame from the probability maps, shared "
                                     "among lights by power (the thesis: 1 M at 1080p; kept small "
                                     "for lavapipe)"),
             &RsmParams::photons),
    pb::bind(pb::toolkit::with_range(pb::toolkit::kMaxBouncesParam, 2, 2, 16,
                                     "surface interactions per photon path; photons are stored at "
                                     "hits 2 to max_bounces (the thesis's one bounce, §8: "
                                     "max_bounces 2)"),
             &RsmParams::max_bounces),
    pb::param("rsm_resolution", &RsmParams::rsm_resolution, 64, {2, 1024}, "texels",
              "side of each light's RSM and probability map over its emission domain, a power of "
              "two (the Haar transform halves it; unspecified in the thesis)"),
    pb::param("photon_near", &RsmParams::photon_near, 0, {0, 1e6}, "m",
              "photon near plane: probability 0 for RSM texels closer to the light (§5.2, Fig. "
              "5.3)"),
    pb::param("photon_far", &RsmParams::photon_far, 1000, {0, 1e6}, "m",
              "photon far plane: probability 0 for RSM texels farther from the light (§5.2)"),
    pb::param("sampler", &RsmParams::sampler, Sampler::wavelet, "wavelet|tracer",
              "wavelet: photons start at Hammersley points warped through the map's Haar pyramid "
              "(§5.3); tracer: the tracer's own sampling of the same map (CDF inversion of Sobol "
              "points)"),
    pb::param("first_hit_roulette", &RsmParams::first_hit_roulette, false,
              "sampler tracer: Russian roulette (Eq. 4.9) at the first hit too, as the thesis runs "
              "it on its sampling points (§5.3.3, p applied twice); false: the map's survival "
              "factor alone"),
    pb::param("tile_size", &RsmParams::tile_size, 16, {1, 512}, "px",
              "side of the screen tiles whose photon counts size the kernels (§6.1.1; "
              "unspecified)"),
    pb::param("n_tile", core(&rsm::KernelParams::n_tile), 3.2, {0.01, 100}, "",
              "n_tile of Eq. 6.2, the kernel radius multiplier (§8: 1.25 Sponza, 1.7 Conference "
              "room; 3.2: kernels cover each point about n_tile^2 s_l^2 / 4 times, README)"),
    pb::param("kernel_min_radius", core(&rsm::KernelParams::r_min), 0.005, {0, 100}, "m",
              "r_min of Eq. 6.2, the density radius's lower clamp (unspecified)"),
    pb::param("kernel_max_radius", core(&rsm::KernelParams::r_max), 0.25, {1e-4, 100}, "m",
              "r_max of Eq. 6.2, its upper clamp (unspecified)"),
    pb::param("ray_length_max", core(&rsm::KernelParams::l_max), 1, {1e-3, 1e4}, "m",
              "l_max of Eq. 6.1: a ray this long gets the full kernel, shorter ones down to 0.1 of "
              "it (unspecified; about the scene's size)"),
    pb::param("kernel_compress", core(&rsm::KernelParams::s_n), 0.25, {1e-3, 1}, "",
              "s_n: the kernel's half-length along the normal over its tangent radius "
              "(unspecified)"),
    pb::param("kernel_max_stretch", core(&rsm::KernelParams::s_max), 5, {1, 100}, "",
              "s_max of Eq. 6.3: the largest stretch along the projected light direction "
              "(unspecified)"),
    pb::param("splat_scale", &RsmParams::splat_scale, SplatScale::half, "full|half|quarter",
              "resolution of the splat targets (§6.2.1: half; quarter had precision issues)"),
    pb::param("estimate", &RsmParams::estimate, Estimate::splat, "splat|gather",
              "the screen-space irradiance estimate: splat (instanced kernels, additive blending, "
              "§6.2) or gather (five compute passes: tile lists of kernels, then per pixel a loop "
              "over its tile's, §6.3; the thesis found it slower, Table 6.1); the same kernels, "
              "targets and ellipsoid test"),
    pb::param("gather_tile", &RsmParams::gather_tile, 8, {1, 64}, "px",
              "estimate gather: side of the gathering tiles at the splat resolution (unspecified; "
              "8: one 8x8 workgroup a tile)"),
    pb::param("gather_capacity", &RsmParams::gather_capacity, 16, {0.01, 4096}, "entries/kernel",
              "estimate gather: the index buffer's size, in entries per kernel drawn (§6.3: it "
              "must be estimated; entries past it are dropped and counted, the thesis's "
              "corruption)"),
    pb::param("temporal", &RsmParams::temporal, true, "the temporal filter (§7.2)"),
    pb::param("temporal_alpha", core(&rsm::FilterParams::alpha_max), 0.95, {0, 1}, "",
              "alpha_max of Eq. 7.4 (the thesis's value)"),
    pb::param("spatial", &RsmParams::spatial, true, "the a-trous spatial filter (§7.3)"),
    pb::param("spatial_iterations", core(&rsm::FilterParams::iterations), 4, {1, 8}, "iterations",
              "a-trous iterations, taps 2^i apart (the thesis's F-iter: 4)"),
    pb::param("detail_clip", core(&rsm::FilterParams::detail_clip), true,
              "keep each iteration's detail clipped to +-gamma sigma (§7.3.1); false: S_N alone"),
    pb::param("detail_gamma", core(&rsm::FilterParams::gamma), 0.05, {0, 100}, "",
              "gamma of the detail clip (§8: 0.05 Conference room, 0.04 Sponza)"),
    pb::param("sigma_z", core(&rsm::FilterParams::sigma_z), 1, {0, 1000}, "",
              "sigma_z of w_z (§7.1: 1)"),
    pb::param("sigma_n", core(&rsm::FilterParams::sigma_n), 32, {0, 1000}, "",
              "sigma_n of w_n (§7.1: 32)"),
    pb::param("depth_epsilon", core(&rsm::FilterParams::epsilon), 0.01, {1e-6, 1}, "fraction",
              "epsilon of w_z as a fraction of the pixel's depth (unspecified; the temporal "
              "tolerance)"),
    pb::param("direction_term", core(&rsm::ShadeParams::direction_term), false,
              "shade with the filtered mean light direction (Eq. 7.10: its cosine with the "
              "shading normal over that with the geometric one); off: Eq. 7.9"),
    pb::param("direction_max_scale", core(&rsm::ShadeParams::sl_max), 4, {1, 1000}, "",
              "sl_max of Eq. 7.10 (unspecified)"),
    pb::bind(pb::toolkit::kShadowMapSizeParam, &RsmParams::shadow_map_size));
// clang-format on
// The core structs keep their initialisers (the unit tests build them whole): they must be the
// declaration's defaults.
static_assert(static_cast<const rsm::KernelParams&>(kParams.defaults()) == rsm::KernelParams{} &&
              static_cast<const rsm::FilterParams&>(kParams.defaults()) == rsm::FilterParams{} &&
              static_cast<const rsm::ShadeParams&>(kParams.defaults()) == rsm::ShadeParams{});

// clang-format off
constexpr auto kCounters = pb::counters({
    {"sampling_points", PB_COUNTER_WORK, "paths", "photon paths started from the probability maps"},
    {"sampling_points_survived", PB_COUNTER_WORK, "paths",
     "paths that left their first hit (roulette, Fig. 5.1)"},
    pb::toolkit::kPhotonsStoredCounter,
    {"rsm_texels_active", PB_COUNTER_SIZE, "texels",
     "RSM texels of non-zero probability, all lights"},
    {"photons_culled", PB_COUNTER_WORK, "photons",
     "stored photons outside the camera frustum or facing away"},
    {"splats", PB_COUNTER_WORK, "splats", "kernels drawn"},
    {"tile_photons_max", PB_COUNTER_SIZE, "photons",
     "photons of the fullest screen tile (n_p of Eq. 6.2)"},
    {"tile_photons_mean", PB_COUNTER_SIZE, "photons", "photons per screen tile that holds any"},
    {"tiles_empty", PB_COUNTER_RATIO, "tiles", "share of the screen tiles without a photon"},
    {"gather_entries", PB_COUNTER_SIZE, "entries",
     "estimate gather: tile-list entries the kernels need"},
    {"gather_dropped", PB_COUNTER_WORK, "entries",
     "estimate gather: entries past the index buffer, dropped"},
    {"bytes_gpu", PB_COUNTER_SIZE, "bytes", "the technique's GPU buffers and images"},
    {"bytes_host", PB_COUNTER_SIZE, "bytes",
     "photons, kept paths, RSMs, maps, filter history (host)"},
});
// clang-format on

// The splat proxy: an octahedron circumscribing the unit sphere (vertices at +-sqrt(3) on the
// axes: its faces are 1 from the centre), 8 faces of 3 vertices, each with its face's outward
// normal. The thesis draws an icosahedron (60 vertices, circumscribing at 1.26); on lavapipe the
// splat is bound by vertex work, and 24 vertices cost less than the larger proxy's extra fragments,
// which the face test discards first.
struct ProxyVertex {
  glm::vec4 position, face_normal;
};
std::vector<ProxyVertex> proxy_mesh() {
  const float r = std::sqrt(3.f);
  std::vector<ProxyVertex> out;
  for (int face = 0; face < 8; ++face) {
    const glm::vec3 s{face & 1 ? -1.f : 1.f, face & 2 ? -1.f : 1.f, face & 4 ? -1.f : 1.f};
    const glm::vec3 corners[3] = {{s.x * r, 0, 0}, {0, s.y * r, 0}, {0, 0, s.z * r}};
    const glm::vec3 n = glm::normalize(s);
    for (const glm::vec3& c : corners) out.push_back({glm::vec4(c, 1.f), glm::vec4(n, 0.f)});
  }
  return out;
}

struct SplatPush {
  glm::mat4 view_projection;
  glm::vec4 camera;
  glm::uvec4 size;
};

// The gathering passes' view (rsm_gather.glsl's View block) and state (its State block: the
// dispatch arguments, the kernel count, the allocation counter, the dropped entries, the capacity).
struct GatherView {
  glm::mat4 view_projection, inverse_view_projection;
  glm::vec4 camera;
  glm::uvec4 size, grid;
};
struct GatherState {
  uint32_t dispatch[3], kernel_count, allocated, dropped, capacity, pad;
};
static_assert(sizeof(GatherState) == 32, "rsm_gather.glsl's State block");

class RsmPhotons final : public pb::Technique {
 public:
  static std::string check(const pb::Params& params) {
    const RsmParams p = kParams.read(params);
    if (p.rsm_resolution & (p.rsm_resolution - 1))
      return fmt::format("rsm_resolution: {} is not a power of two (the Haar transform halves it)",
                         p.rsm_resolution);
    if (p.photon_far <= p.photon_near)
      return fmt::format("photon_far: {} is not beyond photon_near = {}", p.photon_far,
                         p.photon_near);
    if (p.first_hit_roulette && p.sampler == Sampler::wavelet)
      return "first_hit_roulette: true needs sampler: tracer (the warped points are re-emitted "
             "from the RSM pass's paths, which play no roulette at their first hit)";
    if (p.r_max < p.r_min)
      return fmt::format("kernel_max_radius: {} is below kernel_min_radius = {}", p.r_max, p.r_min);
    return "";
  }

  void setup(pb::Context& ctx, const pb::Params& params) override {
    p_ = kParams.read(params);
    pb::toolkit::configure_direct_light(ctx, params);
    scale_ = 1u << uint32_t(p_.splat_scale);  // full, half, quarter: 1, 2, 4
    gather_ = p_.estimate == Estimate::gather;
    pb::toolkit::configure_shadows(ctx, p_.shadow_map_size);

    // The RSM pass: one ray per texel of each light's emission domain (an Owen-scrambled Sobol net
    // of side^2 points has one point in each texel), kept whole so that its first hit can be read
    // (the incident power on vertex 0, what leaves the first hit on vertex 1: their ratio is the
    // reflectance); no roulette at the first hit, so every texel's reflectance is seen. With the
    // wavelet sampler its paths are then re-emitted from the warped points (photon-trace), so it
    // traces with the photons' settings.
    rsm_settings_.max_bounces = p_.max_bounces;
    rsm_settings_.store = pb::trace::kIndirectPhotons | pb::trace::kCausticIndirectPhotons;
    rsm_settings_.rr_start = 1;
    rsm_settings_.keep_light_paths = true;
    rsm_settings_.seed = 0x52534d;
    rsm_settings_.seed_per_frame = true;
    // The photons: the first hit not stored (the photon map holds indirect bounces only, Fig. 4.1),
    // kept whole for each photon's ray length (Eq. 6.1).
    trace_.paths = p_.photons;
    trace_.max_bounces = p_.max_bounces;
    trace_.store = pb::trace::kIndirectPhotons | pb::trace::kCausticIndirectPhotons;
    trace_.rr_start = p_.first_hit_roulette ? 0 : 1;
    trace_.keep_light_paths = true;
    trace_.seed = 1;
    trace_.seed_per_frame = true;

    pb::gpu::Device& gpu = ctx.gpu();
    width_ = ctx.output().extent().width, height_ = ctx.output().extent().height;
    small_width_ = (width_ + scale_ - 1) / scale_, small_height_ = (height_ + scale_ - 1) / scale_;
    using Usage = vk::ImageUsageFlagBits;
    constexpr vk::Format kFloat4 = vk::Format::eR32G32B32A32Sfloat;
    const vk::Extent2D small{small_width_, small_height_};
    accumulation_ = gpu.create_image("rsm-photons.accumulation", small, kFloat4,
                                     Usage::eColorAttachment | Usage::eStorage);
    direction_ = gpu.create_image("rsm-photons.direction", small, kFloat4,
                                  Usage::eColorAttachment | Usage::eStorage);
    radiance_ =
        gpu.create_image("rsm-photons.radiance", {width_, height_}, kFloat4, Usage::eStorage);
    auto host = [&](const char* name, uint64_t texels) {
      return gpu.create_buffer(name, texels * sizeof(glm::vec4),
                               vk::BufferUsageFlagBits::eStorageBuffer,
                               pb::gpu::Memory::host_visible);
    };
    const uint64_t pixels = uint64_t(width_) * height_,
                   small_pixels = uint64_t(small.width) * small.height;
    read_position_ = host("rsm-photons.read_position", pixels);
    read_normal_ = host("rsm-photons.read_normal", pixels);
    read_albedo_ = host("rsm-photons.read_albedo", pixels);
    read_accumulation_ = host("rsm-photons.read_accumulation", small_pixels);
    read_direction_ = host("rsm-photons.read_direction", small_pixels);
    write_radiance_ = host("rsm-photons.write_radiance", pixels);
    const std::vector<ProxyVertex> proxy = proxy_mesh();
    proxy_vertices_ = uint32_t(proxy.size());
    proxy_ =
        gpu.create_buffer("rsm-photons.proxy", proxy.size() * sizeof(ProxyVertex),
                          vk::BufferUsageFlagBits::eVertexBuffer, pb::gpu::Memory::host_visible);
    std::memcpy(proxy_.mapped(), proxy.data(), proxy.size() * sizeof(ProxyVertex));

    pb::gpu::GraphicsPipelineDesc desc;
    desc.name = "rsm-photons.splat";
    desc.vertex_spirv = krsm_splat_vert_spv;
    desc.fragment_spirv = krsm_splat_frag_spv;
    desc.bindings = {Binding::storage_buffer, Binding::storage_image, Binding::storage_image};
    desc.push_bytes = sizeof(SplatPush);
    desc.vertex_stride = sizeof(ProxyVertex);
    desc.vertex_attributes = {kFloat4, kFloat4};
    desc.color_formats = {kFloat4, kFloat4};
    desc.additive_blend = {true, true};
    splat_ = gpu.create_graphics_pipeline(desc);
    readback_ = gpu.create_compute_pipeline("rsm-photons.readback", krsm_readback_comp_spv,
                                            {Binding::storage_image, Binding::storage_buffer},
                                            2 * sizeof(uint32_t));
    upload_ = gpu.create_compute_pipeline("rsm-photons.upload", krsm_upload_comp_spv,
                                          {Binding::storage_buffer, Binding::storage_image},
                                          2 * sizeof(uint32_t));
    if (gather_) setup_gather(gpu);
    lights_.resize(ctx.photon_tracer().light_count());
  }

  void render(pb::Context& ctx) override {
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    const pb::FrameInfo& f = ctx.frame();
    {
      auto scope = ctx.pass("rsm");
      build_rsm(ctx);
    }
    {
      auto scope = ctx.pass("photon-trace");
      trace_photons(ctx, f);
      build_kernels(ctx, f);
    }
    {
      auto scope = ctx.pass("estimate");
      if (gather_)
        gather(ctx, f);
      else
        splat(ctx, f);
      ctx.flush();
      if (gather_) {
        const auto* state = static_cast<const GatherState*>(gather_state_.mapped());
        gather_entries_ = state->allocated;
        gather_dropped_ = state->dropped;
      }
    }
    {
      auto scope = ctx.pass("filters");
      filter(ctx, f);
    }
    {
      auto scope = ctx.pass("gi-shade");
      shade(ctx);
    }
    ctx.shared().shade(&radiance_);
    count(ctx);
  }

 private:
  struct LightMap {
    std::vector<rsm::RsmTexel> texels;
    std::vector<float> probability;
    rsm::HaarPyramid pyramid;
    pb::trace::EmissionDensity density;
    bool active = false;  // some texel has a non-zero probability
  };

  // ---- rsm: the RSM of every light, its probability map and Haar transform (§5.1-5.3)
  void build_rsm(pb::Context& ctx) {
    pb::trace::PhotonTracer& tracer = ctx.photon_tracer();
    const uint32_t n_lights = uint32_t(lights_.size());
    {
      auto scope = ctx.pass("cast");
      for (uint32_t l = 0; l < n_lights; ++l) tracer.set_emission_density(l, nullptr);
      rsm_settings_.paths = p_.rsm_resolution * p_.rsm_resolution * std::max(1u, n_lights);
      tracer.trace(rsm_settings_, rsm_batch_);
      for (LightMap& m : lights_)
        m.texels.assign(size_t(p_.rsm_resolution) * p_.rsm_resolution, rsm::RsmTexel{});
      const auto& paths = rsm_batch_.paths;
      for (const pb::trace::LightPath& path : paths.paths) {
        if (path.light >= n_lights || path.vertex_count == 0) continue;
        const glm::vec2 uv = glm::clamp(path.emission_uv, glm::vec2(0.f), glm::vec2(0.99999f));
        const uint32_t x = uint32_t(uv.x * float(p_.rsm_resolution)),
                       y = uint32_t(uv.y * float(p_.rsm_resolution));
        rsm::RsmTexel& t = lights_[path.light].texels[size_t(y) * p_.rsm_resolution + x];
        if (t.sampled) continue;  // one ray per texel (a second one where lights share the net)
        t.sampled = true;
        const pb::trace::PathVertex& v0 = paths.vertices[path.first_vertex];
        t.incident = v0.power;
        if (path.vertex_count < 2) continue;  // the ray left the scene
        const pb::trace::PathVertex& v1 = paths.vertices[path.first_vertex + 1];
        if (v1.object == ~0u) continue;
        t.hit = true;
        t.position = v1.position;
        t.normal = v1.normal;
        t.distance = glm::distance(v0.position, v1.position);
        t.reflectance = glm::vec3(v0.power.x > 0 ? v1.power.x / v0.power.x : 0.f,
                                  v0.power.y > 0 ? v1.power.y / v0.power.y : 0.f,
                                  v0.power.z > 0 ? v1.power.z / v0.power.z : 0.f);
      }
    }
    {
      auto scope = ctx.pass("probability");
      active_texels_ = 0;
      for (uint32_t l = 0; l < n_lights; ++l) {
        LightMap& m = lights_[l];
        m.probability = rsm::probability_map(m.texels, p_.photon_near, p_.photon_far);
        m.pyramid.build(m.probability, p_.rsm_resolution);
        m.active = m.pyramid.mean() > 0;
        for (float p : m.probability) active_texels_ += p > 0 ? 1 : 0;
        m.density.width = m.density.height = int(p_.rsm_resolution);
        m.density.texels = m.probability;
        // A light whose map is zero everywhere (it sees nothing within the near/far range) emits
        // uniformly: a density must not be all zero.
        tracer.set_emission_density(l, m.active ? &m.density : nullptr);
        if (!m.active)
          ctx.warn(
              fmt::format("rsm-photons: light {} has no RSM texel within the photon near/far "
                          "range; it emits uniformly",
                          l));
      }
    }
  }

  // ---- photon-trace: the photons, from the warped points or by the tracer's own sampling
  void trace_photons(pb::Context& ctx, const pb::FrameInfo& f) {
    pb::trace::PhotonTracer& tracer = ctx.photon_tracer();
    photons_.clear();
    ray_lengths_.clear();
    survivors_ = 0;
    emitted_ = 0;
    if (p_.sampler != Sampler::wavelet) {
      tracer.trace(trace_, batch_);
      collect(batch_, 1.f);
      emitted_ = batch_.stats.paths;
      return;
    }
    // §5.3.2: each light's share of the budget as an n-point Hammersley set, shifted each frame,
    // warped through its map's pyramid. The points start the RSM pass's paths again (their
    // `kRefill` restart, photons.h: a path emitted from a given emission sample, its power divided
    // by the light's density there, which is the map's P / P0, §5.3.3), round after round, one
    // round per RSM ray count. Round r holds the points r * m .. (r + 1) * m - 1 of the set (m per
    // light a round: the strip x in [r / rounds, (r + 1) / rounds) of the unit square), so a round
    // alone is not an estimate of the whole map; all the rounds together are, and each photon
    // carries 1 / rounds of the power the tracer gives it (it divides by m, not by n). A path's
    // bounces draw the tracer's Sobol points of its sample index: giving each point its own index
    // i (not the path's, which every round shares) makes the n photons' bounces n distinct
    // points of one sequence, so more photons buy more independent bounce samples.
    const std::vector<uint32_t>& per_light = rsm_batch_.paths.paths_per_light;
    uint64_t per_round = 0;
    for (uint32_t m : per_light) per_round += m;
    if (per_round == 0) return;
    const uint32_t rounds =
        uint32_t(std::max<uint64_t>(1, (trace_.paths + per_round / 2) / per_round));
    const glm::vec2 shift = rsm::hammersley(f.index % 61u, 61u);
    pb::trace::ReuseSettings exact;
    for (uint32_t round = 0; round < rounds; ++round) {
      tracer.verify_paths(rsm_settings_, exact, rsm_batch_);
      std::vector<uint32_t> index(lights_.size(), 0);
      for (pb::trace::LightPath& path : rsm_batch_.paths.paths) {
        const uint32_t l = path.light;
        const uint32_t n = per_light[l] * rounds, i = round * per_light[l] + index[l]++;
        const glm::vec2 u = rsm::hammersley(i, n, shift);
        path.emission_uv = lights_[l].active ? lights_[l].pyramid.warp(u).uv : u;
        path.sample = i;
        // A surface emitter's direction (cosine-distributed from this point): the next
        // Hammersley dimensions would be correlated with the position, so a hash of the index.
        const uint32_t h = (i + 1) * 0x9e3779b9u ^ (f.index * 0x85ebca6bu);
        path.emission_dir =
            glm::vec2(float(h >> 8) * 0x1p-24f, float((h * 0x27d4eb2du) >> 8) * 0x1p-24f);
        path.restart = pb::trace::LightPath::kRefill;
      }
      tracer.retrace_marked(rsm_settings_, rsm_batch_);
      collect(rsm_batch_, 1.f / float(rounds));
      emitted_ += per_round;
    }
  }

  // The photons of one trace and each one's ray length (from its previous vertex, Eq. 6.1).
  void collect(const pb::trace::PhotonBatch& batch, float power_scale) {
    const auto& paths = batch.paths;
    for (const pb::trace::LightPath& path : paths.paths) survivors_ += path.vertex_count > 2;
    for (pb::trace::PhotonRecord p : batch.photons) {
      float length = p_.l_max;
      if (p.path < paths.paths.size()) {
        const pb::trace::LightPath& path = paths.paths[p.path];
        if (p.bounce < path.vertex_count)
          length = glm::distance(p.position, paths.vertices[path.first_vertex + p.bounce].position);
      }
      p.power *= power_scale;
      photons_.push_back(p);
      ray_lengths_.push_back(length);
    }
  }

  // ---- photon-trace: frustum and facing culls, tile densities, one kernel per photon (§4.3, §6.1)
  void build_kernels(pb::Context& ctx, const pb::FrameInfo& f) {
    auto scope = ctx.pass("kernels");
    const glm::mat4& vp = f.camera.view_projection;
    const uint32_t tiles_x = (width_ + p_.tile_size - 1) / p_.tile_size,
                   tiles_y = (height_ + p_.tile_size - 1) / p_.tile_size;
    tile_counts_.assign(size_t(tiles_x) * tiles_y, 0);
    photon_tile_.assign(photons_.size(), ~0u);
    culled_ = 0;
    for (size_t i = 0; i < photons_.size(); ++i) {
      const pb::trace::PhotonRecord& p = photons_[i];
      const glm::vec4 c = vp * glm::vec4(p.position, 1.f);
      const bool in_frustum = c.w > 0 && std::abs(c.x) <= c.w && std::abs(c.y) <= c.w;
      const bool facing = glm::dot(p.normal, f.camera.position - p.position) > 0;
      if (!in_frustum || !facing) {
        ++culled_;
        continue;
      }
      const float sx = (c.x / c.w * 0.5f + 0.5f) * float(width_);
      const float sy = (c.y / c.w * 0.5f + 0.5f) * float(height_);
      const uint32_t tx = std::min(uint32_t(sx) / p_.tile_size, tiles_x - 1);
      const uint32_t ty = std::min(uint32_t(sy) / p_.tile_size, tiles_y - 1);
      photon_tile_[i] = ty * tiles_x + tx;
      ++tile_counts_[photon_tile_[i]];
    }
    const float c_tile = rsm::tile_constant(f.camera.fov_y, width_, height_, p_.tile_size);
    kernels_.clear();
    for (size_t i = 0; i < photons_.size(); ++i) {
      if (photon_tile_[i] == ~0u) continue;
      const pb::trace::PhotonRecord& p = photons_[i];
      const float ray_length = ray_lengths_[i];
      const float z_view = -(f.camera.view * glm::vec4(p.position, 1.f)).z;
      kernels_.push_back(rsm::make_kernel(p.position, p.normal, p.direction, p.power, ray_length,
                                          z_view, tile_counts_[photon_tile_[i]], c_tile, p_));
    }
    const uint64_t bytes = std::max<uint64_t>(1, kernels_.size()) * sizeof(rsm::Kernel);
    if (kernel_buffer_.size() < bytes)
      kernel_buffer_ = ctx.gpu().create_buffer("rsm-photons.kernels", bytes * 3 / 2,
                                               vk::BufferUsageFlagBits::eStorageBuffer,
                                               pb::gpu::Memory::host_visible);
    if (!kernels_.empty())
      std::memcpy(kernel_buffer_.mapped(), kernels_.data(), kernels_.size() * sizeof(rsm::Kernel));
  }

  // ---- estimate: the kernels splatted into the accumulation targets (§6.2), read back
  void splat(pb::Context& ctx, const pb::FrameInfo& f) {
    vk::CommandBuffer cmd = ctx.cmd();
    const vk::ClearColorValue zero(std::array<float, 4>{0, 0, 0, 0});
    auto attachment = [&](const pb::gpu::Image& image) {
      return vk::RenderingAttachmentInfo{image.view(),
                                         vk::ImageLayout::eGeneral,
                                         {},
                                         {},
                                         {},
                                         vk::AttachmentLoadOp::eClear,
                                         vk::AttachmentStoreOp::eStore,
                                         zero};
    };
    const std::array<vk::RenderingAttachmentInfo, 2> colors{attachment(accumulation_),
                                                            attachment(direction_)};
    const vk::Rect2D area{{0, 0}, {small_width_, small_height_}};
    ctx.gpu().begin_rendering(cmd, vk::RenderingInfo{{}, area, 1, 0, colors});
    if (!kernels_.empty()) {
      cmd.setViewport(0, vk::Viewport{0, 0, float(small_width_), float(small_height_), 0, 1});
      cmd.setScissor(0, area);
      SplatPush push{f.camera.view_projection, glm::vec4(f.camera.position, 1.f),
                     glm::uvec4(width_, height_, scale_, 0)};
      const pb::GBuffer g = ctx.shared().gbuffer_images();
      splat_.bind(cmd, {&kernel_buffer_, g.position, g.normal}, push);
      cmd.bindVertexBuffers(0, proxy_.handle(), vk::DeviceSize(0));
      cmd.draw(proxy_vertices_, uint32_t(kernels_.size()), 0, 0);
    }
    ctx.gpu().end_rendering(cmd);
    pb::gpu::full_barrier(cmd);
    read_back(cmd, accumulation_, read_accumulation_, small_width_, small_height_);
    read_back(cmd, direction_, read_direction_, small_width_, small_height_);
  }

  // ---- estimate, gathering instead (§6.3): five compute passes over the same kernels
  // into the same targets, read back
  void setup_gather(pb::gpu::Device& gpu) {
    gather_grid_ = {(small_width_ + p_.gather_tile - 1) / p_.gather_tile,
                    (small_height_ + p_.gather_tile - 1) / p_.gather_tile};
    using U = vk::BufferUsageFlagBits;
    gather_state_ =
        gpu.create_buffer("rsm-photons.gather_state", sizeof(GatherState),
                          U::eStorageBuffer | U::eIndirectBuffer, pb::gpu::Memory::host_visible);
    gather_tiles_ = gpu.create_buffer(
        "rsm-photons.gather_tiles", uint64_t(gather_grid_.x) * gather_grid_.y * sizeof(glm::uvec4),
        U::eStorageBuffer | U::eTransferDst, pb::gpu::Memory::host_visible);
    gather_view_ = gpu.create_buffer("rsm-photons.gather_view", sizeof(GatherView),
                                     U::eStorageBuffer, pb::gpu::Memory::host_visible);
    const std::vector<Binding> bindings = {
        Binding::storage_buffer, Binding::storage_buffer, Binding::storage_buffer,
        Binding::storage_buffer, Binding::storage_buffer, Binding::storage_image,
        Binding::storage_image,  Binding::storage_image,  Binding::storage_image};
    gather_args_ = gpu.create_compute_pipeline("rsm-photons.gather_args", krsm_gather_args_comp_spv,
                                               bindings, 0);
    gather_count_ = gpu.create_compute_pipeline("rsm-photons.gather_count",
                                                krsm_gather_count_comp_spv, bindings, 0);
    gather_allocate_ = gpu.create_compute_pipeline("rsm-photons.gather_allocate",
                                                   krsm_gather_allocate_comp_spv, bindings, 0);
    gather_copy_ = gpu.create_compute_pipeline("rsm-photons.gather_copy", krsm_gather_copy_comp_spv,
                                               bindings, 0);
    gather_pass_ =
        gpu.create_compute_pipeline("rsm-photons.gather", krsm_gather_comp_spv, bindings, 0);
  }

  void gather(pb::Context& ctx, const pb::FrameInfo& f) {
    const uint32_t n = uint32_t(kernels_.size());
    // The index buffer's size is an estimate made before the lists are known (§6.3).
    const uint32_t capacity =
        uint32_t(std::clamp(std::ceil(p_.gather_capacity * double(n)), 1.0, 4294967295.0 / 4));
    if (gather_indices_.size() < uint64_t(capacity) * 4)
      gather_indices_ = ctx.gpu().create_buffer(
          "rsm-photons.gather_indices", uint64_t(capacity) * 4,
          vk::BufferUsageFlagBits::eStorageBuffer, pb::gpu::Memory::host_visible);
    GatherView view{f.camera.view_projection, f.camera.inverse_view_projection,
                    glm::vec4(f.camera.position, 1.f),
                    glm::uvec4(width_, height_, scale_, p_.gather_tile),
                    glm::uvec4(gather_grid_, small_width_, small_height_)};
    std::memcpy(gather_view_.mapped(), &view, sizeof(view));
    GatherState state{};
    state.kernel_count = n;
    state.capacity = capacity;
    std::memcpy(gather_state_.mapped(), &state, sizeof(state));
    const pb::GBuffer g = ctx.shared().gbuffer_images();
    const std::vector<pb::gpu::Resource> resources = {
        &kernel_buffer_, &gather_state_, &gather_tiles_, &gather_indices_, &gather_view_,
        g.position,      g.normal,       &accumulation_, &direction_};
    const uint32_t tiles = gather_grid_.x * gather_grid_.y;
    ctx.cmd().fillBuffer(gather_tiles_.handle(), 0, VK_WHOLE_SIZE, 0u);
    pb::gpu::full_barrier(ctx.cmd());
    // Each pass timed on its own (estimate/<pass>; a pass scope may submit what came before, so the
    // command buffer is fetched inside it); `groups` 0: the indirect arguments of pass 1.
    auto run = [&](const char* name, const pb::gpu::Pipeline& pipeline, glm::uvec2 groups) {
      auto scope = ctx.pass(name);
      vk::CommandBuffer cmd = ctx.cmd();
      pipeline.bind(cmd, resources);
      if (groups.x == 0)
        cmd.dispatchIndirect(gather_state_.handle(), 0);
      else
        cmd.dispatch(groups.x, groups.y, 1);
      pb::gpu::full_barrier(cmd);
    };
    run("indirect-args", gather_args_, {1, 1});
    run("count", gather_count_, {0, 0});
    run("allocate", gather_allocate_, {pb::gpu::groups_for(tiles, 64), 1});
    run("copy", gather_copy_, {0, 0});
    run("gather", gather_pass_, gather_grid_);
    vk::CommandBuffer cmd = ctx.cmd();
    read_back(cmd, accumulation_, read_accumulation_, small_width_, small_height_);
    read_back(cmd, direction_, read_direction_, small_width_, small_height_);
  }

  void read_back(vk::CommandBuffer cmd, const pb::gpu::Image& image, const pb::gpu::Buffer& buffer,
                 uint32_t width, uint32_t height) {
    uint32_t push[2] = {width, height};
    readback_.bind(cmd, {&image, &buffer}, push, sizeof(push));
    cmd.dispatch(pb::gpu::groups_for(width, 8), pb::gpu::groups_for(height, 8), 1);
    pb::gpu::full_barrier(cmd);
  }

  // ---- filters: upsampling, temporal, a-trous (§6.2.1, §7.2-7.3), on the host
  void filter(pb::Context& ctx, const pb::FrameInfo& f) {
    {
      auto scope = ctx.pass("readback");
      const pb::GBuffer g = ctx.shared().gbuffer_images();
      vk::CommandBuffer cmd = ctx.cmd();
      read_back(cmd, *g.position, read_position_, width_, height_);
      read_back(cmd, *g.normal, read_normal_, width_, height_);
      read_back(cmd, *g.albedo, read_albedo_, width_, height_);
      ctx.flush();
      const size_t n = size_t(width_) * height_;
      geometry_.width = int(width_), geometry_.height = int(height_);
      const glm::vec4* position = static_cast<const glm::vec4*>(read_position_.mapped());
      const glm::vec4* normal = static_cast<const glm::vec4*>(read_normal_.mapped());
      geometry_.position.assign(position, position + n);
      geometry_.normal.assign(normal, normal + n);
      const size_t small = size_t(small_width_) * small_height_;
      const glm::vec4* acc = static_cast<const glm::vec4*>(read_accumulation_.mapped());
      const glm::vec4* dir = static_cast<const glm::vec4*>(read_direction_.mapped());
      std::vector<glm::vec3> e(small), d(small);
      for (size_t i = 0; i < small; ++i) {
        e[i] = glm::vec3(acc[i]);
        d[i] = glm::vec3(acc[i].w, dir[i].x, dir[i].y);
      }
      irradiance_ = rsm::upsample(e, int(small_width_), int(small_height_), int(width_),
                                  int(height_), int(scale_));
      light_dir_ = rsm::upsample(d, int(small_width_), int(small_height_), int(width_),
                                 int(height_), int(scale_));
    }
    if (p_.temporal) {
      auto scope = ctx.pass("temporal");
      rsm::temporal(geometry_, history_, p_, irradiance_, light_dir_);
      history_.valid = true;
      history_.geometry = geometry_;
      history_.view_projection = f.camera.view_projection;
      history_.camera = f.camera.position;
      history_.irradiance = irradiance_;
      history_.direction = light_dir_;
    }
    if (p_.spatial) {
      auto scope = ctx.pass("spatial");
      rsm::atrous(geometry_, p_, irradiance_, light_dir_);
    }
  }

  // ---- gi-shade: indirect radiance of diffuse receivers (§7.4), uploaded for shade()
  void shade(pb::Context& ctx) {
    const glm::vec4* albedo = static_cast<const glm::vec4*>(read_albedo_.mapped());
    glm::vec4* out = static_cast<glm::vec4*>(write_radiance_.mapped());
    for (int y = 0; y < int(height_); ++y)
      for (int x = 0; x < int(width_); ++x) {
        const size_t i = size_t(y) * width_ + x;
        const int type = int(albedo[i].w);
        const bool lit =
            geometry_.valid(x, y) && (type == PB_MATERIAL_DIFFUSE || type == PB_MATERIAL_EMISSIVE);
        glm::vec3 l(0.f);
        if (lit) {
          const glm::vec3 ns = geometry_.normal_at(x, y);
          const glm::vec3 ng = p_.direction_term ? rsm::geometric_normal(geometry_, x, y) : ns;
          l = rsm::shade(irradiance_[i], glm::vec3(albedo[i]), light_dir_[i], ns, ng, p_);
        }
        out[i] = glm::vec4(l, 1.f);
      }
    vk::CommandBuffer cmd = ctx.cmd();
    uint32_t push[2] = {width_, height_};
    upload_.bind(cmd, {&write_radiance_, &radiance_}, push, sizeof(push));
    cmd.dispatch(pb::gpu::groups_for(width_, 8), pb::gpu::groups_for(height_, 8), 1);
    pb::gpu::full_barrier(cmd);
  }

  void count(pb::Context& ctx) {
    pb::count(ctx, kCounters["sampling_points"], double(emitted_));
    pb::count(ctx, kCounters["sampling_points_survived"], double(survivors_));
    pb::count(ctx, pb::toolkit::kPhotonsStoredCounter, double(photons_.size()));
    pb::count(ctx, kCounters["rsm_texels_active"], double(active_texels_));
    pb::count(ctx, kCounters["photons_culled"], double(culled_));
    pb::count(ctx, kCounters["splats"], double(kernels_.size()));
    uint32_t most = 0;
    uint64_t total = 0, filled = 0;
    for (uint32_t c : tile_counts_) {
      most = std::max(most, c);
      total += c;
      filled += c > 0;
    }
    pb::count(ctx, kCounters["tile_photons_max"], double(most));
    pb::count(ctx, kCounters["tile_photons_mean"],
              filled > 0 ? double(total) / double(filled) : 0.0);
    pb::count(ctx, kCounters["tiles_empty"],
              tile_counts_.empty() ? 0.0 : 1.0 - double(filled) / double(tile_counts_.size()));
    pb::count(ctx, kCounters["gather_entries"], double(gather_entries_));  // 0 with the splat
    pb::count(ctx, kCounters["gather_dropped"], double(gather_dropped_));
    if (gather_ && gather_dropped_ > 0) {
      ctx.warn(
          fmt::format("rsm-photons: the gathering index buffer ({} entries a kernel) was "
                      "{} entries short; raise gather_capacity",
                      p_.gather_capacity, gather_dropped_));
    }
    const uint64_t gpu =
        accumulation_.bytes() + direction_.bytes() + radiance_.bytes() + read_position_.size() +
        read_normal_.size() + read_albedo_.size() + read_accumulation_.size() +
        read_direction_.size() + write_radiance_.size() + proxy_.size() + kernel_buffer_.size() +
        gather_state_.size() + gather_tiles_.size() + gather_view_.size() + gather_indices_.size();
    pb::count(ctx, kCounters["bytes_gpu"], double(gpu));
    auto vec_bytes = [](const auto& v) { return uint64_t(v.capacity() * sizeof(v[0])); };
    uint64_t host = vec_bytes(photons_) + vec_bytes(ray_lengths_) + vec_bytes(batch_.photons) +
                    vec_bytes(batch_.paths.paths) + vec_bytes(batch_.paths.vertices) +
                    vec_bytes(rsm_batch_.photons) + vec_bytes(rsm_batch_.paths.paths) +
                    vec_bytes(rsm_batch_.paths.vertices) + vec_bytes(kernels_) +
                    vec_bytes(geometry_.position) + vec_bytes(geometry_.normal) +
                    vec_bytes(irradiance_) + vec_bytes(light_dir_) +
                    vec_bytes(history_.geometry.position) + vec_bytes(history_.geometry.normal) +
                    vec_bytes(history_.irradiance) + vec_bytes(history_.direction);
    for (const LightMap& m : lights_) host += vec_bytes(m.texels) + 2 * vec_bytes(m.probability);
    pb::count(ctx, kCounters["bytes_host"], double(host));
  }

  RsmParams p_ = kParams.defaults();
  uint32_t scale_ = 2;  // the splat targets' pixels per side of one of theirs
  uint32_t width_ = 0, height_ = 0, small_width_ = 0, small_height_ = 0;
  bool gather_ = false;
  glm::uvec2 gather_grid_{0, 0};
  uint64_t gather_entries_ = 0, gather_dropped_ = 0;
  pb::gpu::Buffer gather_state_, gather_tiles_, gather_view_, gather_indices_;
  pb::gpu::Pipeline gather_args_, gather_count_, gather_allocate_, gather_copy_, gather_pass_;
  pb::trace::TraceSettings rsm_settings_, trace_;
  pb::trace::PhotonBatch rsm_batch_, batch_;
  std::vector<LightMap> lights_;
  std::vector<uint32_t> tile_counts_, photon_tile_;
  std::vector<rsm::Kernel> kernels_;
  std::vector<pb::trace::PhotonRecord> photons_;
  std::vector<float> ray_lengths_;
  uint64_t culled_ = 0, survivors_ = 0, active_texels_ = 0, emitted_ = 0;
  rsm::Geometry geometry_;
  rsm::History history_;
  std::vector<glm::vec3> irradiance_, light_dir_;
  pb::gpu::Image accumulation_, direction_, radiance_;
  pb::gpu::Buffer read_position_, read_normal_, read_albedo_, read_accumulation_, read_direction_,
      write_radiance_, proxy_, kernel_buffer_;
  uint32_t proxy_vertices_ = 0;
  pb::gpu::Pipeline splat_, readback_, upload_;
};

// The budget knob (match: in a config): more photons cost more to trace and to splat and lower
// the error.
const pb_budget_knob kBudget[] = {
    {"photons", PB_COST_GROWS, PB_ERROR_FALLS, PB_SCALE_LOG},
};

}  // namespace

// The shared direct light's rows (the toolkit's: shadow maps or many-light next-event estimation,
// seed 002 Papers III and IV) after the technique's own.
constexpr auto kSchema = pb::join_rows(kParams, pb::toolkit::kDirectLightParams);

PB_EXPORT_TECHNIQUE(RsmPhotons, "rsm-photons", "indirect",
                    "reflective-shadow-map photons (seed 000): RSM probability maps, one bounce "
                    "traced, ellipsoid kernels splatted at half resolution, temporal and a-trous "
                    "filters",
                    kSchema.rows, .counters = kCounters.specs, .check = &RsmPhotons::check,
                    .budget = kBudget)
