#version 460
// cluster-build/occupancy (Paper I §4.1, Fig. 3 "occupancy"): each view sample finds its leaf
// cluster (screen block x exponential depth slice), records it in sample_leaves[], and marks it
// occupied in its parent's child mask, then the parent in the grandparent's, and so on while it is
// the first to do so. The first sample to occupy an inner node (atomicOr returned the bit clear)
// hands the node its compact id (appending it to its level's list of occupied nodes) and writes the
// key -> cid map entry; leaves get theirs next, in hierarchy_leaf_alloc. Masks and root flags are
// cleared before this pass; the map is never cleared (an entry is read only where a mask says the
// node exists).
#include "hierarchy_build.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
void main() {
  ivec2 pixel;
  if (!hier_pixel(pixel)) return;
  float near = uintBitsToFloat(hier.depth.x), far = uintBitsToFloat(hier.depth.y);
  if (hier.depth.y == 0u) {  // no view sample this frame
    hier_sample_leaves[uint(pixel.y) * hier.frame.x + uint(pixel.x)] = HIER_NO_LEAF;
    return;
  }
  // Slices are cubical (ratio q = 1 + the leaf block's angular size) unless that many slices cannot
  // span [near, far]: then they stretch to cover it.
  float ln_q = max(hp.ln_q_min, log(far / near) / float(hier.grid.z) * 1.0001);
  float inv_ln_q = 1.0 / ln_q;
  if (pixel == ivec2(0)) hier.depth.zw = uvec2(floatBitsToUint(near), floatBitsToUint(inv_ln_q));

  vec4 pos = imageLoad(gbuffer_position, pixel);
  uint sample_index = uint(pixel.y) * hier.frame.x + uint(pixel.x);
  if (pos.w <= 0.0) {
    hier_sample_leaves[sample_index] = HIER_NO_LEAF;
    return;
  }
  uint key = hier_leaf_key_at(uvec2(pixel), hier_view_depth(pos.xyz), near, inv_ln_q);
  hier_sample_leaves[sample_index] = key;
  uint leaf = hier_leaf_level();
  for (uint level = leaf;; --level) {
    uint old, bit;
    if (level == 0u) {
      bit = 1u;
      old = atomicOr(hier_masks[key], bit);  // masks[0, roots): root occupancy flags
    } else {
      bit = 1u << (key & 31u);
      old = atomicOr(hier_masks[hier.level[level - 1u].x + hier_parent_key(key)], bit);
    }
    if ((old & bit) != 0u) break;  // another sample created this node (and its ancestors)
    if (level != leaf) {           // leaves get their cids in hierarchy_leaf_alloc
      uint cid = hier.level[level].z + atomicAdd(hier.counts[level], 1u);
      hier_slots[hier.level[level].y + key] = cid;
      hier_node_keys[cid] = key;
    }
    if (level == 0u) break;
    key = hier_parent_key(key);
  }
}
