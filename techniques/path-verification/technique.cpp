// path-verification: Paper II (Moreau, Sintorn et al., "Path Verification for Dynamic Indirect
// Illumination") on Paper I's splatting engine. Light paths are kept from frame to frame; each
// frame the segments of the kept paths are tested against what moved (dynamic-occlusion) and only
// the invalid parts are re-traced (photon-trace), by one of the paper's three variants:
//   none: the baseline, every path traced afresh every frame;
//   naive (§3.2): a path is re-traced from its first segment that touches a moved object's box;
//   error_based (§3.3, Algorithm 1): a visibility ray along each suspect segment; a hit that moved
//     is kept while the reflected energy stays within T (Eq. 2) of the original.
// The photons are then laid out bounce-major (§4) and splatted by one of Paper I's splatters (the
// toolkit's TiledSplat, ClusterSplat or DirectionalSplat: `splatter`). README.md gives the passes,
// the data layout, the deviations and what was measured.
#include "photonbench/toolkit/technique.h"

#include <fmt/format.h>

#include <array>
#include <cstring>
#include <memory>
#include <string>

#include "distribution_map.h"
#include "path_layout.h"
#include "photonbench/error.h"
#include "photonbench/plugin.h"
#include "photonbench/toolkit/cluster_splat.h"
#include "photonbench/toolkit/directional_splat.h"
#include "photonbench/toolkit/hierarchy.h"
#include "photonbench/toolkit/jobs.h"
#include "photonbench/toolkit/photon_lists.h"
#include "photonbench/toolkit/tiled_splat.h"
#include "photonbench/toolkit/traversal.h"

namespace {

using namespace pb;
using namespace pb::toolkit;
using pathverification::LayoutBytes;
using pathverification::PathInfo;
using pathverification::PhotonMap;

// Its own parameters (Paper II), beside the toolkit's photon rows and every splatter's.
enum class SplatterName : uint32_t { kTiled, kCluster, kDirectional };
enum class Reuse : uint32_t { kNone, kNaive, kErrorBased };
struct VerificationParams {
  SplatterName splatter;
  Reuse reuse;
  float energy_threshold;
  bool light_reuse;
  uint32_t dm_position_cells;
  uint32_t dm_direction_cells;
  uint32_t max_photons_per_path;
};
// clang-format off
constexpr auto kVerificationParams = pb::params(
    pb::param("splatter", &VerificationParams::splatter, SplatterName::kTiled,
              "tiled|cluster|directional",
              "Paper I splatter the photons go through (Paper II builds on Paper I's engine); each "
              "reads its own rows below"),
    pb::param("reuse", &VerificationParams::reuse, Reuse::kErrorBased, "none|naive|error_based",
              "none: the baseline, every path re-traced each frame; naive: re-trace from the first "
              "segment a moved object's box touches (§3.2); error_based: Algorithm 1 with "
              "energy_threshold (§3.3)"),
    pb::param("energy_threshold", &VerificationParams::energy_threshold, 0.001, {0, 1}, "",
              "T of Eq. 2: a moved hit is kept while the reflected energy differs from the "
              "original by at most this fraction in every channel (Paper II's experiments: 0.1%)"),
    pb::param("light_reuse", &VerificationParams::light_reuse, true,
              "keep the paths of a moved light by moving their origins (§3.1), with the "
              "distribution maps' prune and fill; false: re-emit a moved light's paths whole "
              "(Table 1's 'reuse obj.')"),
    pb::param("dm_position_cells", &VerificationParams::dm_position_cells, 8, {1, 1024}, "cells",
              "distribution-map cells along each position axis of an area light (Figs. 7/8: 8)"),
    pb::param("dm_direction_cells", &VerificationParams::dm_direction_cells, 64, {1, 4096},
              "cells",
              "distribution-map cells along each direction axis (Figs. 7/8: 64; point and spot "
              "lights have only these two)"),
    pb::param("max_photons_per_path", &VerificationParams::max_photons_per_path, 7, {1, 16},
              "photons",
              "rows of the bounce-major photon map (Paper II: 7); max_bounces - 1 may not exceed "
              "it"));
// clang-format on

// The toolkit's photon rows, max_bounces at most the 15 segments the path-information word holds
// (4 bits, Paper II §4).
constexpr auto kPathPhotonParams = kPhotonParams.with_row(
    with_range(kMaxBouncesParam, kMaxBouncesParam.default_value, kMaxBouncesParam.min_value,
               pathverification::PathInfo::kMaxSegments,
               "surface interactions per light path; photons are stored at hits 2 to max_bounces "
               "(Paper I §4.2); at most 15, the segments a path-information word holds (Paper II "
               "§4)"));

// `max_list_entries` is one key for the two list splatters: tiled's row (to 2^28; cluster's own
// stops at 2^25), the device's storage range refusing a capacity the splatter cannot hold.
constexpr auto kClusterParams =
    ClusterSplat::kParams.with_row(TiledSplat::kParams.row("max_list_entries"));

// The photon rows, its own, the splatters' (each reads only its own; rows two splatters share are
// listed once), then the shared direct light's.
constexpr auto kSchema =
    pb::merge_rows<kPathPhotonParams, kVerificationParams, TiledSplat::kParams, kClusterParams,
                   DirectionalSplat::kParams, pb::toolkit::kDirectLightParams>();

// The counters of the reuse steps (Paper II Figs. 7 and 8) and of the data layout (Table 1).
// clang-format off
constexpr auto kVerificationCounters = pb::counters({
    {"paths_kept", PB_COUNTER_WORK, "paths", "paths with no segment re-traced"},
    {"paths_moved", PB_COUNTER_WORK, "paths", "error_based: kept with a vertex or an origin moved"},
    {"paths_retraced", PB_COUNTER_WORK, "paths", "paths re-traced from a segment or whole"},
    {"rays_traced", PB_COUNTER_WORK, "rays", "every ray: re-traced segments plus visibility rays"},
    {"segments_retraced", PB_COUNTER_WORK, "rays", "re-traced segments"},
    {"visibility_rays", PB_COUNTER_WORK, "rays",
     "the reuse steps' rays that are not re-traced segments"},
    {"full_retrace_rays", PB_COUNTER_WORK, "rays",
     "the segments of this frame's paths (tracing all)"},
    {"paths_pruned", PB_COUNTER_WORK, "paths", "paths the prune removed (Eq. 1)"},
    {"paths_refilled", PB_COUNTER_WORK, "paths", "paths the fill emitted into under-full cells"},
    {"dm_distance", PB_COUNTER_RATIO, "paths",
     "total-variation distance of DM_C from DM_T after the fill"},
    {"bytes_path_information", PB_COUNTER_SIZE, "bytes", "one word per path (§4)"},
    {"bytes_path_origins", PB_COUNTER_SIZE, "bytes", "the kept paths' origins"},
    {"bytes_distribution_maps", PB_COUNTER_SIZE, "bytes", "DM_T and DM_C of every light"},
    {"bytes_pruned_paths", PB_COUNTER_SIZE, "bytes", "the pruned-paths array"},
    {"bytes_photon_map", PB_COUNTER_SIZE, "bytes", "the bounce-major photon map (ours, compacted)"},
    {"bytes_photon_map_paper", PB_COUNTER_SIZE, "bytes",
     "the paper's fixed layout at this path count"},
});
// clang-format on

// The stored photons, its own counters, then every splatter's (each cell emits its splatter's
// alone).
constexpr auto kCounters =
    join_counters(std::array{kPhotonsStoredCounter}, std::to_array(kVerificationCounters.specs),
                  TiledSplat::kCounters, ClusterSplat::kCounters, DirectionalSplat::kCounters);

std::unique_ptr<Splatter> make_splatter(SplatterName name) {
  switch (name) {
    case SplatterName::kTiled:
      return std::make_unique<TiledSplat>();
    case SplatterName::kCluster:
      return std::make_unique<ClusterSplat>();
    case SplatterName::kDirectional:
      break;
  }
  return std::make_unique<DirectionalSplat>();
}

class PathVerification final : public Technique {
 public:
  // The parameters together: the photon map's rows, the path-information word, and the chosen
  // splatter's own rows.
  static std::string check(const Params& params) {
    const PhotonParams photon = kPathPhotonParams.read(params);
    const VerificationParams verification = kVerificationParams.read(params);
    // Photons are stored at hits 2..max_bounces (Paper I §4.2), one row per stored photon.
    const uint32_t stored = photon.max_bounces - (photon.store_first_hit ? 0 : 1);
    const uint32_t rows = verification.max_photons_per_path;
    if (stored > rows)
      return fmt::format(
          "max_bounces: {} stores up to {} photons per path, more than max_photons_per_path = {}",
          photon.max_bounces, stored, rows);
    const uint64_t d = verification.dm_direction_cells;
    const uint64_t p = verification.dm_position_cells;
    if (std::string limits =
            pathverification::check_packing_limits(photon.max_bounces, d * d * p * p);
        !limits.empty())
      return limits;
    switch (verification.splatter) {
      case SplatterName::kTiled:
        return TiledSplat::check(params);
      case SplatterName::kCluster:
        return ClusterSplat::check(params);
      case SplatterName::kDirectional:
        break;
    }
    return DirectionalSplat::check(params);
  }

  void setup(Context& ctx, const Params& params) override {
    photon_ = kPathPhotonParams.read(params);
    verification_ = kVerificationParams.read(params);
    pb::toolkit::configure_direct_light(ctx, params);
    reuse_enabled_ = verification_.reuse != Reuse::kNone;
    reuse_.rule = verification_.reuse == Reuse::kNaive ? trace::ReuseRule::naive
                                                       : trace::ReuseRule::error_based;
    reuse_.energy_threshold = verification_.energy_threshold;
    reuse_.update_origins = verification_.light_reuse;
    settings_ = photon_.trace_settings();
    // Every variant traces the same sample sequence each frame (the paths keep the seed they were
    // first traced with), so that on a static scene the baseline's photons are the reuse's.
    settings_.seed_per_frame = false;
    settings_.keep_light_paths = true;
    configure_shadows(ctx, photon_.shadow_map_size);
    splatter_ = make_splatter(verification_.splatter);
    splatter_->setup(ctx, params, photon_);
  }

  void render(Context& ctx) override {
    trace::PhotonTracer& tracer = ctx.photon_tracer();
    trace::TraceStats stats;
    uint64_t pruned = 0, refilled = 0;
    if (!reuse_enabled_ || batch_.paths.empty()) {
      auto scope = ctx.pass("photon-trace");
      stats = tracer.trace(settings_, batch_);
      stats.paths_retraced = stats.paths;
      stats.segments_retraced = stats.rays;
      stats.full_retrace_rays = stats.rays;
      if (reuse_enabled_)
        maps_.setup(batch_, verification_.dm_position_cells, verification_.dm_direction_cells);
    } else {
      // Paper II §4's order: origins and DM_C in one step, then the occlusion tests (they need
      // the new origins), then prune and fill, then the tracing of what they scheduled.
      const bool light_reuse = reuse_.update_origins;
      {
        auto scope = ctx.pass("update-origins");
        tracer.update_origins(settings_, reuse_, batch_);
        if (light_reuse) {
          auto dm = ctx.pass("compute-dm");
          maps_.compute(batch_);
        }
      }
      {
        auto scope = ctx.pass("dynamic-occlusion");
        tracer.verify_paths(settings_, reuse_, batch_);
      }
      if (light_reuse) {
        {
          auto scope = ctx.pass("prune");
          pruned = maps_.prune(batch_, ctx.frame().index, pruned_paths_);
        }
        auto scope = ctx.pass("fill");
        refilled = maps_.fill(batch_, ctx.frame().index, pruned_paths_);
      }
      auto scope = ctx.pass("photon-trace");
      stats = tracer.retrace_marked(settings_, batch_);
    }
    {
      auto scope = ctx.pass("photon-upload");
      pack_path_information();
      photon_map_.build(batch_, verification_.max_photons_per_path);
      upload_photon_map(ctx);
    }
    PhotonSet set{&photons_, photon_map_.records};
    ctx.shared().gbuffer();
    ctx.shared().direct_light();
    const gpu::Image& indirect = splatter_->render(ctx, set);
    gpu::full_barrier(ctx.cmd());
    ctx.shared().shade(&indirect);
    ctx.flush();  // the splatter's counters live on the GPU
    splatter_->report(ctx, set);
    report(ctx, stats, pruned, refilled);
  }

 private:
  // One path-information word per path (§4), from the verdict of this frame's verification.
  void pack_path_information() {
    const auto& paths = batch_.paths.paths;
    path_info_.resize(paths.size());
    for (size_t i = 0; i < paths.size(); ++i) {
      const trace::LightPath& path = paths[i];
      PathInfo info;
      if (!maps_.empty()) info.cell = maps_.maps()[path.light].cell_of(path);
      info.segments = pathverification::path_segments(path, batch_.paths.vertices);
      info.replace = reuse_enabled_ && path.restart != trace::LightPath::kKeep;
      info.reuse_light = path.restart != trace::LightPath::kReemit;
      info.restart_segment = info.replace && info.reuse_light ? path.restart : 0;
      path_info_[i] = info.pack();
    }
  }

  void upload_photon_map(Context& ctx) {
    const auto& records = photon_map_.records;
    const uint64_t bytes =
        uint64_t(std::max<size_t>(records.size(), 1)) * sizeof(trace::PhotonRecord);
    // Grown with a quarter to spare, so a photon count that drifts does not reallocate each frame.
    if (!photons_ || photons_.size() < bytes)
      photons_ = ctx.gpu().create_buffer("path-verification/photon-map", bytes + bytes / 4,
                                         vk::BufferUsageFlagBits::eStorageBuffer,
                                         gpu::Memory::host_visible);
    if (!records.empty())
      std::memcpy(photons_.mapped(), records.data(), records.size() * sizeof(records[0]));
  }

  void report(Context& ctx, const trace::TraceStats& stats, uint64_t pruned, uint64_t refilled) {
    pb::count(ctx, kPhotonsStoredCounter, double(batch_.photons.size()));
    pb::count(ctx, kVerificationCounters["paths_kept"], double(stats.paths - stats.paths_retraced));
    pb::count(ctx, kVerificationCounters["paths_moved"], double(stats.paths_moved));
    pb::count(ctx, kVerificationCounters["paths_retraced"], double(stats.paths_retraced));
    pb::count(ctx, kVerificationCounters["rays_traced"], double(stats.rays));
    pb::count(ctx, kVerificationCounters["segments_retraced"], double(stats.segments_retraced));
    pb::count(ctx, kVerificationCounters["visibility_rays"], double(stats.visibility_rays));
    pb::count(ctx, kVerificationCounters["full_retrace_rays"], double(stats.full_retrace_rays));
    if (reuse_enabled_ && reuse_.update_origins) {
      pb::count(ctx, kVerificationCounters["paths_pruned"], double(pruned));
      pb::count(ctx, kVerificationCounters["paths_refilled"], double(refilled));
      // DM_C against DM_T after this frame's fill: the total-variation distance of all lights.
      double distance = 0, weight = 0;
      for (const auto& m : maps_.maps()) {
        double paths = 0;
        for (float t : m.target) paths += t;
        distance += m.distance() * paths, weight += paths;
      }
      pb::count(ctx, kVerificationCounters["dm_distance"], weight > 0 ? distance / weight : 0);
    }
    LayoutBytes bytes = layout_bytes();
    pb::count(ctx, kVerificationCounters["bytes_path_information"], double(bytes.path_information));
    pb::count(ctx, kVerificationCounters["bytes_path_origins"], double(bytes.path_origins));
    pb::count(ctx, kVerificationCounters["bytes_distribution_maps"],
              double(bytes.distribution_maps));
    pb::count(ctx, kVerificationCounters["bytes_pruned_paths"], double(bytes.pruned_paths));
    pb::count(ctx, kVerificationCounters["bytes_photon_map"], double(bytes.photon_map));
    pb::count(ctx, kVerificationCounters["bytes_photon_map_paper"], double(bytes.photon_map_paper));
  }

  LayoutBytes layout_bytes() const {
    LayoutBytes b;
    const uint64_t paths = batch_.paths.paths.size();
    if (reuse_enabled_) {
      b.path_information = paths * sizeof(uint32_t);
      // Area lights' paths keep their origin (3 floats; a point light's is the light's own).
      for (const auto& path : batch_.paths.paths)
        if (batch_.paths.vertices[path.first_vertex].normal != glm::vec3(0.f))
          b.path_origins += 3 * sizeof(float);
    }
    if (reuse_enabled_ && reuse_.update_origins) {
      for (const auto& m : maps_.maps()) b.distribution_maps += 2 * uint64_t(m.cells()) * 4;
      b.pruned_paths = paths * sizeof(uint32_t);  // capacity: every path may be pruned
    }
    b.photon_map = uint64_t(photon_map_.records.size()) * sizeof(trace::PhotonRecord);
    b.photon_map_paper = paths * verification_.max_photons_per_path * 32;  // §4's 32-byte record
    return b;
  }

  PhotonParams photon_;
  trace::TraceSettings settings_;
  trace::ReuseSettings reuse_;
  VerificationParams verification_ = kVerificationParams.defaults();
  bool reuse_enabled_ = true;
  std::unique_ptr<Splatter> splatter_;
  trace::PhotonBatch batch_;
  std::vector<uint32_t> path_info_;
  pathverification::DistributionMaps maps_;
  std::vector<uint32_t> pruned_paths_;
  PhotonMap photon_map_;
  gpu::Buffer photons_;
};

}  // namespace

PB_EXPORT_TECHNIQUE(
    PathVerification, "path-verification", "indirect",
    "Paper II's path verification: light paths kept across frames, re-validated against moving "
    "objects (none | naive | error_based reuse) and splatted by a Paper I splatter",
    kSchema.rows, .counters = kCounters, .check = &PathVerification::check,
    .budget = kSplatBudgetKnobs)
