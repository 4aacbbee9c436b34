// Paper I's photon splatting with the view-sample cluster hierarchy (§4) as a Splatter, in three
// variants: plain, cone (normal-cone rejection, §4.5) and trivial (per-node flux for photons that
// enclose a node and arrive above all its samples, §4.6). Passes: cluster-build (the Hierarchy),
// splat/{top, regroup, count, prefix-sum, insert, check}, radiance-estimate. Shaders:
// harness/shaders/toolkit/cluster/. techniques/cluster/README.md describes it and its deviations.
#pragma once

#include "photonbench/toolkit/fixed_point.h"
#include "photonbench/toolkit/gpu_scan.h"
#include "photonbench/toolkit/hierarchy.h"
#include "photonbench/toolkit/jobs.h"
#include "photonbench/toolkit/node_flux.h"
#include "photonbench/toolkit/photon_lists.h"
#include "photonbench/toolkit/technique.h"
#include "photonbench/toolkit/traversal.h"

namespace pb::toolkit {

class ClusterSplat final : public Splatter {
 public:
  static constexpr const char* kName = "cluster";
  enum Variant : uint32_t { kPlain = 0, kCone = 1, kTrivial = 2 };
  struct Options {
    Variant variant;
    HierarchyLayout layout;
    uint32_t top_levels;
    uint32_t max_jobs;
    uint32_t max_list_entries;
    float insert_radius_scale;  // the test hook kListCheckHookParam
    uint32_t loop_budget;
    bool profile;
  };
  // clang-format off
  static constexpr auto kParams = pb::params(
      pb::param("variant", &Options::variant, kPlain, "plain|cone|trivial",
                "plain; cone: normal-cone rejection (Paper I §4.5); trivial: cone + per-node flux "
                "(§4.6)"),
      pb::bind(kLayoutParam, &Options::layout),
      pb::bind(kTopLevelsParam, &Options::top_levels),
      pb::bind(kMaxJobsParam, &Options::max_jobs),
      pb::param("max_list_entries", &Options::max_list_entries, 1 << 22, {1, 1 << 25}, "entries",
                "capacity of all per-node photon lists together; overflowing entries are dropped "
                "and counted (list_overflows)"),
      pb::bind(kListCheckHookParam, &Options::insert_radius_scale),
      pb::bind(kLoopBudgetParam, &Options::loop_budget),
      pb::bind(kProfileParam, &Options::profile));
  static constexpr pb_counter_spec kTrivialAcceptsCounter = {
      "trivial_accepts", PB_COUNTER_WORK, "nodes", "photon-node flux adds (variant trivial)"};
  static constexpr pb_counter_spec kConeRejectsCounter = {
      "cone_rejects", PB_COUNTER_WORK, "nodes",
      "nodes skipped by the normal-cone test (variants cone, trivial)"};
  static constexpr pb_counter_spec kHierarchyNodesCounter = {
      "hierarchy_nodes", PB_COUNTER_SIZE, "nodes", "occupied nodes of every level"};
  static constexpr pb_counter_spec kHierarchyLeavesCounter = {
      "hierarchy_leaves", PB_COUNTER_SIZE, "nodes", "occupied leaves"};
  static constexpr pb_counter_spec kBytesNormalConeCounter = {
      "bytes_normal_cone", PB_COUNTER_SIZE, "bytes", "the nodes' normal cones"};
  // clang-format on
  static constexpr auto kCounters = join_counters(
      kPhotonListsCounters, kJobQueueCounters,
      std::array{kTruncatedTraversalsCounter, kPhotonsReadCounter, kPhotonsRejectedCounter,
                 kTrivialAcceptsCounter, kConeRejectsCounter, kHierarchyNodesCounter,
                 kHierarchyLeavesCounter, kBytesClusterHierarchyCounter, kBytesFinalBoundsCounter,
                 kBytesNormalConeCounter, kBytesAccumFluxCounter, kBytesPhotonListsCounter},
      PB_TOOLKIT_PROFILE_COUNTERS("top"), PB_TOOLKIT_PROFILE_COUNTERS("count"),
      PB_TOOLKIT_PROFILE_COUNTERS("insert"));
  static std::string check(const Params&) { return ""; }

  void setup(Context& ctx, const Params& params, const PhotonParams& photon) override;
  const gpu::Image& render(Context& ctx, const PhotonSet& photons) override;
  void report(Context& ctx, const PhotonSet& photons) override;
  const Hierarchy& hierarchy() const { return hierarchy_; }

 private:
  void ensure_resources(Context& ctx);

  Options options_ = kParams.defaults();
  float radius_ = 0;
  uint32_t top_levels_ = 3;  // top_levels, at most the level above the leaves
  Hierarchy hierarchy_;
  PrefixSum scan_;
  JobQueue jobs_;
  PhotonLists lists_;
  PassProfile profile_;
  NodeFlux node_flux_;
  gpu::Buffer stats_;
  gpu::Image indirect_;
  gpu::Pipeline top_pipeline_, leaf_pipeline_, estimate_pipeline_;
};

}  // namespace pb::toolkit
