// KdTree (photonbench/toolkit/kd_tree.h).
#include "photonbench/toolkit/kd_tree.h"

#include <fmt/format.h>

#include <algorithm>
#include <limits>

#include "photonbench/error.h"

namespace pb::toolkit {

namespace {

using Node = KdTree::Node;
using Neighbour = KdTree::Neighbour;

// The nodes left of the root in a left-balanced tree of `count` nodes: half of the full levels
// above the last, and the last level's nodes up to half its capacity (it fills from the left).
size_t left_subtree_size(size_t count) {
  if (count <= 1) return 0;
  size_t levels = 0;  // 2^levels <= count < 2^(levels + 1)
  while ((size_t(2) << levels) <= count) ++levels;
  const size_t full = (size_t(1) << levels) - 1, last = count - full;
  return (full - 1) / 2 + std::min(last, size_t(1) << (levels - 1));
}

uint32_t widest_axis(std::span<const Node> nodes) {
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
  for (const Node& n : nodes) {
    lo = glm::min(lo, n.position);
    hi = glm::max(hi, n.position);
  }
  const glm::vec3 extent = hi - lo;
  return extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
}

// The heap's order: nearer first, ties by index (so the answer does not depend on the tree's
// shape). As std::push_heap's comparison it keeps the farthest held candidate on top.
bool nearer(const Neighbour& a, const Neighbour& b) {
  return a.distance2 < b.distance2 || (a.distance2 == b.distance2 && a.index < b.index);
}

// One lookup's state: the query, and the held candidates as a max-heap in `heap`.
struct Search {
  std::span<const Node> nodes;
  glm::vec3 x;
  uint32_t k;
  float radius2;
  std::vector<Neighbour>& heap;

  // A farther point cannot enter: the maximum radius until k are held, then the k-th distance.
  float bound2() const { return heap.size() == k ? heap.front().distance2 : radius2; }

  void consider(const Node& node) {
    const glm::vec3 d = node.position - x;
    const Neighbour candidate{node.index, glm::dot(d, d)};
    if (candidate.distance2 > radius2) return;
    if (heap.size() < k) {
      heap.push_back(candidate);
      std::push_heap(heap.begin(), heap.end(), nearer);
    } else if (nearer(candidate, heap.front())) {
      std::pop_heap(heap.begin(), heap.end(), nearer);
      heap.back() = candidate;
      std::push_heap(heap.begin(), heap.end(), nearer);
    }
  }

  // The subtree at `i`: the child on x's side first, the other only while its splitting plane
  // lies within the bound (a point on the plane may sit on either side, so the test is <=, which
  // also lets a tie at the k-th distance with a lower index in).
  void visit(size_t i) {
    const Node& node = nodes[i];
    const size_t left = 2 * i + 1;
    if (left < nodes.size()) {
      const float delta = x[node.axis] - node.position[node.axis];
      const size_t near = delta < 0 ? left : left + 1, far = delta < 0 ? left + 1 : left;
      if (near < nodes.size()) visit(near);
      if (far < nodes.size() && delta * delta <= bound2()) visit(far);
    }
    consider(node);
  }
};

}  // namespace

KdTree::KdTree(std::span<const glm::vec3> positions) {
  const size_t n = positions.size();
  if (n > kMaxPoints)
    throw Error(fmt::format("kd-tree: {} points, at most {} in one tree", n, kMaxPoints));
  std::vector<Node> work(n);
  for (size_t i = 0; i < n; ++i) work[i] = Node{positions[i], uint32_t(i), 0};
  nodes_.resize(n);
  struct Subtree {
    size_t first, end, node;  // work[first, end) becomes the subtree rooted at nodes_[node]
  };
  std::vector<Subtree> pending{{0, n, 0}};
  while (!pending.empty()) {
    const Subtree t = pending.back();
    pending.pop_back();
    if (t.first == t.end) continue;
    const uint32_t axis = widest_axis(std::span(work).subspan(t.first, t.end - t.first));
    const size_t median = t.first + left_subtree_size(t.end - t.first);
    std::nth_element(work.begin() + ptrdiff_t(t.first), work.begin() + ptrdiff_t(median),
                     work.begin() + ptrdiff_t(t.end), [axis](const Node& a, const Node& b) {
                       return a.position[axis] < b.position[axis];
                     });
    nodes_[t.node] = work[median];
    nodes_[t.node].axis = axis;
    pending.push_back({t.first, median, 2 * t.node + 1});
    pending.push_back({median + 1, t.end, 2 * t.node + 2});
  }
}

void KdTree::nearest(glm::vec3 x, uint32_t k, float max_radius,
                     std::vector<Neighbour>& found) const {
  found.clear();
  if (k == 0 || nodes_.empty() || !(max_radius >= 0)) return;
  Search search{nodes_, x, k, max_radius * max_radius, found};
  search.visit(0);
  std::sort_heap(found.begin(), found.end(), nearer);
}

}  // namespace pb::toolkit
