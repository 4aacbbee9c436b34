#version 460
// NodeFlux, pass 2: one invocation per word of an occupied node: the 64-bit sum in watts, as float
// bits into the low word. Words of channel c sit at 3 g + c of a node's words_per_node.
#include "node_flux_common.glsl"
layout(local_size_x = 64) in;
void main() {
  uint i = gl_GlobalInvocationID.x;
  uint node = i / push.words_per_node, word = i % push.words_per_node;
  if (node >= resolve_args[3]) return;
  // The node-th occupied node, level by level (their cids are contiguous per level).
  uint level = 0u;
  while (level < push.stop_level && node >= hier_count(level)) node -= hier_count(level++);
  uint at = hier_level_cid(level, node) * push.words_per_node + word;
  float watts = pb_flux_watts(flux_lo[at], flux_hi[at], push.watts_per_unit[word % 3u]);
  flux_lo[at] = floatBitsToUint(watts);
}
