#version 460
// cluster-build/occupancy, second half: one invocation per occupied node of the level above the
// leaves reserves consecutive cids for its occupied leaves (one atomicAdd of the mask's popcount),
// so a leaf's cid is found from its parent without a dense leaf map (hier_cid), records the leaves'
// keys and initialises their bounds (empty, in the ordered-uint encoding) and normal sums.
#include "hierarchy_build.glsl"
layout(local_size_x = 64) in;
void main() {
  uint leaf = hier_leaf_level(), level = leaf - 1u;
  uint i = gl_GlobalInvocationID.x;
  if (i >= hier_count(level)) return;
  uint parent_cid = hier_level_cid(level, i);
  uint parent = hier_node_keys[parent_cid];
  uint mask = hier_mask(level, parent);
  uint base = hier.level[leaf].z + atomicAdd(hier.counts[leaf], uint(bitCount(mask)));
  hier_masks[hier.level[leaf].x + i] = base;
  for (uint m = mask; m != 0u; m &= m - 1u) {
    uint cid = base++;
    hier_node_keys[cid] = hier_child_key(parent, uint(findLSB(m)));
    for (uint k = 0u; k < 3u; ++k) {
      hier_aabb_words[cid * 6u + k] = 0xffffffffu;  // ordered +max: empty min
      hier_aabb_words[cid * 6u + 3u + k] = 0u;      // ordered -max: empty max
    }
    if (hier_has_cones())
      for (uint k = 0u; k < 4u; ++k) hier_cone_words[cid * 4u + k] = 0u;
  }
}
