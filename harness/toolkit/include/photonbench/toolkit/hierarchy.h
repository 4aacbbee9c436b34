// pb::toolkit::Hierarchy: Paper I's view-sample cluster hierarchy (Moreau et al. 2016, §4.1, §4.5,
// §5.2, after Sintorn et al. 2014), rebuilt on the GPU every frame from the shared G-buffer. Part
// of the toolkit library (photonbench::toolkit), so cluster, directional and any later technique
// link it.
//
// LAYOUT (GPU side in hierarchy_layout.h, shader helpers in harness/shaders/toolkit/hierarchy.glsl)
//   Levels 0..L-1. Level 0: one root per root tile of root_tile_px x root_tile_px screen pixels,
//   the whole depth range. Level l+1 splits each level-l node into splits[l] = x * y * z children
//   (<= 32; z splits depth). The last level holds the leaves: a block of pixels x one depth slice.
//   Depth slices are exponential (Olsson-style), as deep as the leaf block is wide (roughly
//   cubical) from the frame's nearest sample, stretched when that many slices cannot reach the
//   farthest one. Keys: root key = root index (row-major over the root tiles); child key = (key <<
//   5) | i with i = cx + sx * (cy + sy * cz) (Paper I §4.3). Needs 5 (L-1) + bits(roots) <= 32.
//   Default "256:2x2x8,2x2x8,2x2x8,4x4x2": 5 levels; nodes of 256, 128, 64, 32 and 8 pixels, 1, 8,
//   64, 512 and 1024 depth slices. Level 3 (32x32 pixels) is the accumulation level, one above the
//   leaves (Paper I §4.7/§5.2 "level 4" counting the root as 1); the top splat pass stops there.
//   Storage (dense per level, Paper I §5.2):
//     masks[]    uint  [roots' occupancy flags][child masks of level 0][level 1]...[level L-2]
//                      [leaf bases: per level-(L-2) node, the cid of its first leaf]
//     slots[]    uint  key -> compact node id ("cid"), dense over the levels above the leaves
//                      (Paper I uses the key as the AABB index there; mapping it keeps all per-node
//                      data compact); never cleared: read only where a mask (or for roots the
//                      level-0 list) says the node is occupied this frame. A leaf's cid is its
//                      parent's leaf base + the rank of its bit in the parent's mask (Paper I §5.2
//                      also avoids a dense last level), so no dense leaf array exists.
//     node_keys[] uint per cid: the key; cids [level[l].z, + count(l)) are level l's occupied nodes
//     aabbs[]    6 floats per cid: view-space min xyz, max xyz (full floats, not Paper I's halves).
//     cones[]    vec4 per cid: view-space axis, half-angle (only with normal_cones; not packed).
//     sample_leaves[] uint per pixel: the leaf key of its view sample, or HIER_NO_LEAF.
//     info       HierInfo: the layout above plus this frame's depth slicing and per-level counts.
//   cid capacity of level l = min(dense nodes of l, pixels), so a technique sizes per-node arrays
//   with node_capacity() (every occupied node has a cid < node_capacity()).
//
// BUILD (pass "cluster-build", nested: depth-range, occupancy, leaf-bounds, [cones], propagate)
//   Call build(ctx) after ctx.shared().gbuffer(), fetching nothing from ctx.cmd() across it.
//
// SHADERS: a shader that reads the hierarchy does `#define HIER_BINDING n`, `#include
//   "toolkit/hierarchy.glsl"` and binds bindings() at n..n+6 in order; toolkit/traverse.glsl walks
//   a photon sphere through it.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "photonbench/context.h"
#include "photonbench/gpu.h"
#include "photonbench/param_table.h"
#include "photonbench/plugin.h"
#include "photonbench/toolkit/hierarchy_layout.h"

namespace pb::toolkit {

// The `layout` parameter of every technique on the hierarchy (HierarchyOptions::named_layout), so a
// sweep compares them on the same hierarchy. Each keeps the level above the leaves at 32x32 pixels
// (Paper I's "leaf node at most contains 32x32 view samples" of its fastest version).
// clang-format off
enum class HierarchyLayout : uint32_t { kDefault, kShallow, kDeep };
inline constexpr pb_param_spec kLayoutParam = pb::row<HierarchyLayout>(
    "layout", HierarchyLayout::kDefault, "default|shallow|deep",
    "hierarchy levels: default 256:2x2x8,2x2x8,2x2x8,4x4x2; shallow 128:2x2x8,2x2x8,4x4x2; deep "
    "512:2x2x4,2x2x4,2x2x4,2x2x4,4x4x2");
// clang-format on

// The hierarchy's memory, per Paper I Table 1 row (cluster and directional report them).
// clang-format off
inline constexpr pb_counter_spec kBytesClusterHierarchyCounter = {
    "bytes_cluster_hierarchy", PB_COUNTER_SIZE, "bytes", "AABBs, child masks and node keys"};
inline constexpr pb_counter_spec kBytesFinalBoundsCounter = {
    "bytes_final_bounds", PB_COUNTER_SIZE, "bytes",
    "key -> id map, leaf bases, per-pixel leaf keys"};
// clang-format on

struct LevelSplit {
  uint32_t x = 2, y = 2, z = 8;  // children per node along screen x, screen y and depth
};

struct HierarchyOptions {
  uint32_t root_tile_px =
      256;  // side of a root's screen tile; divisible by the splits' x and y products
  std::vector<LevelSplit> splits = {{2, 2, 8}, {2, 2, 8}, {2, 2, 8}, {4, 4, 2}};  // L-1 entries
  bool normal_cones = false;  // build per-node normal cones (Paper I §4.5; cluster cone / trivial)

  // "ROOT:XxYxZ,XxYxZ,..." e.g. "256:2x2x8,2x2x8,2x2x8,4x4x2" (the default). Throws pb::InputError
  // (naming `what`, e.g. "cluster: layout") on a malformed string or an impossible layout.
  static HierarchyOptions parse_layout(const std::string& layout, const std::string& what);
  // The named layouts the hierarchy techniques offer as their `layout` parameter (kLayoutParam):
  //   default "256:2x2x8,2x2x8,2x2x8,4x4x2"      5 levels, 8x8-pixel leaves, 1024 depth slices
  //   shallow "128:2x2x8,2x2x8,4x4x2"            4 levels, 128 slices
  //   deep    "512:2x2x4,2x2x4,2x2x4,2x2x4,4x4x2" 6 levels, 512 slices (large dense map)
  static HierarchyOptions named_layout(const std::string& name);
  static HierarchyOptions named_layout(HierarchyLayout layout);
  std::string layout_string() const;
};

class Hierarchy {
 public:
  static constexpr uint32_t kBindingCount = 7;  // HIER_BINDING_COUNT

  // Creates the build pipelines (call in Technique::setup). Throws pb::InputError on a bad layout.
  void setup(gpu::Device& gpu, const HierarchyOptions& options);
  // Records pass "cluster-build" (nested passes) for this frame; (re)allocates on a new resolution.
  // The G-buffer must be rendered already. Throws pb::InputError if the layout cannot address the
  // frame (too many roots for 32-bit keys, or more than 2^28 dense nodes).
  void build(Context& ctx);

  // Layout (valid after the first build).
  uint32_t levels() const { return uint32_t(options_.splits.size()) + 1; }
  uint32_t leaf_level() const { return levels() - 1; }
  // The level one above the leaves, whose nodes cover at most 32x32 pixels with the default layout:
  // where the top splat pass stops and directional accumulates (Paper I §4.7 "level 4").
  uint32_t accumulation_level() const { return levels() - 2; }
  uint32_t root_count() const { return roots_x_ * roots_y_; }
  uint64_t dense_nodes(uint32_t level) const;        // nodes the dense allocation holds at a level
  uint32_t first_cid(uint32_t level) const;          // cids of level l: [first_cid(l), + capacity)
  uint32_t node_capacity(uint32_t level) const;      // at most this many occupied nodes at a level
  uint32_t node_capacity() const;                    // all levels: the size of per-cid arrays
  uint32_t node_footprint_px(uint32_t level) const;  // screen pixels a node spans (x; y the same)
  uint32_t depth_slices(uint32_t level) const;       // leaf depth slices a node spans
  uint32_t total_depth_slices() const { return depth_slices(0); }
  const HierarchyOptions& options() const { return options_; }
  bool has_cones() const { return options_.normal_cones; }

  // GPU buffers, in the binding order of hierarchy.glsl.
  std::array<const gpu::Buffer*, kBindingCount> bindings() const {
    return {&info_, &masks_, &slots_, &node_keys_, &aabbs_, &cones_, &sample_leaves_};
  }
  // The same appended to a pass's resource list (HIER_BINDING = resources.size() before the call).
  void append_bindings(std::vector<gpu::Resource>& resources) const {
    for (const gpu::Buffer* b : bindings()) resources.push_back(b);
  }
  // The layout block as the host filled it (the per-frame fields are the GPU's, in info()).
  const layout::HierInfo& host_layout() const { return layout_; }
  const gpu::Buffer& info() const { return info_; }  // host-visible HierInfo
  const gpu::Buffer& masks() const { return masks_; }
  const gpu::Buffer& slots() const { return slots_; }
  const gpu::Buffer& node_keys() const { return node_keys_; }
  const gpu::Buffer& aabbs() const { return aabbs_; }
  const gpu::Buffer& cones() const { return cones_; }
  const gpu::Buffer& sample_leaves() const { return sample_leaves_; }
  // This frame's occupied nodes per level; read on the host after the frame's work has completed.
  uint32_t occupied(uint32_t level) const;

  // Bytes per Paper I Table 1 row: "Cluster Hierarchy" (AABBs + child masks + node keys),
  // "Final Bounds" (the key -> cid map, leaf bases and per-pixel leaf keys), "Normal Cone" (0
  // without cones).
  uint64_t bytes_hierarchy() const {
    return aabbs_.size() + masks_.size() + node_keys_.size() -
           uint64_t(node_capacity(levels() - 2)) * 4;
  }
  uint64_t bytes_final_bounds() const {
    return slots_.size() + sample_leaves_.size() + uint64_t(node_capacity(levels() - 2)) * 4;
  }
  uint64_t bytes_normal_cone() const { return options_.normal_cones ? cones_.size() : 0; }

 private:
  void allocate(gpu::Device& gpu, uint32_t width, uint32_t height);

  HierarchyOptions options_;
  uint32_t width_ = 0, height_ = 0, roots_x_ = 0, roots_y_ = 0;
  layout::HierInfo layout_{};
  gpu::Buffer info_, masks_, slots_, node_keys_, aabbs_, cones_, sample_leaves_;
  gpu::Pipeline depth_range_, occupancy_, leaf_alloc_, leaf_bounds_, leaf_finalize_, leaf_cones_,
      propagate_;
};

}  // namespace pb::toolkit
