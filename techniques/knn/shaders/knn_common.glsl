// The knn technique's one binding list and push block (KnnGrid in knn_grid.cpp binds the same list
// for every kernel), and the uniform grid's cell arithmetic.
#ifndef KNN_COMMON_GLSL
#define KNN_COMMON_GLSL

#include "../knn_layout.h"
#include "photonbench/photon_layout.h"
#include "toolkit/constants.glsl"

layout(std430, binding = 0) readonly buffer Photons { PhotonRecord photons[]; };
// (photon index, cell key) per photon, as the toolkit's CountingSort takes them, and sorted.
layout(std430, binding = 1) buffer Items { uvec2 items[]; };
layout(std430, binding = 2) buffer Sorted { uvec2 sorted_items[]; };
// Per cell: [first, end) of its photons in `compact` (0, 0: empty).
layout(std430, binding = 3) buffer Cells { uvec2 cells[]; };
layout(std430, binding = 4) buffer Compact { KnnPhoton compact[]; };
layout(std430, binding = 5) buffer Stats { uint stats[]; };
layout(std430, binding = 6) buffer Debug { uint debug_words[]; };
#ifdef KNN_GATHER  // the gather's pipeline alone has the images (KnnGrid::setup)
#define PB_GBUFFER_BINDING 7
#include "toolkit/gbuffer.glsl"
layout(binding = 10, rgba32f) writeonly uniform image2D indirect_out;
// heap: global: each query's k candidates (squared distance bits, place in `compact`) at
// k x its pixel's index (KNN_HEAP_GLOBAL; a one-entry stand-in otherwise).
layout(std430, binding = 11) buffer Heap { uvec2 heap_global[]; };
#endif

layout(push_constant) uniform Push { KnnPush push; };

uvec3 knn_dims() { return uvec3(push.dims_x, push.dims_y, push.dims_z); }

// The cell holding p, clamped into the grid (photons lie inside it; the clamp guards rounding).
uvec3 knn_cell_of(vec3 p) {
  ivec3 c = ivec3(floor((p - push.origin) / push.cell));
  return uvec3(clamp(c, ivec3(0), ivec3(knn_dims()) - 1));
}

uint knn_cell_index(uvec3 c) { return (c.z * push.dims_y + c.y) * push.dims_x + c.x; }

#endif
