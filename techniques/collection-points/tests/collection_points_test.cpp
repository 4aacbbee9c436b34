// collection-points technique: the toolkit box BVH's point and segment walks against a brute-force
// search on random boxes (driven on a device, as the plugin drives it), after a build and after a
// refit over moved boxes, the reuse gates and weight (cp_gather.h, the text the shaders run), a
// caustic seen in a mirror against its closed form with both accumulators, fixed4_28's clamp at
// 15, temporal reuse keeping a static scene's mean, a refit giving the rebuild's image, and bad
// parameters refused with their key.
#include "collection_points.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "gpu_context.h"
#include "io/image.h"
#include "photonbench/error.h"
#include "photonbench/toolkit/box_bvh.h"
#include "photonbench/toolkit/technique.h"
#include "plan_scratch.h"
#include "run_fixture.h"

namespace fs = std::filesystem;

namespace collection_points_test {

using namespace pb::testing;
using pb::toolkit::BvhBox;

constexpr double kPi = 3.14159265358979;

// ---- The toolkit BVH's walks against brute force ----

struct ProbeQuery {
  glm::vec4 origin, direction;
};

// The brute force below runs 24 million box tests a walk check; written on plain floats, without
// GLM's and the standard library's function calls, as the sanitized build compiles the test
// program unoptimised (scripts/sanitizers/tests.cmake).
bool contains(const BvhBox& b, glm::vec3 x) {
  return x.x >= b.lo.x && x.y >= b.lo.y && x.z >= b.lo.z && x.x <= b.hi.x && x.y <= b.hi.y &&
         x.z <= b.hi.z;
}
// The slab test as bvh_walk.glsl makes it: the margin leave - enter by which the segment
// origin + t d, t in [0, t1], meets the box (negative: it misses; -inf: parallel and outside,
// or the box is empty).
float meets(const BvhBox& b, glm::vec3 origin, glm::vec3 direction, float t1) {
  const float lo[3] = {b.lo.x, b.lo.y, b.lo.z}, hi[3] = {b.hi.x, b.hi.y, b.hi.z};
  const float o[3] = {origin.x, origin.y, origin.z}, d[3] = {direction.x, direction.y, direction.z};
  if (lo[0] > hi[0] || lo[1] > hi[1] || lo[2] > hi[2]) return -INFINITY;  // empty
  float enter = 0, leave = t1;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0) {
      if (o[k] < lo[k] || o[k] > hi[k]) return -INFINITY;
      continue;
    }
    const float a = (lo[k] - o[k]) / d[k], c = (hi[k] - o[k]) / d[k];
    const float near = a < c ? a : c, far = a < c ? c : a;
    enter = near > enter ? near : enter;
    leave = far < leave ? far : leave;
  }
  return leave - enter;
}

// `count` random boxes (sizes from 1e-3 to 0.2 of the unit cube, some duplicated centres so that
// runs of equal Morton codes hold several, some empty).
std::vector<BvhBox> random_boxes(uint32_t count, std::mt19937& rng) {
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<BvhBox> boxes(count);
  for (uint32_t i = 0; i < count; ++i) {
    glm::vec3 c = i % 7 == 3 ? 0.5f * (boxes[i - 1].lo + boxes[i - 1].hi)
                             : glm::vec3(unit(rng), unit(rng), unit(rng));
    const float size = std::pow(10.0f, -3.0f + 2.3f * unit(rng));
    glm::vec3 half = size * glm::vec3(unit(rng), unit(rng), unit(rng));
    boxes[i] = BvhBox{c - half, 0, c + half, 0};
    if (i % 97 == 5) std::swap(boxes[i].lo, boxes[i].hi);  // empty
  }
  return boxes;
}

// `count` queries about `boxes`: the first half points (half of those at box corners and centres,
// where containment is decided by equality), the second half segments.
std::vector<ProbeQuery> random_queries(uint32_t count, const std::vector<BvhBox>& boxes,
                                       std::mt19937& rng) {
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<ProbeQuery> queries(count);
  for (uint32_t q = 0; q < count; ++q) {
    const BvhBox& b = boxes[(q * 7919u) % boxes.size()];
    glm::vec3 x = q % 4 == 0   ? b.lo
                  : q % 4 == 1 ? 0.5f * (b.lo + b.hi)
                               : glm::vec3(unit(rng), unit(rng), unit(rng)) * 1.2f - 0.1f;
    if (q < count / 2) {
      queries[q] = {glm::vec4(x, 0), glm::vec4(1, 0, 0, 0)};
    } else {
      glm::vec3 d = glm::vec3(unit(rng), unit(rng), unit(rng)) - 0.5f;
      if (q % 5 == 0) d.y = 0;  // along an axis plane: the slab test's 0 * inf
      queries[q] = {glm::vec4(x, 1), glm::vec4(glm::normalize(d), 0.05f + 0.3f * unit(rng))};
    }
  }
  return queries;
}

bool is_empty(const BvhBox& b) { return glm::any(glm::greaterThan(b.lo, b.hi)); }
bool inside(const BvhBox& b, glm::vec3 lo, glm::vec3 hi) {
  return glm::all(glm::greaterThanEqual(b.lo, lo)) && glm::all(glm::lessThanEqual(b.hi, hi));
}

// The tree read back: from the root every item is reached exactly once; every child's box lies in
// its parent's, every item's (non-empty) box in its leaf's.
void expect_tree_bounds(const pb::toolkit::BoxBvh& bvh, const std::vector<BvhBox>& boxes) {
  const auto* nodes = static_cast<const pb::toolkit::BvhNode*>(bvh.nodes().mapped());
  const auto* items = static_cast<const uint32_t*>(bvh.items().mapped());
  std::vector<int> reached(boxes.size(), 0);
  std::vector<uint32_t> stack = {0};
  size_t bad_items = 0, bad_children = 0, steps = 0;
  while (!stack.empty() && ++steps < 10 * boxes.size()) {
    const pb::toolkit::BvhNode& node = nodes[stack.back()];
    stack.pop_back();
    if (node.left != PB_BVH_NONE) {
      for (uint32_t child : {node.left, node.right}) {
        const BvhBox c{nodes[child].lo, 0, nodes[child].hi, 0};
        if (!is_empty(c) && !inside(c, node.lo, node.hi)) ++bad_children;
        stack.push_back(child);
      }
      continue;
    }
    for (uint32_t j = node.first; j < node.first + node.count; ++j) {
      ++reached[items[j]];
      const BvhBox& b = boxes[items[j]];
      if (!is_empty(b) && !inside(b, node.lo, node.hi)) ++bad_items;
    }
  }
  EXPECT_EQ(size_t(std::count(reached.begin(), reached.end(), 1)), boxes.size())
      << "items reached once";
  EXPECT_EQ(bad_children, 0u) << "child boxes outside their parent's box";
  EXPECT_EQ(bad_items, 0u) << "item boxes outside their leaf's box";
}

// What a brute-force search over `boxes` finds for each query: the items it surely meets, and
// those a segment grazes (|leave - enter| within 1e-5: the device's reciprocal may round otherwise
// than the CPU's division), which a walk may find or not. Points are decided exactly.
struct BruteForce {
  std::vector<std::set<uint32_t>> surely, maybe;
  size_t grazing = 0;
};
BruteForce brute_force(const std::vector<BvhBox>& boxes, const std::vector<ProbeQuery>& queries) {
  BruteForce r;
  r.surely.resize(queries.size());
  r.maybe.resize(queries.size());
  for (size_t q = 0; q < queries.size(); ++q) {
    const glm::vec3 o(queries[q].origin);
    for (uint32_t i = 0; i < boxes.size(); ++i) {
      if (queries[q].origin.w == 0) {
        if (contains(boxes[i], o)) r.surely[q].insert(i);
        continue;
      }
      const float margin =
          meets(boxes[i], o, glm::vec3(queries[q].direction), queries[q].direction.w);
      if (margin > 1e-5f)
        r.surely[q].insert(i);
      else if (margin >= -1e-5f)
        r.maybe[q].insert(i), ++r.grazing;
    }
  }
  return r;
}

// Each query's walk (record_probe's results) against the brute-force search: the hook called for
// exactly the items brute force finds, each once. Returns the item boxes the walks tested per
// query.
double expect_walks_match(const BruteForce& expected, const pb::gpu::Buffer& found,
                          const pb::gpu::Buffer& counts, uint32_t per_query) {
  const auto* f = static_cast<const uint32_t*>(found.mapped());
  const auto* n = static_cast<const uint32_t*>(counts.mapped());
  size_t total = 0, wrong = 0, tested = 0;
  const auto count = uint32_t(expected.surely.size());
  for (uint32_t q = 0; q < count; ++q) {
    std::multiset<uint32_t> got;
    const std::set<uint32_t>&surely = expected.surely[q], &maybe = expected.maybe[q];
    EXPECT_EQ(n[8 * q + 1], 1u) << "query " << q << " ran out of its budget";
    EXPECT_LE(n[8 * q], per_query);
    tested += n[8 * q + 3];
    for (uint32_t k = 0; k < std::min(n[8 * q], per_query); ++k) got.insert(f[q * per_query + k]);
    total += surely.size();
    bool ok = got.size() == std::set<uint32_t>(got.begin(), got.end()).size();  // each once
    for (uint32_t i : surely) ok = ok && got.count(i) == 1;
    for (uint32_t i : got) ok = ok && (surely.count(i) == 1 || maybe.count(i) == 1);
    if (!ok && wrong++ < 5)
      ADD_FAILURE() << (q < count / 2 ? "point" : "segment") << " query " << q << ": walk found "
                    << got.size() << ", brute force " << surely.size() << " (+" << maybe.size()
                    << " grazing; nodes " << n[8 * q + 2] << ", boxes " << n[8 * q + 3] << ")";
  }
  EXPECT_LT(expected.grazing, size_t(count / 4)) << "grazing pairs";
  EXPECT_EQ(wrong, 0u);
  EXPECT_GT(total, size_t(count)) << "the queries must find something to compare";
  return double(tested) / count;
}

// The probe's buffers, host-visible.
struct Probe {
  static constexpr uint32_t kPerQuery = 512;
  pb::gpu::Buffer boxes, queries, found, counts;
  Probe(pb::gpu::Device& gpu, uint32_t box_count, uint32_t query_count) {
    auto host = [&](const char* name, uint64_t bytes) {
      return pb::toolkit::storage_buffer(gpu, name, bytes, pb::gpu::Memory::host_visible);
    };
    boxes = host("test/boxes", box_count * sizeof(BvhBox));
    queries = host("test/queries", query_count * sizeof(ProbeQuery));
    found = host("test/found", uint64_t(query_count) * kPerQuery * 4);
    counts = host("test/counts", query_count * 32);
  }
  void load(const std::vector<BvhBox>& b, const std::vector<ProbeQuery>& q) {
    std::memcpy(boxes.mapped(), b.data(), b.size() * sizeof(BvhBox));
    std::memcpy(queries.mapped(), q.data(), q.size() * sizeof(ProbeQuery));
  }
  void record(vk::CommandBuffer cmd, const pb::toolkit::BoxBvh& bvh, uint32_t query_count,
              uint32_t leaf_size = 0, bool test_item_boxes = true) {
    bvh.record_probe(cmd, boxes, queries, query_count, found, counts, kPerQuery, PB_LOOP_BUDGET,
                     leaf_size, test_item_boxes);
  }
};

// A device, `box_count` random boxes and `query_count` queries about them (seeded), loaded into
// the probe, and the BVH set up (host-readable) with its build over the boxes recorded.
struct BuiltOverRandomBoxes {
  pb::gpu::Device gpu{pb::gpu::Device::Options{}};
  TestGBuffer gbuffer{gpu, 8, 8};
  TestContext ctx{gpu, gbuffer};
  std::vector<BvhBox> boxes;
  std::vector<ProbeQuery> queries;
  Probe probe;
  pb::toolkit::BoxBvh bvh;
  BuiltOverRandomBoxes(uint32_t box_count, uint32_t query_count, uint32_t seed)
      : probe(gpu, box_count, query_count) {
    std::mt19937 rng(seed);
    boxes = random_boxes(box_count, rng);
    queries = random_queries(query_count, boxes, rng);
    probe.load(boxes, queries);
    bvh.setup(gpu, "test/bvh", /* host_readable */ true);
    bvh.reserve(box_count);
    bvh.record_build(ctx.cmd(), probe.boxes, box_count);
  }
};

// 6,000 random boxes, 2,000 point queries and 2,000 segments: each walk must call its hook for
// exactly the items brute force finds, each once.
TEST(CollectionPointsBvh, PointAndSegmentWalksFindWhatBruteForceFinds) {
  constexpr uint32_t kBoxes = 6000, kQueries = 4000;
  BuiltOverRandomBoxes t(kBoxes, kQueries, 11);
  t.probe.record(t.ctx.cmd(), t.bvh, kQueries);
  t.ctx.submit();
  const auto stats = t.bvh.read_stats();
  EXPECT_EQ(stats.items, kBoxes);
  EXPECT_GT(stats.leaves, kBoxes / 2);
  EXPECT_EQ(stats.inner + 1, stats.leaves) << "a binary tree over the runs";
  EXPECT_EQ(stats.long_runs, 0u);
  expect_tree_bounds(t.bvh, t.boxes);
  expect_walks_match(brute_force(t.boxes, t.queries), t.probe.found, t.probe.counts,
                     Probe::kPerQuery);
}

// The point walk as bvh_walk.glsl makes it, on the tree read back: (nodes popped, nodes met, items
// of reached leaves), an inner node of at most `leaf_size` items walked as a leaf.
glm::uvec3 host_point_walk(const pb::toolkit::BoxBvh& bvh, glm::vec3 x, uint32_t leaf_size) {
  const auto* nodes = static_cast<const pb::toolkit::BvhNode*>(bvh.nodes().mapped());
  glm::uvec3 n(0);
  std::vector<uint32_t> stack = {0};
  while (!stack.empty()) {
    const pb::toolkit::BvhNode& node = nodes[stack.back()];
    stack.pop_back();
    ++n.x;
    if (!contains(BvhBox{node.lo, 0, node.hi, 0}, x)) continue;
    ++n.y;
    if (node.left != PB_BVH_NONE && node.count > leaf_size) {
      stack.push_back(node.right);
      stack.push_back(node.left);
      continue;
    }
    n.z += node.count;
  }
  return n;
}

// The walk's leaf size (seed 003 §5.3's T, photon-differentials' leaf_threshold) over one tree: at
// 0, 8 and 64 every walk still finds exactly what brute force finds, and each point walk pops,
// meets and reaches exactly the nodes and items a walk on the host does with that leaf size; the
// larger the leaf size, the fewer nodes popped and the more items reached. With item boxes left
// untested, the hook is called for every item reached. In every hook pb_bvh_slot is the item's
// place in the BVH's order.
TEST(CollectionPointsBvh, WalkingSmallNodesAsLeavesFindsTheSameItemsWithFewerNodes) {
  constexpr uint32_t kBoxes = 6000, kQueries = 2000;
  BuiltOverRandomBoxes t(kBoxes, kQueries, 31);
  t.ctx.submit();
  const BruteForce expected = brute_force(t.boxes, t.queries);
  struct Walk {
    uint32_t leaf_size;
    bool test_item_boxes;
  };
  std::vector<double> popped, reached;
  for (const Walk walk : {Walk{0, true}, Walk{8, true}, Walk{64, true}, Walk{8, false}}) {
    SCOPED_TRACE("leaf size " + std::to_string(walk.leaf_size) +
                 (walk.test_item_boxes ? "" : ", item boxes untested"));
    t.probe.record(t.ctx.cmd(), t.bvh, kQueries, walk.leaf_size, walk.test_item_boxes);
    t.ctx.submit();
    if (walk.test_item_boxes)
      expect_walks_match(expected, t.probe.found, t.probe.counts, Probe::kPerQuery);
    const auto* n = static_cast<const uint32_t*>(t.probe.counts.mapped());
    size_t off = 0, met = 0, wrong_slots = 0;
    double nodes = 0, items = 0;
    for (uint32_t q = 0; q < kQueries; ++q) wrong_slots += n[8 * q + 5];
    for (uint32_t q = 0; q < kQueries / 2; ++q) {  // the point walks
      const glm::uvec3 want =
          host_point_walk(t.bvh, glm::vec3(t.queries[q].origin), walk.leaf_size);
      const glm::uvec3 got(n[8 * q + 2], n[8 * q + 4], n[8 * q + 3]);
      const bool hits_ok = walk.test_item_boxes || n[8 * q] == want.z;
      if ((got != want || !hits_ok) && off++ < 3)
        ADD_FAILURE() << "point query " << q << ": popped, met, reached " << got.x << " " << got.y
                      << " " << got.z << " (hook calls " << n[8 * q] << "), on the host " << want.x
                      << " " << want.y << " " << want.z;
      met += got.y;
      nodes += got.x;
      items += got.z;
    }
    EXPECT_EQ(off, 0u);
    EXPECT_EQ(wrong_slots, 0u) << "hook calls whose pb_bvh_slot did not hold their item";
    EXPECT_GT(met, size_t(kQueries / 4)) << "the points at boxes' corners and centres meet nodes";
    popped.push_back(nodes);
    reached.push_back(items);
  }
  EXPECT_GT(popped[0], popped[1]);
  EXPECT_GT(popped[1], popped[2]);
  EXPECT_LT(reached[0], reached[1]);
  EXPECT_LT(reached[1], reached[2]);
}

// A refit (Paper V §3.2's) keeps the build's tree over boxes that have since moved: a third by
// up to 0.02, a third anywhere in the cube, empty ones filled and others emptied. Every child
// must lie in its parent and every walk find exactly what brute force finds over the moved boxes;
// the walks test more boxes than after a build over them (printed: the cost the paper measured).
TEST(CollectionPointsBvh, RefitOverMovedBoxesBoundsEveryChildAndFindsWhatBruteForceFinds) {
  constexpr uint32_t kBoxes = 6000, kQueries = 4000;
  pb::gpu::Device gpu({});
  TestGBuffer gbuffer(gpu, 8, 8);
  TestContext ctx(gpu, gbuffer);
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const std::vector<BvhBox> before = random_boxes(kBoxes, rng);
  std::vector<BvhBox> after = before;
  const std::vector<BvhBox> elsewhere = random_boxes(kBoxes, rng);
  for (uint32_t i = 0; i < kBoxes; ++i) {
    if (i % 97 == 5 || i % 3 == 1) {  // filled, or moved anywhere
      after[i] = elsewhere[(i + 1) % kBoxes];
      if (is_empty(after[i])) std::swap(after[i].lo, after[i].hi);
    } else if (i % 3 == 0) {
      const glm::vec3 shift = 0.02f * (glm::vec3(unit(rng), unit(rng), unit(rng)) - 0.5f);
      after[i].lo += shift;
      after[i].hi += shift;
    }
    if (i % 89 == 7) after[i] = pb::toolkit::empty_box();
  }
  const std::vector<ProbeQuery> queries = random_queries(kQueries, after, rng);
  Probe probe(gpu, kBoxes, kQueries);
  pb::toolkit::BoxBvh bvh;
  bvh.setup(gpu, "test/bvh", /* host_readable */ true);
  bvh.reserve(kBoxes);
  EXPECT_FALSE(bvh.can_refit(kBoxes)) << "no tree yet";
  EXPECT_THROW(bvh.record_refit(ctx.cmd(), probe.boxes, kBoxes), pb::Error);
  // The build over `after`: the cost of a fresh tree.
  probe.load(after, queries);
  bvh.record_build(ctx.cmd(), probe.boxes, kBoxes);
  probe.record(ctx.cmd(), bvh, kQueries);
  ctx.submit();
  const BruteForce expected = brute_force(after, queries);
  const double built = expect_walks_match(expected, probe.found, probe.counts, Probe::kPerQuery);
  // The build over `before`, then the refit over `after`.
  probe.load(before, queries);
  bvh.record_build(ctx.cmd(), probe.boxes, kBoxes);
  ctx.submit();
  const uint32_t leaves = bvh.read_stats().leaves;
  ASSERT_TRUE(bvh.can_refit(kBoxes));
  EXPECT_FALSE(bvh.can_refit(kBoxes - 1)) << "another count has no tree";
  probe.load(after, queries);
  bvh.record_refit(ctx.cmd(), probe.boxes, kBoxes);
  probe.record(ctx.cmd(), bvh, kQueries);
  ctx.submit();
  const auto stats = bvh.read_stats();
  EXPECT_EQ(stats.leaves, leaves) << "the build's tree kept";
  EXPECT_EQ(stats.inner + 1, stats.leaves) << "every inner node joined again";
  EXPECT_EQ(stats.long_runs, 0u);
  expect_tree_bounds(bvh, after);
  const double refitted = expect_walks_match(expected, probe.found, probe.counts, Probe::kPerQuery);
  std::printf("boxes tested per query: build %.1f, refit %.1f\n", built, refitted);
  EXPECT_GT(refitted, built) << "a third of the boxes moved anywhere: the refitted tree is looser";
}

// ---- The reuse gates (§3.1, Eqs. 3-4) ----

TEST(CollectionPointsReuse, GatesRejectAFlippedNormalAnotherMaterialAndFarPoints) {
  cp::CpPoint current{}, previous{};
  current.position = glm::vec3(1, 2, 3);
  current.normal = glm::vec3(0, 1, 0);
  current.radius = 0.01f;
  current.material = 4;
  previous = current;
  previous.position += glm::vec3(0.004f, 0, 0);
  const float w = cp::cp_reuse_weight(previous, current, 0.75f, 0.9f);
  const double sigma = 0.75 * 0.01;
  EXPECT_NEAR(w, std::exp(-0.004 * 0.004 / (2 * sigma * sigma)), 1e-4);  // float positions
  cp::CpPoint flipped = previous;
  flipped.normal = -previous.normal;
  EXPECT_EQ(cp::cp_reuse_weight(flipped, current, 0.75f, 0.9f), 0.0f);
  cp::CpPoint tilted = previous;  // n . n' = cos 30 degrees < 0.9
  tilted.normal = glm::vec3(0.5f, 0.8660254f, 0);
  EXPECT_EQ(cp::cp_reuse_weight(tilted, current, 0.75f, 0.9f), 0.0f);
  cp::CpPoint other = previous;
  other.material = 5;
  EXPECT_EQ(cp::cp_reuse_weight(other, current, 0.75f, 0.9f), 0.0f);
  cp::CpPoint far = previous;  // inside previous's larger cylinder but beyond current.r
  far.position = current.position + glm::vec3(0.012f, 0, 0);
  far.radius = 0.02f;
  EXPECT_EQ(cp::cp_reuse_weight(far, current, 0.75f, 0.9f), 0.0f);
  cp::CpPoint above = previous;  // off previous's plane by more than half its height (r / 20)
  above.position = current.position + glm::vec3(0, 0.0006f, 0);
  EXPECT_EQ(cp::cp_reuse_weight(above, current, 0.75f, 0.9f), 0.0f);
  above.position = current.position + glm::vec3(0, 0.0004f, 0);
  EXPECT_GT(cp::cp_reuse_weight(above, current, 0.75f, 0.9f), 0.0f);
}

// ---- Runs through photonbench ----

fs::path work_dir(const std::string& name) {
  return pb::testing::work_dir("collection_points_test", name);
}

// A vertical mirror (specular 0.9) at x = 1 facing -x, a floor (albedo 0.5) in front of it, and a
// directional light travelling (1, -1, 0) / sqrt 2 with E = 2 W/m^2 on a plane facing it. The beam
// the mirror reflects, travelling (-1, -1, 0) / sqrt 2, lights the floor for x in [-3, 1] with the
// caustic irradiance 0.9 E cos 45 (L S D). The camera at (0, 1, 0) looks at the mirror and sees
// only the floor in it (C S D): every pixel's path is E S D S L, with throughput 0.9, so the
// indirect_caustics estimate is 0.9 albedo / pi 0.9 E cos 45 everywhere.
constexpr const char* kMirrorScene =
    R"(purpose: a caustic seen in a mirror (techniques/collection-points/tests)
camera: {position: [0, 1, 0], target: [1, 0.5, 0], fov_deg: 30}
lights:
  - {name: sun, type: directional, direction: [1, -1, 0], irradiance: 2}
materials:
  grey: {type: diffuse, albedo: [0.5, 0.5, 0.5]}
  mirror: {type: mirror, specular: 0.9}
objects:
  - {name: floor, shape: {type: quad, size: [6, 6]}, material: grey,
     transform: {translate: [-2, 0, 0]}}
  - {name: mirror, shape: {type: quad, size: [4, 6]}, material: mirror,
     transform: {translate: [1, 2, 0], rotate_deg: [0, 0, 90]}}
)";
constexpr double kMirrorExpected = 0.9 * 0.5 / kPi * 0.9 * 2.0 * 0.70710678;

// `frames` measured frames (the first and the last scored) at 64x48 of the scene text,
// collection-points with `params` (a YAML mapping; a list sweeps): photonbench's exit status.
int run_scene(const fs::path& dir, const std::string& scene, const std::string& params,
              int frames = 2) {
  std::ofstream(dir / "scene.yaml") << scene;
  return run_config(dir, "name: cp\nresolution: [64, 48]\nseed: 1\nscenes: [" +
                             (dir / "scene.yaml").string() +
                             "]\nframes: {warmup: 0, count: " + std::to_string(frames) +
                             ", metrics_every: " + std::to_string(std::max(1, frames - 1)) +
                             "}\nmetrics: [psnr]\nlimits: {cell_seconds: 300}\n"
                             "reference: {samples: 2, cache_dir: " +
                             (dir / "refs").string() +
                             "}\ntechniques:\n  - {technique: "
                             "collection-points, params: " +
                             params + "}\n");
}

double mean_red(const pb::io::Image& image) {
  double sum = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) sum += image.at(x, y, 0);
  return sum / image.pixel_count();
}

// Both accumulators: the image's mean of the indirect_caustics estimate is the closed form within
// 4 Poisson deviations of the photons gathered (contributions / CPs per CP, CPs overlapping, so
// counted once per CP area: a loose bound) plus 2%.
TEST(CollectionPointsRun, CausticSeenInAMirrorMatchesTheClosedForm) {
  fs::path dir = work_dir("mirror");
  // 300,000 paths at 64x48: light_paths is per 1920 x 1080 pixels.
  ASSERT_EQ(
      run_scene(dir, kMirrorScene,
                "{light_paths: 202500000, max_bounces: 3, accumulator: [fixed64, fixed4_28]}"),
      0)
      << "see " << (dir / "log.txt");
  for (const std::string accumulator : {"fixed64", "fixed4_28"}) {
    fs::path cell = find_cell(dir, "collection-points", {{"accumulator", accumulator}});
    ASSERT_FALSE(cell.empty()) << accumulator;
    EXPECT_EQ(read_json(cell / "cell.json")["status"], "ok");
    const CounterSums sums(cell);
    EXPECT_EQ(sums["collection_points"], 2.0 * 64 * 48) << "every pixel sees the floor";
    EXPECT_EQ(sums["collection_points_behind_specular"], 2.0 * 64 * 48);
    EXPECT_EQ(sums["truncated_walks"], 0);
    EXPECT_EQ(sums["saturated_sums"], 0);
    const double per_cp = sums["contributions"] / sums["collection_points"];
    const double mean = mean_red(frame_image(cell, 1, "indirect_caustics"));
    const double tolerance = 4.0 / std::sqrt(per_cp * 64 * 48 / 16) + 0.02;
    std::printf("%s: mean %.5f, closed form %.5f (%.1f photons per CP)\n", accumulator.c_str(),
                mean, kMirrorExpected, per_cp);
    EXPECT_NEAR(mean / kMirrorExpected, 1.0, tolerance) << accumulator;
  }
  fs::remove_all(dir);
}

// emission: aimed sends the light's photons only where they may meet the mirror (the tracer's
// aimed-emission policy) and weights them by the share it keeps: the same closed form, from more
// stored caustic photons for the same light paths than emission over the whole scene square.
TEST(CollectionPointsRun, AimedEmissionKeepsTheMeanWithMoreCausticPhotons) {
  fs::path dir = work_dir("aimed");
  ASSERT_EQ(run_scene(dir, kMirrorScene,
                      "{light_paths: 67500000, max_bounces: 3, emission: [aimed, power]}"),
            0)
      << "see " << (dir / "log.txt");
  fs::path aimed = find_cell(dir, "collection-points", {{"emission", "aimed"}});
  fs::path power = find_cell(dir, "collection-points", {{"emission", "power"}});
  ASSERT_FALSE(aimed.empty());
  ASSERT_FALSE(power.empty());
  const CounterSums a(aimed), p(power);
  std::printf("photons stored: aimed %.0f, power %.0f\n", a["photons_stored"], p["photons_stored"]);
  EXPECT_GT(a["photons_stored"], 1.5 * p["photons_stored"]);
  for (const fs::path& cell : {aimed, power}) {
    const double mean = mean_red(frame_image(cell, 1, "indirect_caustics"));
    std::printf("%s: mean %.5f, closed form %.5f\n", cell.filename().c_str(), mean,
                kMirrorExpected);
    EXPECT_NEAR(mean / kMirrorExpected, 1.0, 0.06) << cell;
  }
  fs::remove_all(dir);
}

// fixed4_28 reproduces the paper's clamp: with the light 250 times brighter (E = 500 W/m^2) and
// 1,000 paths at 64x48, each photon carries about E A / 1000 x 0.9 > 15 W per channel (A, the
// emission square over the scene, is above 40 m^2): every add is clamped and counted in every
// channel (and sums past 16 wrap, counted too); fixed64 clamps nothing.
TEST(CollectionPointsRun, Fixed4_28ClampsAt15AndCountsIt) {
  fs::path dir = work_dir("clamp");
  std::string bright = kMirrorScene;
  bright.replace(bright.find("irradiance: 2"), 13, "irradiance: 500");
  ASSERT_EQ(
      run_scene(dir, bright,
                "{light_paths: 675000, max_bounces: 3, accumulator: [fixed64, fixed4_28]}", 1),
      0)
      << "see " << (dir / "log.txt");
  const CounterSums wide(find_cell(dir, "collection-points", {{"accumulator", "fixed64"}}));
  const CounterSums paper(find_cell(dir, "collection-points", {{"accumulator", "fixed4_28"}}));
  EXPECT_EQ(wide["saturated_sums"], 0);
  ASSERT_GT(paper["contributions"], 0);
  // Every channel of every add is clamped; sums that pass 16 also wrap the word, counted again.
  EXPECT_GE(paper["saturated_sums"], 3 * paper["contributions"]);
  fs::remove_all(dir);
}

// temporal: true on a static scene: the mean over the image stays the basic estimate's (the EMA of
// unbiased estimates, the gather's weights normalised), and CPs do reuse (a static camera's paths
// land on the same points up to the pixel's ray-cone radius).
TEST(CollectionPointsRun, TemporalReuseKeepsAStaticScenesMean) {
  fs::path dir = work_dir("temporal");
  ASSERT_EQ(run_scene(dir, kMirrorScene,
                      "{light_paths: 67500000, max_bounces: 3, temporal: [false, true]}", 6),
            0)
      << "see " << (dir / "log.txt");
  fs::path basic = find_cell(dir, "collection-points", {{"temporal", "false"}});
  fs::path reuse = find_cell(dir, "collection-points", {{"temporal", "true"}});
  ASSERT_FALSE(basic.empty());
  ASSERT_FALSE(reuse.empty());
  EXPECT_EQ(CounterSums(basic)["reused_collection_points"], 0);
  EXPECT_GT(CounterSums(reuse)["reused_collection_points"], 5.0 * 64 * 48 * 0.9)
      << "frames 1 to 5 reuse nearly every CP";
  const double m_basic = mean_red(frame_image(basic, 5, "indirect_caustics"));
  const double m_reuse = mean_red(frame_image(reuse, 5, "indirect_caustics"));
  std::printf("temporal: basic %.5f, reuse %.5f, closed form %.5f\n", m_basic, m_reuse,
              kMirrorExpected);
  EXPECT_NEAR(m_reuse / kMirrorExpected, 1.0, 0.06);
  EXPECT_NEAR(m_basic / kMirrorExpected, 1.0, 0.06);
  fs::remove_all(dir);
}

// cp_update: refit (one box slot per pixel, the first build's tree refitted from the third frame
// on: each of the two frame sets builds once) finds the same CPs for every photon as a rebuild
// does, and the integer sums do not depend on the order of the adds: the same image, exactly.
TEST(CollectionPointsRun, RefitGivesTheRebuildsImage) {
  fs::path dir = work_dir("refit");
  ASSERT_EQ(run_scene(dir, kMirrorScene,
                      "{light_paths: 67500000, max_bounces: 3, cp_update: [rebuild, refit]}", 4),
            0)
      << "see " << (dir / "log.txt");
  fs::path rebuild = find_cell(dir, "collection-points", {{"cp_update", "rebuild"}});
  fs::path refit = find_cell(dir, "collection-points", {{"cp_update", "refit"}});
  ASSERT_FALSE(rebuild.empty());
  ASSERT_FALSE(refit.empty());
  const CounterSums a(rebuild), b(refit);
  EXPECT_EQ(b["collection_points"], a["collection_points"]);
  EXPECT_EQ(b["contributions"], a["contributions"]);
  EXPECT_GT(a["contributions"], 0);
  EXPECT_EQ(b["truncated_walks"], 0);
  const pb::io::Image x = frame_image(rebuild, 3, "indirect_caustics");
  const pb::io::Image y = frame_image(refit, 3, "indirect_caustics");
  ASSERT_EQ(x.pixels.size(), y.pixels.size());
  EXPECT_TRUE(x.pixels == y.pixels) << "frame 3, refitted, differs from the rebuild's";
  EXPECT_GT(mean_red(y), 0.5 * kMirrorExpected);
  fs::remove_all(dir);
}

// Ranges, enumerations and the cross-parameter check: refused before any work at the config's
// file, line and key.
TEST(CollectionPoints, BadParametersAreRefusedWithTheirKey) {
  PlanScratch scratch("collection_points_test_check");
  auto error = [&](const std::string& params) -> std::string {
    try {
      scratch.plan(
          "name: t\nscenes: [mirror-box]\ntechniques:\n  - technique: collection-points\n"
          "    params: " +
          params + "\n");
    } catch (const pb::InputError& e) {
      return e.what();
    }
    return "";
  };
  std::string e = error("{radius_cap: 0}");
  EXPECT_NE(e.find("config.yaml:5:"), std::string::npos) << e;
  EXPECT_NE(e.find("techniques[0].params.radius_cap"), std::string::npos) << e;
  e = error("{accumulator: fixed4_27}");
  EXPECT_NE(e.find("techniques[0].params.accumulator"), std::string::npos) << e;
  EXPECT_NE(e.find("fixed4_28"), std::string::npos) << e;
  e = error("{temporal_alpha: 0.5}");
  EXPECT_NE(e.find("techniques[0].params.temporal_alpha: 0.5 has no effect with temporal = false"),
            std::string::npos)
      << e;
  EXPECT_EQ(error("{temporal: true, temporal_alpha: 0.5}"), "");
  e = error("{cp_update: refitted}");
  EXPECT_NE(e.find("techniques[0].params.cp_update"), std::string::npos) << e;
  EXPECT_NE(e.find("rebuild"), std::string::npos) << e;
  EXPECT_EQ(error("{camera_bounces: 0}").find("camera_bounces") != std::string::npos, true);
}

}  // namespace collection_points_test
