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
//   3. Table 8.2: a scene's photons (--scene, default seed001-room; --scene-photons 50,000 stored,
//      the thesis's) in one map against one map per crease-angle chart (the toolkit's
//      segment_charts, 30 degrees): the time to balance the map(s) and to precalculate --estimates
//      irradiance estimates (the --k nearest photons' power over the disc they span) at points
//      spread over the surfaces by area, each from the one map or from its own chart's; beside the
//      thesis's 0.56 against 0.08 s and 13.80 against 5.88 s (its Figs. 8.3 and 8.4: a room of
//      many polygons; the number of estimates and their k are not given: 20,000 and 100 here).
//
//   bench_photon_maps [--rounds 3] [--photons 1000000] [--lookups 2000] [--small-maps 400]
//                     [--scene scenes/seed001-room.yaml] [--scene-photons 50000]
//                     [--estimates 20000] [--k 100]
//
// Photons are uniform in the unit cube, each map's drawn afresh every round (the thesis: "photons
// that are distributed randomly in space", "100 completely random photon maps"); lookups are at
// uniform points of the cube, in the maps in turn, with no maximum radius, so that every lookup
// finds its k (the thesis gives its radius nowhere). A lookup here is the search alone; the
// thesis's also summed the photons' power into an irradiance estimate, which adds k multiply-adds.
// The configurations run in alternating rounds (the order rotated each round), and each ratio is
// the median of per-round ratios. Times are wall-clock on a shared machine: the ratios are the
// figures, the absolute times this machine's.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "bench_support.h"
#include "photonbench/photons.h"
#include "photonbench/toolkit/charts.h"
#include "photonbench/toolkit/kd_tree.h"
#include "scene/scene.h"
#include "trace/embree_scene.h"
#include "trace/photon_tracer.h"

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

// Balances every map into its tree, timed together.
std::vector<KdTree> balance_all(const std::vector<std::vector<glm::vec3>>& maps, double& seconds) {
  std::vector<KdTree> trees(maps.size());
  const auto start = Clock::now();
  for (size_t m = 0; m < maps.size(); ++m) trees[m] = KdTree(maps[m]);
  seconds = seconds_since(start);
  return trees;
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
  Timing t;
  const std::vector<KdTree> trees = balance_all(photons, t.balance_s);
  std::vector<KdTree::Neighbour> found;
  found.reserve(k);
  const auto start = Clock::now();
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

// ---- Table 8.2: one photon map against one per chart, on a scene's own photons ----

// The scene's triangles at frame 0 in world space, in the scene-wide numbering photon records use
// (photonbench/scene_layout.h: object o's triangle t is first_triangle(o) + t, objects in order).
struct WorldMesh {
  std::vector<glm::vec3> positions;
  std::vector<glm::uvec3> triangles;
};

WorldMesh world_mesh(const pb::scene::Scene& scene, const pb::scene::FrameState& state) {
  WorldMesh m;
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    const auto& mesh = scene.objects[o].mesh;
    const uint32_t base = uint32_t(m.positions.size());
    for (const glm::vec3& p : mesh.positions)
      m.positions.push_back(glm::vec3(state.object_to_world[o] * glm::vec4(p, 1.0f)));
    for (const glm::uvec3& t : mesh.triangles) m.triangles.push_back(t + glm::uvec3(base));
  }
  return m;
}

struct Estimate {
  glm::vec3 point;
  uint32_t chart;
};

// Points spread over the surfaces by area (triangles chosen by area, uniform in each).
std::vector<Estimate> estimate_points(const WorldMesh& m, const pb::toolkit::Charts& charts,
                                      size_t count, std::mt19937& rng) {
  std::vector<double> cumulative(m.triangles.size());
  double total = 0;
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    const glm::uvec3 v = m.triangles[t];
    total += 0.5 * glm::length(glm::cross(m.positions[v.y] - m.positions[v.x],
                                          m.positions[v.z] - m.positions[v.x]));
    cumulative[t] = total;
  }
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Estimate> points(count);
  for (Estimate& e : points) {
    const size_t t = size_t(std::lower_bound(cumulative.begin(), cumulative.end(), u(rng) * total) -
                            cumulative.begin());
    const glm::uvec3 v = m.triangles[std::min(t, m.triangles.size() - 1)];
    double a = u(rng), b = u(rng);
    if (a + b > 1) a = 1 - a, b = 1 - b;
    e.point = m.positions[v.x] + float(a) * (m.positions[v.y] - m.positions[v.x]) +
              float(b) * (m.positions[v.z] - m.positions[v.x]);
    e.chart = charts.chart_of[std::min(t, m.triangles.size() - 1)];
  }
  return points;
}

struct MapTiming {
  double balance_s = 0, estimates_s = 0;
};

// Balances the photons into one map (per_chart false) or one map per chart, then makes every
// estimate: the k nearest photons' power (mean over RGB) over pi r^2, r the k-th's distance.
MapTiming precalculate(const std::vector<pb::trace::PhotonRecord>& photons,
                       const std::vector<uint32_t>& photon_chart, size_t chart_count,
                       const std::vector<Estimate>& points, uint32_t k, bool per_chart,
                       double& checksum) {
  const size_t maps = per_chart ? chart_count : 1;
  std::vector<std::vector<glm::vec3>> positions(maps);
  std::vector<std::vector<float>> power(maps);
  for (size_t i = 0; i < photons.size(); ++i) {
    const size_t m = per_chart ? photon_chart[i] : 0;
    const auto& r = photons[i];
    positions[m].push_back(r.position);
    power[m].push_back((r.power.r + r.power.g + r.power.b) / 3.0f);
  }
  MapTiming t;
  const std::vector<KdTree> trees = balance_all(positions, t.balance_s);
  std::vector<KdTree::Neighbour> found;
  found.reserve(k);
  const auto start = Clock::now();
  for (const Estimate& e : points) {
    const size_t m = per_chart ? e.chart : 0;
    trees[m].nearest(e.point, k, std::numeric_limits<float>::infinity(), found);
    if (found.empty()) continue;
    double flux = 0;
    for (const auto& n : found) flux += power[m][n.index];
    checksum += flux / (3.14159265358979 * double(found.back().distance2) + 1e-12);
  }
  t.estimates_s = seconds_since(start);
  return t;
}

void table_8_2(const std::string& scene_path, uint32_t scene_photons, size_t estimates, uint32_t k,
               int rounds) {
  pb::scene::Scene scene = pb::scene::load_scene(scene_path);
  const pb::scene::FrameState state = scene.at(0);
  pb::trace::EmbreeScene world(scene, state);
  pb::trace::EmbreePhotonTracer tracer(world);
  pb::trace::TraceSettings ts;
  // Waves of a fiftieth of the target until it is reached: at most one wave's photons over it.
  ts.paths = std::max(1u, scene_photons / 50);
  ts.photon_target = scene_photons;
  ts.store = pb::trace::kAllPhotons;  // the maps hold every photon: irradiance, not only indirect
  pb::trace::PhotonBatch batch;
  tracer.trace(ts, batch);
  const WorldMesh mesh = world_mesh(scene, state);
  const pb::toolkit::Charts charts = pb::toolkit::segment_charts(mesh.positions, mesh.triangles);
  std::vector<uint32_t> photon_chart(batch.photons.size());
  for (size_t i = 0; i < batch.photons.size(); ++i) {
    const uint32_t t = batch.photons[i].triangle;
    if (t >= mesh.triangles.size()) {
      std::fprintf(stderr, "bench_photon_maps: photon %zu on triangle %u of %zu\n", i, t,
                   mesh.triangles.size());
      std::exit(1);
    }
    photon_chart[i] = charts.chart_of[t];
  }
  std::mt19937 rng(2004);
  const std::vector<Estimate> points = estimate_points(mesh, charts, estimates, rng);
  std::vector<double> balance[2], estimate[2], balance_ratio, estimate_ratio;
  double checksum[2] = {0, 0};
  for (int r = 0; r < rounds; ++r) {
    MapTiming t[2];
    for (int j = 0; j < 2; ++j) {
      const int i = (j + r) % 2;  // alternate which goes first
      t[i] = precalculate(batch.photons, photon_chart, charts.charts.size(), points, k, i == 1,
                          checksum[i]);
    }
    for (int i = 0; i < 2; ++i) {
      balance[i].push_back(t[i].balance_s);
      estimate[i].push_back(t[i].estimates_s);
    }
    balance_ratio.push_back(t[1].balance_s / t[0].balance_s);
    estimate_ratio.push_back(t[1].estimates_s / t[0].estimates_s);
  }
  const size_t triangles = mesh.triangles.size();
  std::printf(
      "Table 8.2: %s (%zu triangles, %zu charts at 30 degrees), %zu photons stored, %zu "
      "estimates of the %u nearest\n",
      scene.name.c_str(), triangles, charts.charts.size(), batch.photons.size(), estimates, k);
  std::printf("%9s | %12s %12s\n", "", "balance ms", "estimates ms");
  const char* names[2] = {"one map", "per chart"};
  for (int i = 0; i < 2; ++i)
    std::printf("%9s | %12.2f %12.2f\n", names[i], 1e3 * pb::bench::median(balance[i]),
                1e3 * pb::bench::median(estimate[i]));
  std::printf(
      "per chart / one map: balance %.3f (thesis 0.08 / 0.56 = %.3f), estimates %.3f "
      "(thesis 5.88 / 13.80 = %.3f); medians of %d rounds' ratios\n",
      pb::bench::median(balance_ratio), 0.08 / 0.56, pb::bench::median(estimate_ratio),
      5.88 / 13.80, rounds);
  std::printf(
      "estimates' sum, one map / per chart: %.4f (photons of other surfaces in the one "
      "map's estimates)\n\n",
      checksum[0] / checksum[1]);
}

}  // namespace

int main(int argc, char** argv) {
  const char* usage =
      "bench_photon_maps [--rounds 3] [--photons 1000000] [--lookups 2000] [--small-maps 400] "
      "[--scene FILE] [--scene-photons 50000] [--estimates 20000] [--k 100]";
  auto options = pb::bench::parse_options(
      argc, argv,
      {{"--rounds", "3"},
       {"--photons", "1000000"},
       {"--lookups", "2000"},
       {"--small-maps", "400"},
       {"--scene", std::string(PB_SOURCE_DIR) + "/scenes/seed001-room.yaml"},
       {"--scene-photons", "50000"},
       {"--estimates", "20000"},
       {"--k", "100"}},
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
  const uint32_t scene_photons = uint32_t(std::stoul((*options)["--scene-photons"]));
  const size_t estimates = std::stoull((*options)["--estimates"]);
  const uint32_t k = uint32_t(std::stoul((*options)["--k"]));
  if (scene_photons < 2 || estimates < 1 || k < 1) {
    std::fprintf(stderr,
                 "bench_photon_maps: --scene-photons at least 2, --estimates and --k at "
                 "least 1\n");
    return 2;
  }
  try {
    table_8_2((*options)["--scene"], scene_photons, estimates, k, rounds);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_photon_maps: %s\n", e.what());
    return 2;
  }
  return 0;
}
