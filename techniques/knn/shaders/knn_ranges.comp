#version 460
// build/ranges, after the counting sort: the first and last item of each key's run mark its cell's
// range [first, end) in the sorted order, and each photon is copied to its sorted place in the
// compact array the gather reads (position, flux, direction, record index), so that a cell's
// photons lie together in memory.
#include "knn_common.glsl"
layout(local_size_x = 64) in;
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.photon_count) return;
  uvec2 item = sorted_items[i];
  uint key = item.y;
  if (i == 0u || sorted_items[i - 1u].y != key) {
    cells[key].x = i;
    atomicAdd(stats[KNN_STAT_OCCUPIED], 1u);
  }
  if (i + 1u == push.photon_count || sorted_items[i + 1u].y != key) cells[key].y = i + 1u;
  PhotonRecord ph = photons[item.x];
  compact[i] = KnnPhoton(ph.position, item.x, ph.power, 0u, ph.direction, 0.0);
}
