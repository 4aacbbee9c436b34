// The knn technique's GPU layouts, written once for C++ and GLSL (GLSL: `#include
// "../knn_layout.h"` from shaders/): the compile-time cap on k, the grid's push block, the compact
// photon the gather reads, the statistics words and the radius histogram's bins. Every vec3 is
// followed by a 4-byte scalar, so std430 offsets equal the packed C++ ones (knn_grid.cpp
// static_asserts the sizes).
#ifndef KNN_LAYOUT_H
#define KNN_LAYOUT_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace knn {
using vec3 = glm::vec3;
using uint = uint32_t;
#endif

// The largest k a query keeps (its max-heap is an array of this many entries per invocation). 512
// covers seed 003's largest k_PM (511, its Wall scene, Table 2); the schema's range of `k` ends
// here.
#define KNN_MAX_K 512u

// Bins of the radius histogram: seed 003 Table 3's, 20 bins of equal width (0.05 there) and one
// for everything at or beyond 20 widths ("> 1.00").
#define KNN_RADIUS_BINS 21u

// Words of the statistics buffer (host-visible, read after the frame). 64-bit counters take two
// words (low, high: PB_ADD64).
#define KNN_STAT_VISITED 0u       // photons whose distance a query computed (64-bit)
#define KNN_STAT_CELLS 2u         // grid cells a query opened (64-bit)
#define KNN_STAT_FOUND 4u         // sum over queries of the photons found (<= k each) (64-bit)
#define KNN_STAT_QUERIES 6u       // lit view samples queried
#define KNN_STAT_SHORT 7u         // queries that found fewer than k photons within r_max
#define KNN_STAT_TRUNCATED 8u     // queries cut short by the loop budget
#define KNN_STAT_HISTOGRAM 10u    // KNN_RADIUS_BINS words: queries per radius bin
#define KNN_STAT_QUERY_WORDS 31u  // the words above, cleared before each gather
#define KNN_STAT_OCCUPIED 31u     // grid cells holding at least one photon (cleared by the build)
#define KNN_STAT_HEAP 32u         // heap entries read or written (64-bit; cleared before a gather)
#define KNN_STAT_WORDS 34u

// Modes of the gather's push block.
#define KNN_KERNEL_UNIFORM 0u       // K = 1 / (pi r^2): Jensen's estimate
#define KNN_KERNEL_EPANECHNIKOV 1u  // K = 2 / (pi r^2) (1 - d^2 / r^2)
#define KNN_SPARSE_RMAX 0u          // fewer than k found: r = r_max (the disc searched)
#define KNN_SPARSE_FARTHEST 1u      // fewer than k found: r = the farthest photon found
#define KNN_SEARCH_GRID 0u          // the uniform grid in shells near to far (the stronger)
#define KNN_SEARCH_KDTREE 1u        // seed 003's: a balanced kd-tree from r_max (Jensen 1996)
#define KNN_HEAP_PRIVATE 0u         // the k candidates in the invocation's own array
#define KNN_HEAP_GLOBAL 1u          // in a storage buffer, seed 003 §7's "slow global memory"

// The grid and the query settings, one push block for every kernel (96 bytes).
struct KnnPush {
  vec3 origin;    // grid corner (the photons' bounds, less half a cell), m
  float cell;     // cell side, m
  vec3 grid_max;  // the grid's far corner, m
  uint photon_count;
  uint dims_x, dims_y, dims_z, cell_count;
  uint width, height, k, kernel;
  float r_max, bin_width;
  uint sparse, budget;
  uint debug;         // 1: write each query's photons to the debug buffer (tests)
  uint debug_stride;  // words per query in the debug buffer
  uint search;        // KNN_SEARCH_*: with the kd-tree, `compact` holds the tree's nodes
  uint heap;          // KNN_HEAP_*
};

// A photon as the gather reads it, in cell order (48 bytes): position, flux, direction of travel,
// and the index of its PhotonRecord (tests compare photon identities). In the kd-tree the photons
// are the nodes, in the implicit order of a balanced tree (node i's children 2i + 1 and 2i + 2),
// and `axis` is the splitting axis (0, 1, 2).
struct KnnPhoton {
  vec3 position;
  uint index;
  vec3 power;
  uint axis;
  vec3 direction;
  float pad1;
};

#ifdef __cplusplus
}  // namespace knn
#endif

#endif  // KNN_LAYOUT_H
