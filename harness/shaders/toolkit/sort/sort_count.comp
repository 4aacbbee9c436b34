#version 460
// Counting sort, pass 1: items per key (sort_common.glsl).
#include "sort_common.glsl"
void main() {
  uvec2 item;
  uint key;
  if (sort_item(item, key)) atomicAdd(sort_bins[key], 1u);
}
