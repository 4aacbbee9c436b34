// Sharding (run/shard.h): the I/N syntax, the longest-processing-time split (deterministic,
// independent of input order, within Graham's bound of the best split), and the cost estimate's
// dependence on what a cell's config says.
#include "run/shard.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>

#include "photonbench/error.h"
#include "plan_scratch.h"

namespace pb::run {
namespace shard_test {

namespace fs = std::filesystem;

TEST(Shard, ParsesIOfN) {
  const ShardSpec spec = parse_shard("2/4");
  EXPECT_EQ(spec.index, 2u);
  EXPECT_EQ(spec.count, 4u);
  EXPECT_EQ(spec.text(), "2/4");
  EXPECT_EQ(parse_shard("1/1").count, 1u);
  for (const char* bad : {"0/4", "5/4", "2", "2/", "/4", "a/4", "2/b", "-1/4", "2/4/1", " 2/4", ""})
    EXPECT_THROW(parse_shard(bad), InputError) << bad;
  try {
    parse_shard("3/2");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--shard: '3/2'"), std::string::npos) << e.what();
  }
}

// The makespan: the largest shard's total cost.
double makespan(const std::vector<double>& costs, const std::vector<uint32_t>& shard_of,
                uint32_t count) {
  std::vector<double> load(count, 0.0);
  for (size_t i = 0; i < costs.size(); ++i) load.at(shard_of[i]) += costs[i];
  return *std::max_element(load.begin(), load.end());
}

TEST(Shard, LongestFirstToTheLightestShard) {
  // Sorted a5 b4 c3 d3 e3: a -> 1st, b -> 2nd, c -> 2nd (4 < 5), d -> 1st (5 < 7), e -> 2nd (7 <
  // 8).
  const std::vector<std::string> ids = {"a", "b", "c", "d", "e"};
  const std::vector<double> costs = {5, 4, 3, 3, 3};
  EXPECT_EQ(assign_shards(ids, costs, 2), (std::vector<uint32_t>{0, 1, 1, 0, 1}));
  // Equal costs go in id order, each to the lowest of the equally loaded shards.
  EXPECT_EQ(assign_shards({"c", "a", "b"}, {1, 1, 1}, 2), (std::vector<uint32_t>{0, 0, 1}));
  // More shards than cells: the extra shards are empty.
  EXPECT_EQ(assign_shards({"x", "y"}, {1, 2}, 4), (std::vector<uint32_t>{1, 0}));
}

TEST(Shard, SplitDoesNotDependOnTheOrderOfTheCells) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> cost(1, 100);
  std::vector<std::string> ids;
  std::vector<double> costs;
  for (int i = 0; i < 40; ++i) {
    ids.push_back("cell" + std::to_string(i));
    costs.push_back(i % 5 == 0 ? 10.0 : cost(rng));  // some equal costs: the tie-break matters
  }
  const std::vector<uint32_t> split = assign_shards(ids, costs, 6);
  std::vector<size_t> order(ids.size());
  std::iota(order.begin(), order.end(), size_t(0));
  for (int round = 0; round < 5; ++round) {
    std::shuffle(order.begin(), order.end(), rng);
    std::vector<std::string> shuffled_ids;
    std::vector<double> shuffled_costs;
    for (size_t i : order) shuffled_ids.push_back(ids[i]), shuffled_costs.push_back(costs[i]);
    const std::vector<uint32_t> again = assign_shards(shuffled_ids, shuffled_costs, 6);
    for (size_t k = 0; k < order.size(); ++k) EXPECT_EQ(again[k], split[order[k]]) << ids[order[k]];
  }
}

TEST(Shard, WithinGrahamsBoundOfTheBestSplit) {
  // LPT's makespan is at most (4/3 - 1/(3m)) of the optimum (Graham 1969); the optimum of 9 cells
  // on 3 shards by trying all 3^9 splits.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> cost(1, 50);
  for (int instance = 0; instance < 20; ++instance) {
    const uint32_t m = 3;
    std::vector<std::string> ids;
    std::vector<double> costs;
    for (int i = 0; i < 9; ++i) ids.push_back(std::to_string(i)), costs.push_back(cost(rng));
    double best = 1e300;
    std::vector<uint32_t> split(costs.size());
    for (int code = 0; code < 19683; ++code) {
      for (int i = 0, c = code; i < 9; ++i, c /= 3) split[i] = uint32_t(c % 3);
      best = std::min(best, makespan(costs, split, m));
    }
    const double lpt = makespan(costs, assign_shards(ids, costs, m), m);
    EXPECT_LE(lpt, (4.0 / 3.0 - 1.0 / (3.0 * m)) * best + 1e-9) << "instance " << instance;
    EXPECT_GE(lpt, best - 1e-9);
  }
}

// A config in a scratch folder, with the build's plugins.
struct Scratch : testing::PlanScratch {
  Scratch() : PlanScratch("shard_test") {}
};

const char* kSweep = R"(name: t
resolution: [320, 180]
frames: {warmup: 2, count: 8, metrics_every: 4}
scenes: [cornell-box]
techniques:
  - technique: direct
    params: {shadow_map_size: [64, 1024]}
  - technique: tiled
    params: {photons: [10000, 160000], tile_size: [16, 32]}
)";

double cost_of(const RunPlan& plan, const std::string& technique,
               const std::map<std::string, std::string>& params) {
  for (const Cell& cell : plan.cells) {
    bool match = cell.technique == technique;
    for (const auto& [k, v] : params) match = match && cell.params.at(k) == v;
    if (match) return estimate_cell_cost(plan.config, cell, *plan.plugins);
  }
  ADD_FAILURE() << "no such cell";
  return 0;
}

TEST(Shard, CostGrowsWithPixelsFramesPathsAndScoring) {
  const Scratch scratch;
  const RunPlan plan = scratch.plan(kSweep);
  // Light paths are the parameters whose unit is "paths"; others (texels, pixels) do not count.
  const double few = cost_of(plan, "tiled", {{"photons", "10000"}, {"tile_size", "32"}});
  const double many = cost_of(plan, "tiled", {{"photons", "160000"}, {"tile_size", "32"}});
  const double direct = cost_of(plan, "direct", {{"shadow_map_size", "64"}});
  EXPECT_GT(many, few);
  EXPECT_GT(few, direct);
  EXPECT_EQ(cost_of(plan, "tiled", {{"photons", "10000"}, {"tile_size", "16"}}), few);
  EXPECT_EQ(cost_of(plan, "direct", {{"shadow_map_size", "1024"}}), direct);

  const auto direct_with = [&](const std::vector<std::string>& overrides) {
    return cost_of(scratch.plan(kSweep, overrides), "direct", {{"shadow_map_size", "64"}});
  };
  EXPECT_GT(direct_with({"resolution=[640,360]"}), direct);
  EXPECT_GT(direct_with({"frames.count=16"}), direct);
  EXPECT_GT(direct_with({"frames.metrics_every=1"}), direct);  // 8 metric frames, not 2
  EXPECT_LT(direct_with({"frames.metrics_every=0"}), direct);  // none scored
}

TEST(Shard, ShardsPartitionThePlanInItsOrder) {
  const Scratch scratch;
  const RunPlan plan = scratch.plan(kSweep);
  ASSERT_EQ(plan.cells.size(), 6u);
  std::vector<std::string> seen;
  double sum = 0;
  for (uint32_t i = 1; i <= 4; ++i) {
    const ShardSelection shard = select_shard(plan, {i, 4});
    EXPECT_EQ(shard.every.size(), plan.cells.size());
    // In the plan's order, as an unsharded run would run them.
    for (size_t k = 1; k < shard.cells.size(); ++k) {
      const auto at = [&](const Cell& c) {
        return std::find_if(plan.cells.begin(), plan.cells.end(),
                            [&](const Cell& p) { return p.id == c.id; }) -
               plan.cells.begin();
      };
      EXPECT_LT(at(shard.cells[k - 1]), at(shard.cells[k]));
    }
    for (const Cell& cell : shard.cells) seen.push_back(cell.id);
    sum += shard.shard_cost;
    // Another plan of the same config, as another machine makes it, splits the same way.
    const ShardSelection again = select_shard(scratch.plan(kSweep), {i, 4});
    ASSERT_EQ(again.cells.size(), shard.cells.size());
    for (size_t k = 0; k < shard.cells.size(); ++k) EXPECT_EQ(again.cells[k].id, shard.cells[k].id);
  }
  std::sort(seen.begin(), seen.end());
  EXPECT_EQ(std::adjacent_find(seen.begin(), seen.end()), seen.end()) << "a cell in two shards";
  EXPECT_EQ(seen.size(), plan.cells.size());
  EXPECT_NEAR(sum, select_shard(plan, {}).total_cost, 1e-9);
  // The two costly tiled cells (160000 paths) go to different shards.
  const ShardSelection first = select_shard(plan, {1, 4}), second = select_shard(plan, {2, 4});
  ASSERT_EQ(first.cells.size(), 1u);
  ASSERT_EQ(second.cells.size(), 1u);
  EXPECT_EQ(first.cells[0].params.at("photons"), "160000");
  EXPECT_EQ(second.cells[0].params.at("photons"), "160000");
}

}  // namespace shard_test
}  // namespace pb::run
