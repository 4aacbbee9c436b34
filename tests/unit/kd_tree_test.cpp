// The toolkit's photon map (photonbench/toolkit/kd_tree.h): the balanced tree is left-balanced and
// splits each subtree at its median, and the k-nearest lookup returns exactly what a brute-force
// search returns (the first k of the points within the radius, sorted by squared distance, then
// index) on random points and on lattice points full of ties and duplicates, stops at the radius,
// and handles empty and one-point maps.
#include "photonbench/toolkit/kd_tree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>
#include <vector>

namespace kd_tree_test {

using pb::toolkit::KdTree;
using Neighbour = KdTree::Neighbour;

constexpr float kUnbounded = std::numeric_limits<float>::infinity();

std::vector<Neighbour> brute_force(const std::vector<glm::vec3>& points, glm::vec3 x, uint32_t k,
                                   float max_radius) {
  std::vector<Neighbour> all;
  for (size_t i = 0; i < points.size(); ++i) {
    const glm::vec3 d = points[i] - x;
    const float d2 = glm::dot(d, d);
    if (d2 <= max_radius * max_radius) all.push_back({uint32_t(i), d2});
  }
  std::sort(all.begin(), all.end(), [](const Neighbour& a, const Neighbour& b) {
    return a.distance2 < b.distance2 || (a.distance2 == b.distance2 && a.index < b.index);
  });
  if (all.size() > k) all.resize(k);
  return all;
}

// Compares index by index, so a failure names the first place the two differ.
void expect_same(const std::vector<Neighbour>& found, const std::vector<Neighbour>& expected,
                 const std::string& what) {
  ASSERT_EQ(found.size(), expected.size()) << what;
  for (size_t i = 0; i < found.size(); ++i) {
    ASSERT_EQ(found[i].index, expected[i].index) << what << ", place " << i;
    ASSERT_EQ(found[i].distance2, expected[i].distance2) << what << ", place " << i;
  }
}

std::vector<glm::vec3> random_points(size_t count, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<glm::vec3> points(count);
  for (auto& p : points) p = {u(rng), u(rng), u(rng)};
  return points;
}

// Checks the tree against its definition: every point once, at its own position; each node splits
// its subtree on that subtree's widest axis with the left subtree <= node <= the right subtree.
// (The shape needs no check: n nodes in the implicit order are the left-balanced tree of n nodes,
// so what balancing can get wrong is which point lands in which subtree.)
void expect_balanced(const KdTree& tree, const std::vector<glm::vec3>& points) {
  const auto nodes = tree.nodes();
  ASSERT_EQ(nodes.size(), points.size());
  std::vector<int> seen(points.size(), 0);
  for (const auto& node : nodes) {
    ASSERT_LT(node.index, points.size());
    ++seen[node.index];
    EXPECT_EQ(node.position, points[node.index]);
  }
  EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int s) { return s == 1; }));
  // Subtree members by walking the implicit indices.
  auto members = [&](size_t root) {
    std::vector<size_t> out, stack{root};
    while (!stack.empty()) {
      const size_t i = stack.back();
      stack.pop_back();
      if (i >= nodes.size()) continue;
      out.push_back(i);
      stack.push_back(2 * i + 1);
      stack.push_back(2 * i + 2);
    }
    return out;
  };
  for (size_t i = 0; i < nodes.size(); ++i) {
    if (2 * i + 1 >= nodes.size()) continue;
    const std::vector<size_t> all = members(i), left = members(2 * i + 1),
                              right = members(2 * i + 2);
    glm::vec3 lo(kUnbounded), hi(-kUnbounded);
    for (size_t m : all) lo = glm::min(lo, nodes[m].position), hi = glm::max(hi, nodes[m].position);
    const glm::vec3 extent = hi - lo;
    const uint32_t axis = nodes[i].axis;
    for (int a = 0; a < 3; ++a) EXPECT_GE(extent[axis], extent[a]) << "node " << i;
    const float split = nodes[i].position[axis];
    for (size_t m : left) EXPECT_LE(nodes[m].position[axis], split) << "node " << i;
    for (size_t m : right) EXPECT_GE(nodes[m].position[axis], split) << "node " << i;
  }
}

TEST(KdTree, BalancesIntoALeftBalancedMedianSplitTree) {
  std::mt19937 rng(11);
  for (size_t count : {2u, 3u, 7u, 8u, 100u, 1000u}) {
    const auto points = random_points(count, rng);
    expect_balanced(KdTree(points), points);
  }
  // A flat set: every split must be on x or z, never on the empty y extent.
  std::vector<glm::vec3> flat = random_points(500, rng);
  for (auto& p : flat) p.y = 0.5f;
  const KdTree tree(flat);
  expect_balanced(tree, flat);
  for (size_t i = 0; 2 * i + 1 < tree.size(); ++i) EXPECT_NE(tree.nodes()[i].axis, 1u);
}

TEST(KdTree, NearestEqualsBruteForceOnRandomPoints) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-0.1f, 1.1f);  // queries inside and just outside
  std::vector<Neighbour> found;
  for (size_t count : {1u, 2u, 5u, 64u, 1000u, 5000u}) {
    const auto points = random_points(count, rng);
    const KdTree tree(points);
    for (uint32_t k : {1u, 8u, 100u, 500u, 6000u})
      for (float radius : {kUnbounded, 0.3f, 0.05f})
        for (int q = 0; q < 20; ++q) {
          const glm::vec3 x{u(rng), u(rng), u(rng)};
          tree.nearest(x, k, radius, found);
          expect_same(found, brute_force(points, x, k, radius),
                      "n " + std::to_string(count) + ", k " + std::to_string(k) + ", radius " +
                          std::to_string(radius));
        }
  }
}

// Points on a coarse integer lattice, many coincident, queried at lattice points and half-way
// between: many exact ties at the k-th distance (distances are small integers, exact in float),
// which the lookup must break by index as the brute force does.
TEST(KdTree, NearestBreaksTiesByIndexAsBruteForce) {
  std::mt19937 rng(9);
  std::uniform_int_distribution<int> cell(0, 4);
  std::vector<glm::vec3> points(400);
  for (auto& p : points) p = glm::vec3(float(cell(rng)), float(cell(rng)), float(cell(rng)));
  const KdTree tree(points);
  std::vector<Neighbour> found;
  for (uint32_t k : {1u, 3u, 10u, 57u, 200u})
    for (float radius : {kUnbounded, 1.0f, 2.0f})
      for (int q = 0; q < 50; ++q) {
        const glm::vec3 x = glm::vec3(float(cell(rng)), float(cell(rng)), float(cell(rng))) +
                            (q % 2 ? glm::vec3(0.5f) : glm::vec3(0.0f));
        tree.nearest(x, k, radius, found);
        const auto expected = brute_force(points, x, k, radius);
        expect_same(found, expected,
                    "k " + std::to_string(k) + ", radius " + std::to_string(radius) + ", query " +
                        std::to_string(q));
      }
}

TEST(KdTree, MaxRadiusLimitsTheLookup) {
  // Points on the x axis at 0, 1, ..., 9; the query at the origin.
  std::vector<glm::vec3> points;
  for (int i = 0; i < 10; ++i) points.push_back({float(i), 0.0f, 0.0f});
  const KdTree tree(points);
  std::vector<Neighbour> found;
  tree.nearest(glm::vec3(0.0f), 100, 3.0f, found);  // a point exactly at the radius counts
  ASSERT_EQ(found.size(), 4u);
  for (uint32_t i = 0; i < 4; ++i) {
    EXPECT_EQ(found[i].index, i);
    EXPECT_EQ(found[i].distance2, float(i * i));
  }
  tree.nearest(glm::vec3(0.0f), 100, 2.5f, found);
  EXPECT_EQ(found.size(), 3u);
  tree.nearest(glm::vec3(0.0f), 2, 2.5f, found);  // k binds before the radius
  EXPECT_EQ(found.size(), 2u);
  tree.nearest(glm::vec3(0.0f), 100, 0.0f, found);  // only the coincident point
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].index, 0u);
  tree.nearest(glm::vec3(-5.0f, 0.0f, 0.0f), 100, 4.9f, found);  // nothing that near
  EXPECT_TRUE(found.empty());
}

TEST(KdTree, EmptyAndOnePointMaps) {
  std::vector<Neighbour> found{{7, 1.0f}};  // stale content is cleared
  const KdTree empty(std::vector<glm::vec3>{});
  EXPECT_TRUE(empty.empty());
  empty.nearest(glm::vec3(0.0f), 10, kUnbounded, found);
  EXPECT_TRUE(found.empty());
  const KdTree default_constructed;
  default_constructed.nearest(glm::vec3(0.0f), 10, kUnbounded, found);
  EXPECT_TRUE(found.empty());

  const KdTree one(std::vector<glm::vec3>{{1.0f, 2.0f, 2.0f}});
  ASSERT_EQ(one.size(), 1u);
  one.nearest(glm::vec3(0.0f), 10, kUnbounded, found);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].index, 0u);
  EXPECT_EQ(found[0].distance2, 9.0f);
  one.nearest(glm::vec3(0.0f), 10, 2.9f, found);
  EXPECT_TRUE(found.empty());
  one.nearest(glm::vec3(0.0f), 0, kUnbounded, found);  // k = 0 asks for nothing
  EXPECT_TRUE(found.empty());
}

}  // namespace kd_tree_test
