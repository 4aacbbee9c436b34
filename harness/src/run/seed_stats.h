// The seed axis' per-pixel statistics (`seeds: K` > 1): for every group of K cells that differ
// only in their seed (Cell::seed_group) and every metric frame and scored class, the mean and the
// variance of the K images, and a Z-test of the mean against the reference (metrics/z_test.h: does
// the technique converge to the reference, or is it biased?). The per-metric spread across seeds
// is the tools' (tools/pbtools/seeds.py), from each cell's metrics.csv.
//
//   RUN/seeds/<group>/mean_NNNN_<class>.exr       the mean of the K images (linear)
//   RUN/seeds/<group>/variance_NNNN_<class>.exr   their unbiased per-pixel variance S^2
//   RUN/seeds/<group>/stddev_NNNN_<class>.png     sqrt(S^2) / (mean + 0.01), magma, 0..1: where the
//                                                  technique's noise is, relative to the signal
//   RUN/seeds/<group>/seeds.json                  scene, technique, params, seeds, cells, and per
//                                                  frame and class the Z-test (z_test.h's fields)
//   RUN/seeds.json                                 {"alpha", "groups": [<group>, ...]}
#pragma once

#include <filesystem>

#include "plan/plan.h"

namespace pb::run {

// The family-wise level of every Z-test a run writes.
inline constexpr double kSeedZTestAlpha = 0.01;

// Writes the files above for every group whose K cells are all complete and ok (others are listed
// in RUN/seeds.json "incomplete", with the reason); nothing when the plan has no seed axis.
// Reference images come from the cache the cells were scored with.
void write_seed_statistics(const RunPlan& plan, const std::filesystem::path& run_dir);

}  // namespace pb::run
