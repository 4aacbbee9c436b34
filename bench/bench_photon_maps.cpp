// bench_photon_maps: the cost of splitting one photon map into several, seed 001's Ch. 8 argument
// for per-surface photon maps, on the toolkit's photon map (photonbench/toolkit/kd_tree.h: Jensen's
// left-balanced kd-tree, the k nearest by a max-heap):
//   1. Table 8.1: N = 10^6 random photons split over M = 1, 10, 100 and 1000 maps of N / M photons
//      each: the time to balance all M maps, and one lookup of the 500 nearest photons in one of
//      them, each as a ratio to one map, beside the thesis's (5.05, 3.08, 0.70, 0.55 s; 332, 291,
//      213, 116 us; "averaged over 100 random photon maps", a 1.7 GHz Pentium 4 with 512 KB of L2);
//   2. Table 14.1: one small map of 300, 500, 1000 and 2000 photons: its balancing time and one
//      lookup of the 100 nearest ("irradiance lookup (100 photons)": 0.023, 0.027, 0.029, 0.034
//      ms; balancing 0.10, 0.18, 0.39, 0.84 ms), as ratios to 300 photons, beside the thesis's.
//
//   bench_photon_maps [--rounds 3] [--photons 1000000] [--lookups 2000] [--small-maps 400]
//
// Photons are uniform in the unit cube, each map's drawn afresh every round (the thesis: "photons
// that are distributed randomly in space", "100 completely random photon maps"); lookups are at
// uniform points of the cube, in the maps in turn, with no maximum radius, so that every lookup
// finds its k (the thesis gives its radius nowhere). A lookup here is the search alone; the
// thesis's also summed the photons' power into an irradiance estimate, which adds k multiply-adds.
// The configurations run in alternating rounds (the order rotated each round), and each ratio is
// the median of per-round ratios. Times are wall-clock on a shared machine: the ratios are the
// figures, the absolute times this machine's.
#include <chrono>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "bench_support.h"
#include "photonbench/toolkit/kd_tree.h"

using pb::toolkit::KdTree;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

std::vector<glm::vec3> random_photons(size_t count, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<glm::vec3> photons(count);
  for (auto& p : photons) p = {u(rng), u(rng), u(rng)};
  return photons;
}

struct Timing {
  double balance_s = 0;  // all maps
  double lookup_s = 0;   // one lookup
};

// `maps` maps of `per_map` random photons: balances them all (timed together), then `lookups`
// k-nearest lookups at random points, in the maps in turn. `checksum` keeps the work observable.
Timing measure(size_t maps, size_t per_map, uint32_t k, uint32_t lookups, std::mt19937& rng,
               size_t& checksum) {
  std::vector<std::vector<glm::vec3>> photons(maps);
  for (auto& map : photons) map = random_photons(per_map, rng);
  std::vector<glm::vec3> queries = random_photons(lookups, rng);
  std::vector<KdTree> trees(maps);
  Timing t;
  auto start = Clock::now();
  for (size_t m = 0; m < maps; ++m) trees[m] = KdTree(photons[m]);
  t.balance_s = seconds_since(start);
  std::vector<KdTree::Neighbour> found;
  found.reserve(k);
  start = Clock::now();
  for (uint32_t q = 0; q < lookups; ++q) {
    trees[q % maps].nearest(queries[q], k, std::numeric_limits<float>::infinity(), found);
    checksum += found.size() + found.back().index;
  }
  t.lookup_s = seconds_since(start) / lookups;
  return t;
}

struct Row {
  size_t size;           // maps (Table 8.1) or photons (Table 14.1)
  double paper_balance;  // the thesis's, in its unit
  double paper_lookup;
};

// Runs `rows` in alternating rounds and prints each one's medians and ratios to the first row.
void table(const char* title, const std::vector<Row>& rows, bool split_total, size_t total,
           size_t small_maps, uint32_t k, uint32_t lookups, int rounds, const char* paper_units) {
  const size_t n = rows.size();
  std::vector<std::vector<double>> balance(n), lookup(n), balance_ratio(n), lookup_ratio(n);
  std::mt19937 rng(2004);
  size_t checksum = 0;
  for (int r = 0; r < rounds; ++r) {
    std::vector<Timing> t(n);
    for (size_t j = 0; j < n; ++j) {
      const size_t i = (j + size_t(r)) % n;  // rotate the order each round
      const size_t maps = split_total ? rows[i].size : small_maps;
      const size_t per_map = split_total ? total / rows[i].size : rows[i].size;
      t[i] = measure(maps, per_map, k, lookups, rng, checksum);
      // Table 14.1 is per map: the balancing of one.
      if (!split_total) t[i].balance_s /= double(maps);
    }
    for (size_t i = 0; i < n; ++i) {
      balance[i].push_back(t[i].balance_s);
      lookup[i].push_back(t[i].lookup_s);
      balance_ratio[i].push_back(t[i].balance_s / t[0].balance_s);
      lookup_ratio[i].push_back(t[i].lookup_s / t[0].lookup_s);
    }
  }
  std::printf("%s\n", title);
  std::printf("%9s | %12s %10s %10s | %12s %10s %10s\n", split_total ? "maps" : "photons",
              "balance ms", "ratio", "thesis", "lookup us", "ratio", "thesis");
  for (size_t i = 0; i < n; ++i)
    std::printf("%9zu | %12.3f %10.3f %10.3f | %12.2f %10.3f %10.3f\n", rows[i].size,
                1e3 * pb::bench::median(balance[i]), pb::bench::median(balance_ratio[i]),
                rows[i].paper_balance / rows[0].paper_balance, 1e6 * pb::bench::median(lookup[i]),
                pb::bench::median(lookup_ratio[i]), rows[i].paper_lookup / rows[0].paper_lookup);
  std::printf("thesis (%s):", paper_units);
  for (const Row& row : rows)
    std::printf(" %zu: %g / %g;", row.size, row.paper_balance, row.paper_lookup);
  std::printf(" (checksum %zu)\n\n", checksum);
}

}  // namespace

int main(int argc, char** argv) {
  const char* usage =
      "bench_photon_maps [--rounds 3] [--photons 1000000] [--lookups 2000] [--small-maps 400]";
  auto options = pb::bench::parse_options(
      argc, argv,
      {{"--rounds", "3"}, {"--photons", "1000000"}, {"--lookups", "2000"}, {"--small-maps", "400"}},
      usage);
  if (!options) return 2;
  const int rounds = std::stoi((*options)["--rounds"]);
  const size_t photons = std::stoull((*options)["--photons"]);
  const uint32_t lookups = uint32_t(std::stoul((*options)["--lookups"]));
  const size_t small_maps = std::stoull((*options)["--small-maps"]);
  if (rounds < 1 || photons < 1000 * 500 || lookups < 1 || small_maps < 1) {
    std::fprintf(stderr,
                 "bench_photon_maps: --rounds, --lookups and --small-maps at least 1, --photons at "
                 "least 500000 (1000 maps of at least 500 photons for the 500 nearest)\n");
    return 2;
  }
  std::printf(
      "bench_photon_maps: %d rounds, %zu photons, %u lookups per configuration and round, %zu "
      "small maps per size and round\n",
      rounds, photons, lookups, small_maps);
  std::printf("cpu: %s\nvector units: %s\nnode: %zu bytes a photon (the thesis's: 40)\n\n",
              pb::bench::cpu_model().c_str(), pb::bench::vector_units().c_str(),
              sizeof(KdTree::Node));

  table("Table 8.1: N photons over M maps; balancing all M maps, one 500-nearest lookup",
        {{1, 5.05, 332}, {10, 3.08, 291}, {100, 0.70, 213}, {1000, 0.55, 116}}, true, photons, 0,
        500, lookups, rounds, "balance s / lookup us");
  table("Table 14.1: one map; balancing it, one 100-nearest lookup",
        {{300, 0.10, 0.023}, {500, 0.18, 0.027}, {1000, 0.39, 0.029}, {2000, 0.84, 0.034}}, false,
        0, small_maps, 100, lookups, rounds, "balance ms / lookup ms");
  return 0;
}
