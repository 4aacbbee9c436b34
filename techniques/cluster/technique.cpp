// cluster: Paper I's photon splatting with a view-sample cluster hierarchy (Moreau et al. 2016,
// §4), in three variants: plain, cone (normal-cone rejection, §4.5) and trivial (per-node flux for
// photons that enclose a node and arrive above all its samples, §4.6). Per frame: photons traced
// exactly as `tiled` does (same settings and seed, so the two splat the same photons); after the
// shared G-buffer and direct light the hierarchy is rebuilt (cluster-build), the top pass walks
// each photon down 3 levels emitting (photon, node) jobs, the jobs are sorted by node, and the leaf
// passes run twice (count, prefix sum, insert, check; §4.3); the estimate walks each sample's leaf
// and ancestors (L = f I / (pi r^2), §4.4). The passes are pb::toolkit::ClusterSplat
// (harness/toolkit/); README.md gives them and the deviations.
#include "photonbench/toolkit/technique.h"

#include "photonbench/plugin.h"
#include "photonbench/toolkit/cluster_splat.h"

namespace {

using namespace pb::toolkit;

using Cluster = SplatTechnique<ClusterSplat>;

}  // namespace

PB_EXPORT_TECHNIQUE(
    Cluster, "cluster", "indirect",
    "Paper I's photon splatting into a view-sample cluster hierarchy: per-node photon lists; "
    "variants plain, cone (normal-cone rejection) and trivial (per-node flux)",
    Cluster::kSchema.rows, .counters = Cluster::kCounters, .check = &Cluster::check,
    .budget = kSplatBudgetKnobs)
