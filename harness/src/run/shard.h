// Sharding a run: `run CONFIG --shard I/N` runs the I-th of N disjoint subsets of the config's
// cells, balanced by an estimate of what each cell costs; `merge` (run/merge.h) joins the N run
// folders into one. The split depends only on the cells (their ids and configs), so every shard of
// one config, on any machine, computes the same split without talking to the others.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "plan/plan.h"

namespace pb::run {

// Shard `index` of `count`, 1-based ("2/4"); count 0 is the whole run, unsharded.
struct ShardSpec {
  uint32_t index = 0;
  uint32_t count = 0;
  bool sharded() const { return count > 0; }
  std::string text() const;  // "2/4"
};

// "I/N" with 1 <= I <= N; pb::InputError otherwise, naming --shard and the text.
ShardSpec parse_shard(const std::string& text);

// A cell's estimated cost, in seconds of the machine the constants were measured on (a loaded
// 2-core machine, lavapipe: only the ratios between cells mean anything, and only they matter to
// the split). It reads only what the config says of the cell:
//   start-up   a child process, the device, the scene and the technique's setup;
//   frames     (warm-up + measured) x (pixels x a + paths x b + paths x pixels x c), the light
//              paths being the sum of the cell's parameters whose unit is "paths" (photon paths
//              traced per frame: `photons` of tiled, cluster and directional; 0 for direct);
//   scoring    metric frames x pixels x the reference classes scored (combined and the
//              technique's own, each again against a bounce-matched reference when the config
//              asks for them).
// The constants are fitted to measured cells (docs/architecture.md, Sharding). References are not
// in it: they are rendered once per scene and frame into the shared cache.
double estimate_cell_cost(const config::Config& config, const Cell& cell, PluginRegistry& plugins);

// Longest processing time first (Graham 1969): the cells in decreasing cost, ties by id, each to
// the shard with the least cost so far, ties to the lower shard. Returns the shard (0-based) of
// each cell, by the cells' order. Deterministic, and independent of the order of the input.
std::vector<uint32_t> assign_shards(const std::vector<std::string>& ids,
                                    const std::vector<double>& costs, uint32_t count);

// The cells of one shard, in the plan's order, with the estimated cost of each.
struct ShardSelection {
  std::vector<Cell> cells;
  std::vector<double> costs;       // per cell of `cells`
  double shard_cost = 0;           // the sum over `cells`
  double total_cost = 0;           // the sum over every cell of the plan
  std::vector<std::string> every;  // every cell id of the plan, in its order
  // This shard's part of the whole plan's estimated cost, 0..1.
  double share() const { return total_cost > 0 ? shard_cost / total_cost : 0; }
};
ShardSelection select_shard(const RunPlan& plan, const ShardSpec& shard);

// run.json's "shard": index, count, this shard's cells and share of the estimated cost, every
// cell of the plan (what merge checks the shards against), the host and, under Slurm, the job and
// array task.
nlohmann::json describe_shard(const ShardSpec& shard, const ShardSelection& selection);

// `--resume` of a shard must name the same shard it started as; pb::InputError otherwise.
void check_resumed_shard(const std::filesystem::path& run_dir, const ShardSpec& shard);

}  // namespace pb::run
