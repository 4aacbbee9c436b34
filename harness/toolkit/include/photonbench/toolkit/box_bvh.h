// A linear BVH over axis-aligned boxes, built on the GPU from scratch each time it is recorded
// (kernels: harness/shaders/toolkit/bvh/), and walked by a technique's own shaders with
// toolkit/bvh_walk.glsl's point walk and segment walk and their any-hit hook. Moved out of
// photon-differentials, which builds it over its footprints' boxes and walks it with its leaf
// size T (seed 003 §5.2, §5.3, §6.2): 30-bit Morton codes of the box centres, the
// toolkit's radix sort, runs of equal codes as leaves, Karras's radix tree over the runs, boxes
// joined bottom-up one level a dispatch. It stands in for DXR's per-frame build over procedural
// AABBs and its any-hit shader (Paper V §3; thesis §3.2), as Vulkan compute any GPU runs.
//
//   BoxBvh bvh;  bvh.setup(gpu, "collection-points/bvh");  bvh.reserve(n);
//   bvh.record_build(cmd, boxes, n);       // boxes: BvhBox[n]; full barriers inside and after
//   bvh.record_refit(cmd, boxes, n);       // later, over moved boxes: the built tree, new boxes
//   pipeline.bind(cmd, {..., walk[0], walk[1], walk[2], walk[3]}, push) with
//   const auto walk = bvh.walk_resources(boxes);
//
// The boxes stay the caller's: the walk reads them (an item's own box is tested before its hook,
// unless the shader sets pb_bvh_test_item_boxes false). items() is the Morton order: a caller may
// keep its records in it and read them in the hook at pb_bvh_slot.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "photonbench/gpu.h"
#include "photonbench/toolkit/gpu_scan.h"
#include "photonbench/toolkit/radix_sort.h"

namespace pb::toolkit {

#include "photonbench/toolkit/box_bvh_layout.h"

static_assert(sizeof(BvhBox) == 32 && offsetof(BvhBox, hi) == 16);
static_assert(sizeof(BvhNode) == 48 && offsetof(BvhNode, hi) == 16 &&
              offsetof(BvhNode, first) == 32);

// A box no walk meets (lo > hi), for an item slot with nothing in it; joined with a box, it leaves
// that box as it was.
inline BvhBox empty_box() { return BvhBox{glm::vec3(3.0e38f), 0, glm::vec3(-3.0e38f), 0}; }

// The smallest box around a flat cylinder: axis `normal` (unit), radius r, height h, centred at c.
BvhBox cylinder_box(glm::vec3 centre, glm::vec3 normal, float radius, float height);

class BoxBvh {
 public:
  static constexpr uint32_t kMortonBits = 30;
  static constexpr uint32_t kBottomUpPasses = 32;  // > the tree's internal depth over 30-bit codes

  struct Stats {
    uint32_t items = 0, leaves = 0, inner = 0, long_runs = 0;
    uint32_t nodes() const { return leaves + inner; }
  };

  // host_readable: the nodes and items live in host-visible memory (tests read them back).
  void setup(gpu::Device& gpu, std::string_view name, bool host_readable = false);
  // Makes room for builds over up to `count` boxes (replaces buffers: call before recording any of
  // the frame's work that uses this BVH).
  void reserve(uint32_t count);
  // Records the build over boxes[0, count), with full barriers between its passes and after the
  // last. The caller puts a barrier before (boxes written).
  void record_build(vk::CommandBuffer cmd, const gpu::Buffer& boxes, uint32_t count);
  // True when record_refit may follow: a build over `count` boxes was recorded since the buffers
  // were last replaced (reserve).
  bool can_refit(uint32_t count) const { return count > 0 && built_count_ == count; }
  // Records a refit over boxes[0, count), which may have moved, grown, emptied or filled since the
  // build: the build's tree is kept (its Morton order, leaves and inner nodes), each leaf's box is
  // joined anew from its items' boxes and the inner nodes' bottom-up by level, as a DXR
  // acceleration-structure update keeps the topology (Paper V §3.2's refit). Every node then
  // bounds its children, so walks find what they find after a build; only their cost grows as the
  // boxes leave the places the tree sorted them into. Needs can_refit(count); full barriers
  // inside and after, as record_build.
  void record_refit(vk::CommandBuffer cmd, const gpu::Buffer& boxes, uint32_t count);
  // The walk's four bindings (nodes, items, boxes, control) for toolkit/bvh_walk.glsl.
  std::array<gpu::Resource, 4> walk_resources(const gpu::Buffer& boxes) const;
  // After the build has run (a flush): its counts.
  Stats read_stats() const;
  // GPU memory of the BVH's own buffers (the boxes are the caller's), sort and scan scratch.
  uint64_t bytes() const;

  // Test hook: per query (BvhProbeQuery of bvh_probe.comp: origin.w 0 point, 1 segment with t1 in
  // direction.w) the items the walk's hook was called for, at most `per_query` in `found`, and two
  // uvec4 in `counts`: (hits, complete, nodes popped, items of reached leaves), (nodes met, hook
  // calls whose pb_bvh_slot did not hold the item, 0, 0). `leaf_size` and `test_item_boxes`: the
  // walk's pb_bvh_leaf_size and pb_bvh_test_item_boxes. Buffers are the caller's; a barrier after.
  void record_probe(vk::CommandBuffer cmd, const gpu::Buffer& boxes, const gpu::Buffer& queries,
                    uint32_t count, const gpu::Buffer& found, const gpu::Buffer& counts,
                    uint32_t per_query, uint32_t budget, uint32_t leaf_size = 0,
                    bool test_item_boxes = true) const;
  const gpu::Buffer& nodes() const { return nodes_; }
  const gpu::Buffer& items() const { return items_; }

 private:
  gpu::Device* gpu_ = nullptr;
  std::string name_;
  bool host_readable_ = false;
  uint32_t capacity_ = 0;
  RadixSort sort_;
  PrefixSum scan_;
  uint32_t built_count_ = 0;  // boxes of the last build since reserve (0: no tree to refit)
  gpu::Pipeline bounds_, morton_, heads_pipeline_, runs_, karras_, bottom_up_, probe_;
  gpu::Pipeline refit_gather_, refit_leaves_;
  gpu::Buffer keys_, items_, heads_, run_index_, unique_, nodes_, control_;
  gpu::Buffer refit_bounds_;  // a refit's per-leaf bounds (6 words a leaf), made by the first refit
};

}  // namespace pb::toolkit
