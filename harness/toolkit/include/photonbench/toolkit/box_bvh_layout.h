// The toolkit's GPU box BVH (photonbench/toolkit/box_bvh.h), its records written once for C++ and
// GLSL: every vec3 is followed by a 4-byte scalar, so std430 offsets equal the packed C++ ones
// (box_bvh.h static_asserts them).
// GLSL: #include "photonbench/toolkit/box_bvh_layout.h"; C++: box_bvh.h includes it in
// namespace pb::toolkit.
#ifndef PB_TOOLKIT_BOX_BVH_LAYOUT_H
#define PB_TOOLKIT_BOX_BVH_LAYOUT_H

#ifdef __cplusplus
#define PB_BVH_VEC3 glm::vec3
#define PB_BVH_UINT uint32_t
#else
#define PB_BVH_VEC3 vec3
#define PB_BVH_UINT uint
#endif

// One item's axis-aligned box, what the caller hands to the build (item i is boxes[i]). A box with
// lo > hi on any axis is empty: it is built over but never met by a walk. 32 bytes.
struct BvhBox {
  PB_BVH_VEC3 lo;
  PB_BVH_UINT pad0;
  PB_BVH_VEC3 hi;
  PB_BVH_UINT pad1;
};

// A node of the linear BVH (Karras 2012 over the U distinct 30-bit Morton codes of the boxes'
// centres): internal nodes 0 .. U-2 (node 0 the root), then the U runs of equal codes as leaves
// U-1 .. 2U-2 (with U = 1 the one leaf is node 0). Every node covers the Morton-sorted items
// [first, first + count), whose item indices are the build's `items` buffer. 48 bytes.
struct BvhNode {
  PB_BVH_VEC3 lo;
  PB_BVH_UINT left;  // child node; PB_BVH_NONE for a leaf (a run of equal codes)
  PB_BVH_VEC3 hi;
  PB_BVH_UINT right;
  PB_BVH_UINT first;
  PB_BVH_UINT count;
  PB_BVH_UINT parent;  // PB_BVH_NONE at the root
  PB_BVH_UINT visits;  // the bottom-up pass that joined it (0: not yet)
};

#define PB_BVH_NONE 0xffffffffu

// Words of the build's control buffer (uint).
#define PB_BVH_CTL_MIN 0u        // 3 words: the box centres' bounds, order-preserving float bits
#define PB_BVH_CTL_MAX 3u        // 3 words
#define PB_BVH_CTL_RUNS 6u       // U, the distinct Morton codes (the leaves)
#define PB_BVH_CTL_INNER 7u      // internal nodes joined by the bottom-up passes
#define PB_BVH_CTL_LONG_RUNS 8u  // runs longer than the loop budget (their boxes cut short)
#define PB_BVH_CTL_COUNT 9u      // items built over
#define PB_BVH_CTL_WORDS 16u

// Push block of every build pass.
struct BvhPush {
  PB_BVH_UINT count;   // items
  PB_BVH_UINT pass;    // the bottom-up pass's number, from 1
  PB_BVH_UINT budget;  // loop steps one invocation may take
  PB_BVH_UINT pad;
};

#undef PB_BVH_VEC3
#undef PB_BVH_UINT

#endif  // PB_TOOLKIT_BOX_BVH_LAYOUT_H
