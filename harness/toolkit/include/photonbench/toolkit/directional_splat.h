// Paper I's directional approximation (§4.7, §5.1, §5.2) as a Splatter: photons splatted into the
// view-sample cluster hierarchy accumulate flux per node in eight view-space octant buckets from
// the accumulation level ("level 4", one above the leaves) up, instead of per-node lists; per view
// sample the containing nodes' buckets weighted by 2cos(n, d) give irradiance; a depth- and
// normal-aware blur smooths it before the diffuse BRDF. The splat runs in Paper I's two sub-passes:
// a top pass per photon down `top_levels` levels, then per-node jobs (sorted by node) down to the
// stop level. Passes: cluster-build, splat/{leaf-counts, top, regroup, deposit}, radiance-estimate,
// blur. Shaders: harness/shaders/toolkit/directional/. techniques/directional/README.md describes
// it.
#pragma once

#include "photonbench/toolkit/fixed_point.h"
#include "photonbench/toolkit/gpu_scan.h"
#include "photonbench/toolkit/hierarchy.h"
#include "photonbench/toolkit/jobs.h"
#include "photonbench/toolkit/node_flux.h"
#include "photonbench/toolkit/technique.h"
#include "photonbench/toolkit/traversal.h"

namespace pb::toolkit {

class DirectionalSplat final : public Splatter {
 public:
  static constexpr const char* kName = "directional";
  enum class Deposit : uint32_t { kCoverage, kPaper };
  enum class Weighting : uint32_t { kCos2, kClip };
  enum class AccumulateAt : uint32_t { kAccumulation, kLeaves };
  enum class DebugIrradiance : uint32_t { kPhotons, kNormal };
  struct Options {
    Deposit deposit;
    Weighting weighting;
    HierarchyLayout layout;
    AccumulateAt accumulate_at;
    uint32_t top_levels;
    uint32_t max_jobs;
    int32_t blur_radius;  // -1: automatic
    float blur_depth_sigma;
    float blur_normal_sigma;
    uint32_t loop_budget;
    bool profile;
    DebugIrradiance debug_irradiance;
  };
  // clang-format off
  static constexpr auto kParams = pb::params(
      pb::param("deposit", &Options::deposit, Deposit::kCoverage, "coverage|paper",
                "flux an intersected (not enclosed) stop-level node receives: coverage = the "
                "photon's flux times the share of the node's leaf clusters inside its sphere; "
                "paper = the whole flux"),
      pb::param("weighting", &Options::weighting, Weighting::kCos2, "cos2|clip",
                "octant weight at a sample: cos2 = Paper I's max(0, 2cos(n, d)); clip = share of "
                "the octant above the tangent plane (the correction Paper I describes and "
                "approximates)"),
      pb::bind(kLayoutParam, &Options::layout),
      pb::param("accumulate_at", &Options::accumulate_at, AccumulateAt::kAccumulation,
                "accumulation|leaves",
                "lowest level with buckets: accumulation = one above the leaves (Paper I's level "
                "4, default); leaves = the leaf clusters (finer, Paper I §5.2 sizes buckets down "
                "to them)"),
      pb::bind(kTopLevelsParam, &Options::top_levels),
      pb::bind(kMaxJobsParam, &Options::max_jobs),
      pb::param("blur_radius", &Options::blur_radius, -1, {-1, 64}, "pixels",
                "taps on each side of the separable depth/normal-aware blur; 0 turns the blur off; "
                "-1 (default) = half the screen side of a stop-level node (16 for the 32-pixel "
                "accumulation level)"),
      pb::param("blur_depth_sigma", &Options::blur_depth_sigma, 0.02, {1e-6, 1e6}, "",
                "blur depth awareness: distance from the tangent plane, relative to the camera "
                "distance"),
      pb::param("blur_normal_sigma", &Options::blur_normal_sigma, 0.2, {1e-6, 1e6}, "rad",
                "blur normal awareness: angle between the normals"),
      pb::bind(kLoopBudgetParam, &Options::loop_budget),
      pb::bind(kProfileParam, &Options::profile),
      pb::param("debug_irradiance", &Options::debug_irradiance, DebugIrradiance::kPhotons,
                "photons|normal",
                "test hook: normal = irradiance is |world normal| instead of the photon estimate "
                "(checks that the blur keeps surfaces apart)"));
  static constexpr pb_counter_spec kNodeDepositsCounter = {
      "node_deposits", PB_COUNTER_WORK, "deposits", "bucket adds (64-bit exact)"};
  static constexpr pb_counter_spec kPhotonsMissedCounter = {
      "photons_missed", PB_COUNTER_WORK, "photons",
      "photons whose sphere met no occupied node: no deposit, no job"};
  static constexpr pb_counter_spec kBytesLeafCountsCounter = {
      "bytes_leaf_counts", PB_COUNTER_SIZE, "bytes", "the coverage weights"};
  // The blur's taps: blur_radius as set, or what -1 (automatic) resolved to. A counter named as a
  // parameter is its resolved value: the harness records it in cell.json's params_resolved.
  static constexpr pb_counter_spec kBlurRadiusCounter = {
      "blur_radius", PB_COUNTER_SIZE, "pixels",
      "the blur's taps on each side: blur_radius, or what -1 resolved to"};
  // clang-format on
  static constexpr auto kCounters = join_counters(
      kJobQueueCounters,
      std::array{kNodeDepositsCounter, kPhotonsMissedCounter, kTruncatedTraversalsCounter,
                 kBytesClusterHierarchyCounter, kBytesFinalBoundsCounter, kBytesAccumFluxCounter,
                 kBytesLeafCountsCounter, kBlurRadiusCounter},
      PB_TOOLKIT_PROFILE_COUNTERS("top"), PB_TOOLKIT_PROFILE_COUNTERS("deposit"));
  static std::string check(const Params&) { return ""; }

  void setup(Context& ctx, const Params& params, const PhotonParams& photon) override;
  const gpu::Image& render(Context& ctx, const PhotonSet& photons) override;
  void report(Context& ctx, const PhotonSet& photons) override;
  const Hierarchy& hierarchy() const { return hierarchy_; }

 private:
  void ensure_resources(Context& ctx);
  uint32_t stop_level() const;

  Options options_ = kParams.defaults();
  float radius_ = 0;
  int32_t blur_taps_ = 0;  // blur_radius as resolved
  uint32_t flags_ = 0, top_levels_ = 3, width_ = 0, height_ = 0;
  Hierarchy hierarchy_;
  PrefixSum scan_;
  JobQueue jobs_;
  PassProfile profile_;
  NodeFlux flux_;
  gpu::Buffer leaf_counts_, stats_;
  gpu::Image irradiance_, blur_tmp_, indirect_;
  gpu::Pipeline leaf_counts_pipeline_, top_pipeline_, deposit_pipeline_, estimate_pipeline_,
      blur_pipeline_;
};

}  // namespace pb::toolkit
