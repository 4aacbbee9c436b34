// The view-sample cluster hierarchy's layout block, written once for C++ and GLSL (like
// photonbench/photon_layout.h): pb::toolkit::Hierarchy fills the CPU part when the resolution
// changes, the cluster-build passes write the GPU part every frame, and every shader that reads the
// hierarchy binds it as the first of the hierarchy's buffers (toolkit/hierarchy.glsl). std430,
// every member a 16-byte vector so the C++ and GLSL offsets agree without padding rules.
//
// Terms (Paper I §4.1, after Sintorn et al. 2014): level 0 holds the roots (one per root tile of
// the screen, whole depth range); level l+1 splits each level-l node into split[l].x * .y * .z
// children (at most 32); the last level holds the leaves (a block of leaf_px pixels x one depth
// slice). A node's key is (parent key << 5) | child index (child index = cx + sx * (cy + sy * cz));
// a root's key is its root index. Storage per level is dense (indexed by key, Paper I §5.2
// "statically allocates memory for a dense hierarchy") for child masks and the key -> compact-id
// map; everything else (AABB, cone, the techniques' per-node data) is indexed by a compact node id
// ("cid") handed out as nodes become occupied; a leaf's cid is its parent's leaf base + the number
// of occupied siblings before it (no dense leaf map).
#ifndef PB_TOOLKIT_HIERARCHY_LAYOUT_H
#define PB_TOOLKIT_HIERARCHY_LAYOUT_H

#define HIER_MAX_LEVELS 8
#define HIER_FLAG_CONES 1u
#define HIER_NO_LEAF 0xffffffffu  // sample_leaves[] of a background pixel

#ifdef __cplusplus
#include <glm/glm.hpp>
namespace pb::toolkit::layout {
using uvec4 = glm::uvec4;
using uint = uint32_t;
#endif

struct HierInfo {
  uvec4 dims;   // x levels (L), y roots_x, z roots_y, w root count
  uvec4 frame;  // x width, y height (pixels), z leaf block width, w leaf block height (pixels)
  uvec4
      grid;  // x, y: leaf grid size in blocks (roots * product of splits), z depth slices, w flags
  uvec4 split[HIER_MAX_LEVELS];    // xyz: how a level-l node splits into level l+1 (l < L-1)
  uvec4 divisor[HIER_MAX_LEVELS];  // xyz: leaf-grid digit divisors of the child index below level l
  // x: first word of level l in masks[] (l < L-1; masks[0, roots) are the roots' occupancy flags;
  //    for l = L-1: the first word of the leaf bases, one per level-(L-2) node: the cid of its
  //    first leaf, its leaves' cids being consecutive in child-mask bit order),
  // y: first word of level l in slots[] (key -> cid map; l < L-1, leaves have no map),
  // z: first cid of level l, w: cid capacity.
  uvec4 level[HIER_MAX_LEVELS];
  // x, y: screen pixels a level-l node spans; z: depth slices it spans; w: dense nodes at level l.
  uvec4 footprint[HIER_MAX_LEVELS];
  // Written by cluster-build each frame: x, y: min / max view depth (float bits) of the samples, z:
  // near depth of slice 0 (float bits), w: 1 / ln(q), q the depth ratio of one slice (float bits).
  uvec4 depth;
  uint counts[HIER_MAX_LEVELS];  // occupied nodes per level
};

#ifdef __cplusplus
}  // namespace pb::toolkit::layout
#endif
#endif
