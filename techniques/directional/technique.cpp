// directional: Paper I's directional approximation (Moreau et al. 2016, §4.7, §5.1, §5.2): photons
// splatted into the view-sample cluster hierarchy accumulate their flux per node, from the
// accumulation level (one above the leaves, Paper I's "level 4") up, in eight direction buckets
// (the octants of the incident direction in view space) instead of per-node lists; each view sample
// sums its containing nodes' buckets weighted by 2cos(n, d) into an irradiance texture, which a
// depth- and normal-aware blur smooths before the diffuse BRDF. The splat runs in Paper I's two
// sub-passes: a top pass per photon down 3 levels, then per-node jobs sorted by node. The passes
// are pb::toolkit::DirectionalSplat (harness/toolkit/); README.md gives them and the deviations.
#include "photonbench/toolkit/technique.h"

#include "photonbench/plugin.h"
#include "photonbench/toolkit/directional_splat.h"

namespace {

using namespace pb::toolkit;

using Directional = SplatTechnique<DirectionalSplat>;

}  // namespace

PB_EXPORT_TECHNIQUE(
    Directional, "directional", "indirect",
    "Paper I's directional approximation: photons splatted into the view-sample cluster hierarchy "
    "accumulate flux per node in 8 view-space octant buckets; per-sample 2cos-weighted irradiance, "
    "depth- and normal-aware blur",
    Directional::kSchema.rows, .counters = Directional::kCounters, .check = &Directional::check,
    .budget = kSplatBudgetKnobs)
