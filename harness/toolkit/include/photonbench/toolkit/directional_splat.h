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
  // clang-format off
  static constexpr pb_param_spec kDepositParam = {
      "deposit", PB_PARAM_ENUM, 0, 0, 1, "coverage|paper", "",
      "flux an intersected (not enclosed) stop-level node receives: coverage = the photon's flux "
      "times the share of the node's leaf clusters inside its sphere; paper = the whole flux"};
  static constexpr pb_param_spec kWeightingParam = {
      "weighting", PB_PARAM_ENUM, 0, 0, 1, "cos2|clip", "",
      "octant weight at a sample: cos2 = Paper I's max(0, 2cos(n, d)); clip = share of the octant "
      "above the tangent plane (the correction Paper I describes and approximates)"};
  static constexpr pb_param_spec kAccumulateAtParam = {
      "accumulate_at", PB_PARAM_ENUM, 0, 0, 1, "accumulation|leaves", "",
      "lowest level with buckets: accumulation = one above the leaves (Paper I's level 4, "
      "default); leaves = the leaf clusters (finer, Paper I §5.2 sizes buckets down to them)"};
  static constexpr pb_param_spec kBlurRadiusParam = {
      "blur_radius", PB_PARAM_INT, -1, -1, 64, nullptr, "pixels",
      "taps on each side of the separable depth/normal-aware blur; 0 turns the blur off; -1 "
      "(default) = half the screen side of a stop-level node (16 for the 32-pixel accumulation "
      "level)"};
  static constexpr pb_param_spec kBlurDepthSigmaParam = {
      "blur_depth_sigma", PB_PARAM_FLOAT, 0.02, 1e-6, 1e6, nullptr, "",
      "blur depth awareness: distance from the tangent plane, relative to the camera distance"};
  static constexpr pb_param_spec kBlurNormalSigmaParam = {
      "blur_normal_sigma", PB_PARAM_FLOAT, 0.2, 1e-6, 1e6, nullptr, "rad",
      "blur normal awareness: angle between the normals"};
  static constexpr pb_param_spec kDebugIrradianceParam = {
      "debug_irradiance", PB_PARAM_ENUM, 0, 0, 1, "photons|normal", "",
      "test hook: normal = irradiance is |world normal| instead of the photon estimate (checks "
      "that the blur keeps surfaces apart)"};
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

  float radius_ = 0, blur_depth_sigma_ = 0.02f, blur_normal_sigma_ = 0.2f;
  int32_t blur_radius_ = -1, blur_taps_ = 0;  // as set (-1: automatic); as resolved
  uint32_t flags_ = 0, top_levels_ = 3, budget_ = PB_LOOP_BUDGET, width_ = 0, height_ = 0;
  bool at_leaves_ = false;
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
