// The photon map of Jensen's photon mapping (Jensen 1996; "Realistic Image Synthesis Using Photon
// Mapping", 2001, Ch. 6), which seed 001 (Ch. 4 and 8) splits into one map per surface and seed
// 003 uses as its baseline: a left-balanced kd-tree of points, CPU side.
//
// Balancing: each node is a point, the median of its subtree along the axis of the subtree's
// largest extent (the tight bounds of the points under it), stored in the implicit order of a
// complete binary tree: node i's children are 2i + 1 and 2i + 2, and every level is full but the
// last, which is filled from the left. No child pointers are stored, so a tree is its node array
// (16 bytes a node) and can be uploaded as it is (knn's `search: kdtree` walks the same order on
// the GPU).
//
// Lookup: the k nearest points within a maximum radius, with a max-heap of the k best held so far
// (Jensen's locate_photons): near child first, the far child only while its splitting plane lies
// within the search bound, which is the maximum radius until k are held and then the k-th
// distance. Ties are broken by the point's index, so the answer is exactly the first k of all
// points within the radius sorted by (squared distance, index), the order a brute-force search
// gives.
//
//   const pb::toolkit::KdTree tree(positions);
//   std::vector<pb::toolkit::KdTree::Neighbour> found;
//   tree.nearest(x, 100, r_max, found);   // nearest first: found[i].index, found[i].distance2
#pragma once

#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <span>
#include <vector>

namespace pb::toolkit {

class KdTree {
 public:
  // The index field's width: a tree holds at most 2^30 points.
  static constexpr uint32_t kIndexBits = 30;
  static constexpr size_t kMaxPoints = size_t(1) << kIndexBits;

  struct Node {
    glm::vec3 position;
    uint32_t index : kIndexBits;  // the point's place in the span the tree was balanced from
    uint32_t axis : 2;            // the splitting axis (0 x, 1 y, 2 z); unused at a leaf
  };

  struct Neighbour {
    uint32_t index;   // the point's place in the span the tree was balanced from
    float distance2;  // squared distance to the query point
  };

  KdTree() = default;
  // Balances `positions` (throws pb::Error for more than kMaxPoints).
  explicit KdTree(std::span<const glm::vec3> positions);

  // The k nearest points within `max_radius` of `x` (a point exactly at the radius counts), nearest
  // first, ties in index order, into `found` (cleared first; its capacity is reused, so a caller
  // looking up many points allocates once). Fewer than k when fewer lie within the radius.
  void nearest(glm::vec3 x, uint32_t k, float max_radius, std::vector<Neighbour>& found) const;

  std::span<const Node> nodes() const { return nodes_; }
  size_t size() const { return nodes_.size(); }
  bool empty() const { return nodes_.empty(); }
  size_t bytes() const { return nodes_.size() * sizeof(Node); }

 private:
  std::vector<Node> nodes_;
};

}  // namespace pb::toolkit
