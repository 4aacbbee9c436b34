// tiled: Paper I's version of Mara et al.'s tiled photon splatting (Moreau et al. 2016, §5.1; Mara,
// Luebke & McGuire 2013), the baseline the cluster hierarchy is measured against. Per frame:
// photons traced on the CPU (every diffuse hit but the first, Paper I §4.2) and uploaded; after the
// shared G-buffer and direct light, 32x32 tiles get view-depth bounds, each photon's sphere is
// binned into the lists of the tiles it may touch (count, prefix sum, insert, consistency check),
// and each pixel sums the photons of its tile's list whose sphere contains it (L = f I / (pi r^2),
// §4.4). The passes are pb::toolkit::TiledSplat (harness/toolkit/); README.md gives them and the
// deviations.
#include "photonbench/toolkit/technique.h"

#include "photonbench/plugin.h"
#include "photonbench/toolkit/tiled_splat.h"

namespace {

using namespace pb::toolkit;

using Tiled = SplatTechnique<TiledSplat>;

}  // namespace

PB_EXPORT_TECHNIQUE(
    Tiled, "tiled", "indirect",
    "Paper I's tiled photon splatting (Mara et al. 2013): 32x32 tiles with depth bounds, "
    "per-tile photon lists, constant-kernel radiance estimate",
    Tiled::kSchema.rows, .counters = Tiled::kCounters, .check = &Tiled::check,
    .budget = kSplatBudgetKnobs)
