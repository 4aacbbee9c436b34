// photon-differentials: Fabianowski and Dingliana 2009, "Interactive Global Photon Mapping" (seed
// 003). Every photon hit carries its own footprint from photon differentials, the photon map is a
// linear BVH over the footprints' ellipsoids rebuilt on the GPU each frame, and a query sums every
// footprint that contains the shading point, with no k-nearest search. Per frame:
//   photon-trace   the CPU tracer with differential_rules.h as its policy (Eqs. 2-9 at the light,
//                  Igehy's transfer at specular hits, re-emission with a virtual origin at diffuse
//                  ones, Eqs. 10-13, Russian roulette's 1 / sqrt(p), §4.2); the first hits (direct
//                  light is shaded, not estimated) only give the lit surface area for T_auto;
//   photon-upload  the stored hits into a storage buffer;
//   postprocess    per hit the compressed (|dp|^-3/4), smoothed (s, or 5 for specular-only
//                  paths) and clamped (r_max) semi-axes, the skewed ellipsoid and its box, Table
//                  3's radius histogram; the footprint areas summed and T_auto (§4.3, §5.3, §7);
//   build          the toolkit's box BVH over the footprints' boxes (photonbench/toolkit/box_bvh.h:
//                  30-bit Morton codes, its stable radix sort, runs of equal codes as leaves, the
//                  radix tree over the runs, bottom-up boxes, §5.2, §6.2), and the counts of the
//                  tree the query walks, nodes of at most T hits fused into leaves (§5.3);
//   query          per G-buffer sample the toolkit's point walk with leaf size T, Eq. 1's sum in
//                  its any-hit hook, radiance albedo / pi x E.
// README.md gives the parameters, every choice the paper leaves open, the deviations and the
// measured figures. When it fails: large footprints (high s, r_max, sparse photons) make queries
// slow and blur, and a query walk is cut at llvmpipe's loop limit (counted, warned).
#include "photonbench/toolkit/technique.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "differential_rules.h"
#include "footprint.h"
#include "photon-differentials_shaders.h"
#include "photonbench/error.h"
#include "photonbench/plugin.h"
#include "photonbench/scene_layout.h"
#include "photonbench/toolkit/box_bvh.h"

namespace {

using pb::gpu::Binding;
namespace tk = pb::toolkit;

// c of T_auto, measured (README "Measured": on cornell-box the fastest fixed T were 16 and 64 in
// two rounds, where c = 1 gave T_auto = 303 and half their speed; 0.15 puts T_auto at about 45).
constexpr double kTAutoConstant = 0.15;

// The choices of the enumerated parameters, in their declared order.
enum class CompressionBase : uint32_t { differential, semiaxis };
enum class Kernel : uint32_t { uniform, epanechnikov };

// Every parameter of a cell: the toolkit's shared rows (all but `radius`: every footprint has its
// own), the footprint post-processing's (footprint.h, whose initialisers the unit tests use) and
// the technique's own.
struct PdParams : tk::PhotonParams, pd::PostProcess {
  CompressionBase compression_base;
  Kernel kernel;
  bool normal_gate;
  uint32_t leaf_threshold;
  double t_auto_constant;  // compared with its default in check(), as given
  float surface_area;
  bool caustics;
  bool first_hit_roulette;
  bool verify;
};

constexpr auto kParams = pb::params(
    pb::bind(tk::kPhotonsParam, pb::base_field<PdParams>(&tk::PhotonParams::paths)),
    pb::bind(tk::with_range(tk::kMaxBouncesParam, 3, 2, 31,
                            "surface interactions per light path; photons are stored at hits 2 to "
                            "max_bounces (seed 003 §7: two indirect bounces, so 3)"),
             pb::base_field<PdParams>(&tk::PhotonParams::max_bounces)),
    pb::param("smoothing", pb::base_field<PdParams>(&pd::PostProcess::smoothing), 5, {0.01, 1000},
              "",
              "s: every semi-axis of a diffusely reflected photon's footprint times s (Table 2: 10 "
              "to 60 per scene; 5 puts k_PD on cornell-box in Table 2's range)"),
    pb::param("smoothing_specular", pb::base_field<PdParams>(&pd::PostProcess::smoothing_specular),
              5, {0.01, 1000}, "",
              "s for photons with only specular interactions before the hit (§7: 5, sharp "
              "caustics)"),
    pb::param("compression_exponent", pb::base_field<PdParams>(&pd::PostProcess::exponent), -0.75,
              {-2, 1}, "",
              "e of the nonlinear compression: each semi-axis of a diffusely reflected photon "
              "times |dp|^e (§4.3: -3/4; 0: none)"),
    pb::param("compression_base", &PdParams::compression_base, CompressionBase::differential,
              "differential|semiaxis",
              "what |.|^e is taken of: the positional differential dp (§4.3, literally) or the "
              "semi-axis Delta dp"),
    pb::param("r_max", pb::base_field<PdParams>(&pd::PostProcess::r_max), 0.7, {1e-4, 100}, "m",
              "each semi-axis clamped to this length (§7: 0.7 in every scene)"),
    pb::param(
        "normal_extent", pb::base_field<PdParams>(&pd::PostProcess::normal_extent), 0.5, {0.01, 10},
        "",
        "the ellipsoid's semi-axis along the hit's normal, times sqrt(|a1| |a2|) "
        "(unspecified in §4; 0.5: README's sweep, a quarter of 1's excess at concave corners)"),
    pb::param("kernel", &PdParams::kernel, Kernel::uniform, "uniform|epanechnikov",
              "K of Eq. 1, normalised by the footprint's area pi |a1 x a2| (Fig. 4: both)"),
    pb::param("normal_gate", &PdParams::normal_gate, true,
              "leave out photons arriving from behind the query's surface (unspecified)"),
    pb::param("leaf_threshold", &PdParams::leaf_threshold, 0, {0, 65536}, "hits",
              "T: nodes of at most T hits are leaves (Table 1 sweeps 1 to 512); 0: T_auto"),
    pb::param("t_auto_constant", &PdParams::t_auto_constant, kTAutoConstant, {1e-4, 1e4}, "",
              "c of T_auto = c sum(footprint areas) / surface area (§5.3 gives none; README: the "
              "sweep)"),
    pb::param("surface_area", &PdParams::surface_area, 0, {0, 1e9}, "m^2",
              "the scene's surface area for T_auto; 0: the area the light's first hits cover, from "
              "their differentials, each frame"),
    pb::param("caustics", &PdParams::caustics, false,
              "also store L S+ D photons (the paper's one map; the technique's class is then more "
              "than `indirect`, so only the combined score is fair)"),
    pb::param("first_hit_roulette", &PdParams::first_hit_roulette, false,
              "Russian roulette at the first hit too, as §4.2 plays it (whenever a photon meets a "
              "surface); false: from the second hit on, the first scaling the flux by the albedo "
              "(README: why false)"),
    pb::bind(tk::kStoreFirstHitParam, pb::base_field<PdParams>(&tk::PhotonParams::store_first_hit)),
    pb::param("verify", &PdParams::verify, false,
              "test hook: read the BVH back and check it, and check sampled queries against a "
              "brute-force sum over every footprint (counters bvh_violations, query_mismatches)"),
    pb::bind(tk::kShadowMapSizeParam,
             pb::base_field<PdParams>(&tk::PhotonParams::shadow_map_size)));
// The post-processing keeps its initialisers (the unit tests build it whole): they must be the
// declaration's defaults.
static_assert(static_cast<const pd::PostProcess&>(kParams.defaults()) == pd::PostProcess{});

// ---- Counters (README.md, "Counters"). Table 3's semi-axis histogram's bins are the last.
// clang-format off
#define PD_BIN(name) {"radius_" name, PB_COUNTER_WORK, "semi-axes", "Table 3's semi-axis bins"}
constexpr auto kCounters = pb::counters({
    {"hits", PB_COUNTER_SIZE, "hits", "photon hits in the map"},
    {"leaf_threshold", PB_COUNTER_SIZE, "hits", "T used this frame (cell.json params_resolved)"},
    {"t_auto", PB_COUNTER_SIZE, "hits", "T_auto of this frame"},
    {"morton_runs", PB_COUNTER_SIZE, "runs", "distinct Morton codes (the leaves before fusion)"},
    {"bvh_nodes", PB_COUNTER_SIZE, "nodes", "inner nodes plus the leaves below them, after fusion"},
    {"bvh_inner_nodes", PB_COUNTER_SIZE, "nodes", "nodes of more than T hits"},
    {"bvh_leaves", PB_COUNTER_SIZE, "nodes", "leaves (runs and fused nodes)"},
    {"queries", PB_COUNTER_WORK, "samples", "G-buffer samples on diffuse surfaces queried"},
    {"hits_tested", PB_COUNTER_WORK, "hits", "footprints tested in the leaves the queries reached"},
    {"hits_contributing", PB_COUNTER_WORK, "hits", "footprints that contained their query point"},
    {"nodes_visited", PB_COUNTER_WORK, "nodes", "nodes whose box contained the query point"},
    {"nodes_fetched", PB_COUNTER_WORK, "nodes",
     "nodes the queries read (popped), boxes tested or not"},
    {"bytes_read_per_query", PB_COUNTER_RATIO, "bytes",
     "records a query reads: (nodes_fetched 48 + hits_tested (4 + 96: item index and footprint)) "
     "/ queries"},
    {"hits_per_query", PB_COUNTER_RATIO, "hits", "hits_contributing / queries (Table 2's k_PD)"},
    {"hits_tested_per_query", PB_COUNTER_RATIO, "hits", "hits_tested / queries"},
    {"truncated_queries", PB_COUNTER_WORK, "samples", "queries cut short by the loop budget"},
    {"footprints_degenerate", PB_COUNTER_WORK, "hits", "footprints dropped as singular"},
    {"semiaxes_clamped", PB_COUNTER_WORK, "semi-axes", "semi-axes clamped to r_max"},
    {"long_runs", PB_COUNTER_WORK, "runs", "runs longer than the loop budget"},
    {"footprint_area", PB_COUNTER_SIZE, "m^2", "sum of the footprints' areas pi |a1 x a2|"},
    {"surface_area", PB_COUNTER_SIZE, "m^2", "the surface area T_auto used (params_resolved)"},
    {"bytes_total", PB_COUNTER_SIZE, "bytes", "GPU memory of the technique's buffers"},
    {"bytes_bvh", PB_COUNTER_SIZE, "bytes",
     "the BVH's buffers, sort and scan scratch, and the footprints in its order"},
    {"bvh_violations", PB_COUNTER_WORK, "checks",
     "verify: BVH invariants broken (footprint.h check_bvh), footprints out of its order"},
    {"query_mismatches", PB_COUNTER_WORK, "samples",
     "verify: sampled queries off the brute-force sum"},
    {"query_checked", PB_COUNTER_WORK, "samples", "verify: sampled queries compared"},
    {"footprints_off", PB_COUNTER_WORK, "footprints",
     "verify: GPU footprints off footprint.h's make_footprint"},
    {"totals_off", PB_COUNTER_WORK, "totals",
     "verify: area sum, T_auto, histogram bins off the CPU's"},
    tk::kPhotonsStoredCounter,
    tk::kBytesPhotonsCounter,
    PD_BIN("0p00_0p05"), PD_BIN("0p05_0p10"), PD_BIN("0p10_0p15"), PD_BIN("0p15_0p20"),
    PD_BIN("0p20_0p25"), PD_BIN("0p25_0p30"), PD_BIN("0p30_0p35"), PD_BIN("0p35_0p40"),
    PD_BIN("0p40_0p45"), PD_BIN("0p45_0p50"), PD_BIN("0p50_0p55"), PD_BIN("0p55_0p60"),
    PD_BIN("0p60_0p65"), PD_BIN("0p65_0p70"), PD_BIN("0p70_0p75"), PD_BIN("0p75_0p80"),
    PD_BIN("0p80_0p85"), PD_BIN("0p85_0p90"), PD_BIN("0p90_0p95"), PD_BIN("0p95_1p00"),
    PD_BIN("above_1p00"),
});
#undef PD_BIN
// clang-format on
// The histogram's first bin, in the table's order.
constexpr size_t kFirstRadiusBin = &kCounters["radius_0p00_0p05"] - kCounters.specs;
static_assert(kFirstRadiusBin + PD_RADIUS_BINS == kCounters.size());

constexpr uint32_t kGroup = 256;

class PhotonDifferentials final : public pb::Technique {
 public:
  static std::string check(const pb::Params& params) {
    const PdParams p = kParams.read(params);
    if (p.leaf_threshold > 0 && p.t_auto_constant != kTAutoConstant)
      return fmt::format(
          "t_auto_constant: {} has no effect with leaf_threshold = {} (a fixed T; 0 for T_auto)",
          p.t_auto_constant, p.leaf_threshold);
    if (p.caustics && p.store_first_hit)
      return "store_first_hit: goes with caustics = false only (the closed-form check of direct "
             "light)";
    return "";
  }

  void setup(pb::Context& ctx, const pb::Params& params) override {
    const PdParams p = kParams.read(params);
    pb::toolkit::configure_direct_light(ctx, params);
    photon_ = p;
    tk::configure_shadows(ctx, photon_.shadow_map_size);
    post_ = p;
    post_.compress_semiaxis = p.compression_base == CompressionBase::semiaxis;
    epanechnikov_ = p.kernel == Kernel::epanechnikov;
    normal_gate_ = p.normal_gate;
    fixed_threshold_ = p.leaf_threshold;
    t_constant_ = float(p.t_auto_constant);
    surface_area_param_ = p.surface_area;
    verify_ = p.verify;

    // First hits give the lit surface area (T_auto) and are dropped before the upload, unless the
    // test hook keeps them in the map.
    settings_ = pd::differential_trace_settings(photon_.trace_settings(), differential_rules_,
                                                p.first_hit_roulette);
    if (p.caustics) settings_.store |= pb::trace::kCausticPhotons;

    pb::gpu::Device& gpu = ctx.gpu();
    width_ = ctx.output().extent().width, height_ = ctx.output().extent().height;
    radiance_ = gpu.create_image("photon-differentials/radiance", {width_, height_},
                                 vk::Format::eR32G32B32A32Sfloat, vk::ImageUsageFlagBits::eStorage);
    control_ = tk::storage_buffer(gpu, "photon-differentials/control", PD_CTL_WORDS * 4,
                                  pb::gpu::Memory::host_visible);
    // The verify hook reads the BVH on the host: its buffers are host-visible then.
    bvh_.setup(gpu, "photon-differentials/bvh", /* host_readable */ verify_);
    std::vector<Binding> bindings(10, Binding::storage_buffer);  // pd_common.glsl's
    bindings.insert(bindings.end(), 4, Binding::storage_image);
    auto make = [&](const char* name, std::span<const uint32_t> spirv) {
      return gpu.create_compute_pipeline(std::string("photon-differentials/") + name, spirv,
                                         bindings, sizeof(pd::PdPush));
    };
    postprocess_ = make("postprocess", kpd_postprocess_comp_spv);
    reduce_ = make("reduce", kpd_reduce_comp_spv);
    tree_ = make("tree", kpd_tree_comp_spv);
    query_ = make("query", kpd_query_comp_spv);
    reserve(ctx, 1024);
  }

  void render(pb::Context& ctx) override {
    uint32_t count = 0;
    {
      auto scope = ctx.pass("photon-trace");
      ctx.photon_tracer().trace(settings_, batch_);
      // The first hits' differential parallelograms |Delta dp_u x Delta dp_v| are the surface
      // each emitted photon covers where it lands: summed, the area the light sees.
      lit_area_ = 0;
      kept_.clear();
      for (const pb::trace::PhotonRecord& p : batch_.photons) {
        if (p.bounce == 0) {
          lit_area_ += glm::length(glm::cross(p.footprint_u, p.footprint_v));
          if (!photon_.store_first_hit) continue;
        }
        kept_.push_back(&p - batch_.photons.data());
      }
      count = uint32_t(kept_.size());
    }
    {
      auto scope = ctx.pass("photon-upload");
      reserve(ctx, count);
      auto* out = static_cast<pb::trace::PhotonRecord*>(photons_.mapped());
      for (uint32_t i = 0; i < count; ++i) out[i] = batch_.photons[kept_[i]];
    }
    ctx.shared().gbuffer();
    ctx.shared().direct_light();

    const float surface = surface_area_param_ > 0 ? surface_area_param_ : float(lit_area_);
    pd::PdPush push{};
    push.count = count;
    push.groups = pb::gpu::groups_for(count, kGroup);
    push.width = width_, push.height = height_;
    push.smoothing = post_.smoothing;
    push.smoothing_specular = post_.smoothing_specular;
    push.exponent = post_.exponent;
    push.r_max = post_.r_max;
    push.normal_extent = post_.normal_extent;
    push.flags = (post_.compress_semiaxis ? PD_FLAG_COMPRESS_SEMIAXIS : 0u) |
                 (epanechnikov_ ? PD_FLAG_EPANECHNIKOV : 0u) |
                 (normal_gate_ ? PD_FLAG_NORMAL_GATE : 0u);
    push.surface_area = surface;
    push.t_constant = t_constant_;
    push.fixed_threshold = fixed_threshold_;
    push.budget = PB_LOOP_BUDGET;
    const pb::GBuffer g = ctx.shared().gbuffer_images();
    const auto walk = bvh_.walk_resources(boxes_);
    const std::vector<pb::gpu::Resource> resources = {
        &photons_, &footprints_, &boxes_, &control_,  &partials_, &sorted_, walk[0],
        walk[1],   walk[2],      walk[3], g.position, g.normal,   g.albedo, &radiance_};
    auto dispatch = [&](vk::CommandBuffer cmd, const pb::gpu::Pipeline& pipeline, uint32_t groups) {
      if (groups == 0) return;
      pipeline.bind(cmd, std::span<const pb::gpu::Resource>(resources), push);
      cmd.dispatch(groups, 1, 1);
      pb::gpu::full_barrier(cmd);
    };
    const uint32_t groups = push.groups;
    {
      auto scope = ctx.pass("postprocess");
      vk::CommandBuffer cmd = ctx.cmd();
      cmd.fillBuffer(control_.handle(), 0, VK_WHOLE_SIZE, 0u);
      pb::gpu::full_barrier(cmd);
      cmd.fillBuffer(control_.handle(), 0, 3 * sizeof(uint32_t), 0xffffffffu);
      pb::gpu::full_barrier(cmd);
      dispatch(cmd, postprocess_, groups);
      dispatch(cmd, reduce_, 1);
    }
    {
      // The toolkit's build over the boxes (barriers inside and after), then the footprints in
      // its order and the counts of the tree as the query walks it with leaf size T.
      auto scope = ctx.pass("build");
      vk::CommandBuffer cmd = ctx.cmd();
      bvh_.record_build(cmd, boxes_, count);
      dispatch(cmd, tree_, groups);
    }
    {
      auto scope = ctx.pass("query");
      vk::CommandBuffer cmd = ctx.cmd();
      query_.bind(cmd, std::span<const pb::gpu::Resource>(resources), push);
      cmd.dispatch(pb::gpu::groups_for(width_, 8), pb::gpu::groups_for(height_, 8), 1);
      pb::gpu::full_barrier(cmd);
    }
    ctx.shared().shade(&radiance_);
    ctx.flush();
    report(ctx, count, surface);
  }

 private:
  // Buffers for `count` hits (grown by half again when short; before any of the frame's work is
  // recorded, since recorded work refers to the old ones).
  void reserve(pb::Context& ctx, uint32_t count) {
    if (count <= capacity_ && photons_) return;
    capacity_ = std::max<uint32_t>(1024, std::max(count, capacity_ + capacity_ / 2));
    pb::gpu::Device& gpu = ctx.gpu();
    const uint64_t n = capacity_;
    // The verify hook reads the boxes and footprints on the host: host-visible then.
    const auto readable = verify_ ? pb::gpu::Memory::host_visible : pb::gpu::Memory::device_local;
    auto buffer = [&](const char* name, uint64_t bytes, pb::gpu::Memory memory) {
      tk::check_storage_range(gpu, bytes, fmt::format("photon-differentials: {} hits", count));
      return tk::storage_buffer(gpu, std::string("photon-differentials/") + name, bytes, memory);
    };
    photons_ =
        buffer("photons", n * sizeof(pb::trace::PhotonRecord), pb::gpu::Memory::host_visible);
    footprints_ = buffer("footprints", n * sizeof(pd::PdFootprint), readable);
    boxes_ = buffer("boxes", n * sizeof(pd::BvhBox), readable);
    sorted_ = buffer("sorted-footprints", n * sizeof(pd::PdFootprint), readable);
    partials_ = buffer("partials", uint64_t(pb::gpu::groups_for(capacity_, kGroup)) * 4,
                       pb::gpu::Memory::device_local);
    bvh_.reserve(capacity_);
  }

  uint64_t bytes_total() const {
    uint64_t b = bvh_.bytes() + control_.size() + radiance_.bytes();
    for (const pb::gpu::Buffer* x : {&photons_, &footprints_, &boxes_, &sorted_, &partials_})
      b += x->size();
    return b;
  }

  void report(pb::Context& ctx, uint32_t count, float surface) {
    const uint32_t* c = static_cast<const uint32_t*>(control_.mapped());
    auto wide = [&](uint32_t at) { return double(c[at]) + double(c[at + 1]) * 4294967296.0; };
    const pb::toolkit::BoxBvh::Stats bvh = bvh_.read_stats();
    const uint32_t runs = bvh.leaves;
    uint32_t inner = c[PD_CTL_INNER], leaves = c[PD_CTL_LEAVES];
    if (inner == 0 && runs > 0) leaves = 1;  // the root alone, a leaf
    const double queries = c[PD_CTL_QUERIES];
    pb::count(ctx, kCounters["hits"], count);
    pb::count(ctx, tk::kPhotonsStoredCounter, double(batch_.photons.size()));
    pb::count(ctx, tk::kBytesPhotonsCounter, double(count) * sizeof(pb::trace::PhotonRecord));
    pb::count(ctx, kCounters["leaf_threshold"], c[PD_CTL_THRESHOLD]);
    pb::count(ctx, kCounters["t_auto"], c[PD_CTL_T_AUTO]);
    pb::count(ctx, kCounters["morton_runs"], runs);
    pb::count(ctx, kCounters["bvh_nodes"], double(inner) + leaves);
    pb::count(ctx, kCounters["bvh_inner_nodes"], inner);
    pb::count(ctx, kCounters["bvh_leaves"], leaves);
    pb::count(ctx, kCounters["queries"], queries);
    pb::count(ctx, kCounters["hits_tested"], wide(PD_CTL_TESTED));
    pb::count(ctx, kCounters["hits_contributing"], wide(PD_CTL_CONTRIBUTING));
    pb::count(ctx, kCounters["nodes_visited"], wide(PD_CTL_NODES_VISITED));
    pb::count(ctx, kCounters["nodes_fetched"], wide(PD_CTL_NODES_FETCHED));
    pb::count(ctx, kCounters["bytes_read_per_query"],
              queries > 0 ? (wide(PD_CTL_NODES_FETCHED) * sizeof(pd::BvhNode) +
                             wide(PD_CTL_TESTED) * (sizeof(uint32_t) + sizeof(pd::PdFootprint))) /
                                queries
                          : 0.0);
    pb::count(ctx, kCounters["hits_per_query"],
              queries > 0 ? wide(PD_CTL_CONTRIBUTING) / queries : 0.0);
    pb::count(ctx, kCounters["hits_tested_per_query"],
              queries > 0 ? wide(PD_CTL_TESTED) / queries : 0.0);
    pb::count(ctx, kCounters["truncated_queries"], c[PD_CTL_TRUNCATED]);
    pb::count(ctx, kCounters["footprints_degenerate"], c[PD_CTL_DEGENERATE]);
    pb::count(ctx, kCounters["semiaxes_clamped"], c[PD_CTL_CLAMPED]);
    pb::count(ctx, kCounters["long_runs"], bvh.long_runs);
    pb::count(ctx, kCounters["footprint_area"],
              count > 0 ? std::bit_cast<float>(c[PD_CTL_AREA]) : 0.0);
    pb::count(ctx, kCounters["surface_area"], surface);
    pb::count(ctx, kCounters["bytes_total"], double(bytes_total()));
    pb::count(ctx, kCounters["bytes_bvh"], double(bvh_.bytes() + sorted_.size()));
    for (uint32_t b = 0; b < PD_RADIUS_BINS; ++b)
      pb::count(ctx, kCounters.specs[kFirstRadiusBin + b], c[PD_CTL_HISTOGRAM + b]);
    if (c[PD_CTL_TRUNCATED] > 0)
      ctx.warn(fmt::format("photon-differentials: {} queries cut short by the loop budget",
                           c[PD_CTL_TRUNCATED]));
    if (bvh.long_runs > 0)
      ctx.warn(fmt::format("photon-differentials: {} Morton runs longer than the loop budget",
                           bvh.long_runs));
    size_t violations = 0, mismatches = 0, checked = 0, footprints_off = 0, totals_off = 0;
    if (verify_ && count > 0) {
      verify(ctx, count, runs, violations, mismatches, checked);
      verify_postprocess(ctx, count, surface, footprints_off, totals_off);
    }
    pb::count(ctx, kCounters["bvh_violations"], double(violations));
    pb::count(ctx, kCounters["query_mismatches"], double(mismatches));
    pb::count(ctx, kCounters["query_checked"], double(checked));
    pb::count(ctx, kCounters["footprints_off"], double(footprints_off));
    pb::count(ctx, kCounters["totals_off"], double(totals_off));
  }

  // The verify hook's second half: the GPU's post-processing (pd_postprocess.comp) against the
  // CPU's footprint.h on the photons uploaded this frame, every footprint record (semi-axes
  // compressed, smoothed and clamped, the ellipsoid's inverse, area, flux density); and the totals
  // of pd_postprocess.comp and pd_reduce.comp against CPU sums: the footprints' area, T_auto (§5.3)
  // and Table 3's histogram bins.
  void verify_postprocess(pb::Context& ctx, uint32_t count, float surface, size_t& footprints_off,
                          size_t& totals_off) {
    const auto* footprints = static_cast<const pd::PdFootprint*>(footprints_.mapped());
    const uint32_t* c = static_cast<const uint32_t*>(control_.mapped());
    auto near = [](float got, float want, float scale) {
      return std::abs(got - want) <= 1e-4f * scale + 1e-12f;
    };
    auto near3 = [&](const glm::vec3& got, const glm::vec3& want) {
      const float scale = std::max(glm::length(want), glm::length(got));
      return near(got.x, want.x, scale) && near(got.y, want.y, scale) && near(got.z, want.z, scale);
    };
    std::vector<uint32_t> seen(count, 0), histogram(PD_RADIUS_BINS, 0);
    double area = 0;
    for (uint32_t j = 0; j < count; ++j) {
      const pd::PdFootprint& got = footprints[j];
      if (got.photon >= count || seen[got.photon]++ > 0) {
        ++footprints_off;
        continue;
      }
      const pb::trace::PhotonRecord& p = batch_.photons[kept_[got.photon]];
      glm::vec3 a1, a2;
      pd::scaled_semiaxes(p, post_, a1, a2);
      ++histogram[pd::radius_bin(glm::length(a1))];
      ++histogram[pd::radius_bin(glm::length(a2))];
      pd::PdFootprint want;
      pd::BvhBox box;
      if (pd::make_footprint(p, got.photon, post_, want, box)) area += want.area;
      const bool same = got.position == want.position && got.kind == want.kind &&
                        near(got.area, want.area, want.area) &&
                        near(got.radius_major, want.radius_major, want.radius_major) &&
                        near(got.radius_minor, want.radius_minor, want.radius_major) &&
                        near3(got.flux_density, want.flux_density) &&
                        near3(got.incoming, want.incoming) && near3(got.inverse0, want.inverse0) &&
                        near3(got.inverse1, want.inverse1) && near3(got.inverse2, want.inverse2);
      if (!same && footprints_off++ == 0)
        ctx.warn(fmt::format(
            "photon-differentials verify: footprint of photon {}: GPU area {} radii {} {}, "
            "footprint.h area {} radii {} {}",
            got.photon, got.area, got.radius_major, got.radius_minor, want.area, want.radius_major,
            want.radius_minor));
    }
    const double gpu_area = std::bit_cast<float>(c[PD_CTL_AREA]);
    if (std::abs(gpu_area - area) > 1e-4 * area) {
      ++totals_off;
      ctx.warn(
          fmt::format("photon-differentials verify: footprint area GPU {} CPU {}", gpu_area, area));
    }
    // T_auto from the CPU's sum, unless the GPU's float sum may round the other way (c sum / A
    // within 1e-4 of a half).
    const double t = surface > 0 ? double(t_constant_) * area / double(surface) : 0;
    const bool at_a_half = std::abs(t - std::floor(t) - 0.5) < 1e-4 * std::max(1.0, t);
    if (!at_a_half && c[PD_CTL_T_AUTO] != pd::t_auto(area, surface, t_constant_)) {
      ++totals_off;
      ctx.warn(fmt::format("photon-differentials verify: T_auto GPU {} CPU {}", c[PD_CTL_T_AUTO],
                           pd::t_auto(area, surface, t_constant_)));
    }
    for (uint32_t b = 0; b < PD_RADIUS_BINS; ++b)
      if (c[PD_CTL_HISTOGRAM + b] != histogram[b]) {
        if (totals_off++ == 0)
          ctx.warn(fmt::format("photon-differentials verify: radius bin {} GPU {} CPU {}", b,
                               c[PD_CTL_HISTOGRAM + b], histogram[b]));
      }
  }

  // The verify hook: the BVH's invariants (footprint.h check_bvh) and the query's copy of the
  // footprints in its order, and every 41st lit pixel's irradiance against the sum over every
  // footprint.
  void verify(pb::Context& ctx, uint32_t count, uint32_t runs, size_t& violations,
              size_t& mismatches, size_t& checked) {
    const auto* nodes = static_cast<const pd::BvhNode*>(bvh_.nodes().mapped());
    const auto* items = static_cast<const uint32_t*>(bvh_.items().mapped());
    const auto* boxes = static_cast<const pd::BvhBox*>(boxes_.mapped());
    const auto* footprints = static_cast<const pd::PdFootprint*>(footprints_.mapped());
    std::vector<pd::BvhNode> tree(nodes, nodes + (runs > 0 ? 2 * size_t(runs) - 1 : 0));
    std::vector<pd::BvhBox> sorted_boxes(count);
    for (uint32_t j = 0; j < count; ++j) sorted_boxes[j] = boxes[items[j]];
    std::string first;
    violations = pd::check_bvh(tree, runs, count, sorted_boxes, &first);
    // The query's copy of the footprints in the BVH's order (pd_tree.comp).
    const auto* sorted = static_cast<const pd::PdFootprint*>(sorted_.mapped());
    for (uint32_t j = 0; j < count; ++j)
      if (std::memcmp(&sorted[j], &footprints[items[j]], sizeof(pd::PdFootprint)) != 0 &&
          violations++ == 0)
        first = fmt::format("footprint {} of the BVH's order is not photon {}'s", j, items[j]);
    if (violations > 0) ctx.warn("photon-differentials verify: " + first);
    std::vector<float> position, normal, albedo, estimate;
    const pb::GBuffer g = ctx.shared().gbuffer_images();
    ctx.gpu().read_image(*g.position, position);
    ctx.gpu().read_image(*g.normal, normal);
    ctx.gpu().read_image(*g.albedo, albedo);
    ctx.gpu().read_image(radiance_, estimate);
    size_t lit = 0;
    for (size_t px = 0; px < size_t(width_) * height_; ++px) {
      const float* p = &position[4 * px];
      const float* a = &albedo[4 * px];
      int type = int(a[3]);
      if (p[3] <= 0 || !(type == PB_MATERIAL_DIFFUSE || type == PB_MATERIAL_EMISSIVE)) continue;
      if (lit++ % 41 != 0) continue;
      const glm::vec3 x(p[0], p[1], p[2]),
          n(normal[4 * px], normal[4 * px + 1], normal[4 * px + 2]);
      glm::vec3 e(0.f);
      for (uint32_t j = 0; j < count; ++j)
        e += pd::contribution(footprints[j], x, n, epanechnikov_, normal_gate_);
      for (int k = 0; k < 3; ++k) {
        const double expected = a[k] / pd::kPi * e[k], got = estimate[4 * px + k];
        if (std::abs(got - expected) > 1e-3 * std::abs(expected) + 1e-6) {
          if (mismatches == 0)
            ctx.warn(
                fmt::format("photon-differentials verify: pixel {} channel {}: query {}, "
                            "brute force {}",
                            px, k, got, expected));
          ++mismatches;
          break;
        }
      }
      ++checked;
    }
  }

  tk::PhotonParams photon_;
  pd::PostProcess post_;
  bool epanechnikov_ = false, normal_gate_ = true, verify_ = false;
  uint32_t fixed_threshold_ = 0;
  float t_constant_ = float(kTAutoConstant), surface_area_param_ = 0;
  double lit_area_ = 0;
  uint32_t width_ = 0, height_ = 0, capacity_ = 0;
  pb::trace::TraceSettings settings_;
  pd::DifferentialRules differential_rules_;  // the tracer policy of §4 (differential_rules.h)
  pb::trace::PhotonBatch batch_;
  std::vector<size_t> kept_;
  tk::BoxBvh bvh_;  // over boxes_, rebuilt every frame
  pb::gpu::Image radiance_;
  pb::gpu::Buffer photons_, footprints_, boxes_, sorted_, control_, partials_;
  pb::gpu::Pipeline postprocess_, reduce_, tree_, query_;
};

// The budget knobs (match: in a config): more light paths cost more to trace and build and lower
// the error; a larger smoothing s widens every footprint, so each query sums more of them (the
// query dominates the frame) and trades variance for bias.
const pb_budget_knob kBudget[] = {
    {"photons", PB_COST_GROWS, PB_ERROR_FALLS, PB_SCALE_LOG},
    {"smoothing", PB_COST_GROWS, PB_ERROR_MIXED, PB_SCALE_LOG},
};

}  // namespace

// The shared direct light's rows (the toolkit's: shadow maps or many-light next-event estimation,
// seed 002 Papers III and IV) after the technique's own.
constexpr auto kSchema = pb::join_rows(kParams, pb::toolkit::kDirectLightParams);

PB_EXPORT_TECHNIQUE(PhotonDifferentials, "photon-differentials", "indirect",
                    "photon differentials (seed 003): per-hit ellipsoidal footprints, a linear "
                    "BVH photon map built on the GPU each frame, a query summing every footprint "
                    "containing the point",
                    kSchema.rows, .counters = kCounters.specs, .check = &PhotonDifferentials::check,
                    .budget = kBudget)
