#version 460
// build/keys: each photon's grid cell, as an item (photon index, cell key) for the toolkit's
// CountingSort (knn_common.glsl).
#include "knn_common.glsl"
layout(local_size_x = 64) in;
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.photon_count) return;
  items[i] = uvec2(i, knn_cell_index(knn_cell_of(photons[i].position)));
}
