#version 460
// Box BVH build / hierarchy: internal node i of the binary radix tree over the U distinct Morton
// codes (Karras 2012, "Maximizing parallelism in the construction of BVHs, octrees and k-d
// trees"), one node per invocation. Writes each node's children and their parent pointers.
#include "bvh_build.glsl"
layout(local_size_x = 256) in;

uint runs;
// Length of the common prefix of codes i and j; -1 outside [0, U).
int delta(int i, int j) {
  if (j < 0 || j >= int(runs)) return -1;
  return 31 - findMSB(unique_keys[i] ^ unique_keys[j]);
}

void main() {
  runs = control[PB_BVH_CTL_RUNS];
  int i = int(gl_GlobalInvocationID.x);
  if (runs < 2u || i >= int(runs) - 1) return;
  int d = delta(i, i + 1) - delta(i, i - 1) >= 0 ? 1 : -1;
  int delta_min = delta(i, i - d);
  int l_max = 2;
  while (delta(i, i + l_max * d) > delta_min) l_max *= 2;
  int l = 0;
  for (int t = l_max / 2; t >= 1; t /= 2)
    if (delta(i, i + (l + t) * d) > delta_min) l += t;
  int j = i + l * d;
  int delta_node = delta(i, j);
  int s = 0;
  int divisor = 2;
  for (;;) {
    int t = (l + divisor - 1) / divisor;
    if (delta(i, i + (s + t) * d) > delta_node) s += t;
    if (t <= 1) break;
    divisor *= 2;
  }
  int gamma = i + s * d + min(d, 0);
  uint leaves = runs - 1u;
  uint left = min(i, j) == gamma ? leaves + uint(gamma) : uint(gamma);
  uint right = max(i, j) == gamma + 1 ? leaves + uint(gamma + 1) : uint(gamma + 1);
  nodes[i].left = left;
  nodes[i].right = right;
  nodes[i].visits = 0u;
  nodes[left].parent = uint(i);
  nodes[right].parent = uint(i);
  if (i == 0) nodes[0].parent = PB_BVH_NONE;
}
