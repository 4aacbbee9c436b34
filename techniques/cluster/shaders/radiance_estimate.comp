#version 460
// radiance-estimate (Paper I §4.4, the same estimator as tiled): one invocation per view sample
// loops over the photon lists of its leaf cluster and all of the leaf's ancestors ("the lists of
// photons of the containing nodes"); a photon contributes when the sample lies inside its sphere and
// the photon arrives from above the sample's tangent plane: I += f Phi with the Lambertian
// f = albedo / pi, and L = I / (pi r^2). With the trivial variant the containing nodes' accumulated
// flux is added too (Paper I §4.6: "we add this flux multiplied by the BRDF"). Only diffuse (and
// emissive) samples receive indirect light (path class C D (D|S)* D (D|S)* L).
//
// The lists of one sample, concatenated, hold each photon at most once (a photon stored at a node is
// not stored below it), so their total length is at most the photon count; they are read in slices of
// push.list_slice entries, one dispatch each (llvmpipe ends an invocation's loops after 65535
// iterations in all), later slices adding to the image.
#include "cluster_common.h"
layout(local_size_x = 8, local_size_y = 8) in;
const float PI = 3.14159265358979;
shared uint group_read, group_rejected;

void main() {
  if (gl_LocalInvocationIndex == 0u) {
    group_read = 0u;
    group_rejected = 0u;
  }
  barrier();
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  bool inside = pixel.x < int(hier.frame.x) && pixel.y < int(hier.frame.y);
  vec3 radiance = vec3(0.0);
  if (inside) {
    vec4 pos = imageLoad(gbuffer_position, pixel);
    vec4 albedo = imageLoad(gbuffer_albedo, pixel);
    int type = int(albedo.w);
    uint key = hier_sample_leaf(pixel);
    if (pos.w > 0.0 && key != HIER_NO_LEAF &&
        (type == PB_MATERIAL_DIFFUSE || type == PB_MATERIAL_EMISSIVE)) {
      vec3 n = imageLoad(gbuffer_normal, pixel).xyz;
      float r2 = push.radius * push.radius;
      vec3 flux = vec3(0.0);
      uint accepted = 0u, read = 0u;
      uint first = push.list_first, last = push.list_first + push.list_slice;
      uint base = 0u;  // position of this node's list in the sample's concatenated lists
      for (int level = int(hier_leaf_level()); level >= 0; --level) {
        uint cid = hier_cid(uint(level), key);
        uint begin = list_offsets[cid];
        uint end = min(begin + list_counts[cid], push.list_capacity);
        uint length = end > begin ? end - begin : 0u;
        uint lo = max(first, base), hi = min(last, base + length);
        for (uint k = lo; k < hi; ++k) {
          PhotonRecord ph = photons[lists[begin + (k - base)]];
          vec3 d = ph.position - pos.xyz;
          if (dot(d, d) <= r2 && dot(n, ph.direction) < 0.0) {
            flux += ph.power;
            ++accepted;
          }
        }
        if (hi > lo) read += hi - lo;
        base += length;
        if (push.variant == VARIANT_TRIVIAL && push.list_first == 0u)
          flux += vec3(node_flux[cid * 3u], node_flux[cid * 3u + 1u], node_flux[cid * 3u + 2u]) /
                  push.flux_scale;
        key = hier_parent_key(key);
      }
      atomicAdd(group_read, read);
      atomicAdd(group_rejected, read - accepted);
      radiance = albedo.rgb / PI * flux / (PI * r2);
      if (push.list_first > 0u) radiance += imageLoad(indirect_out, pixel).rgb;
    }
    if (push.list_first == 0u || any(notEqual(radiance, vec3(0.0))))
      imageStore(indirect_out, pixel, vec4(radiance, 1.0));
  }
  barrier();
  if (gl_LocalInvocationIndex == 0u) {
    add64(STAT_READ, group_read);
    add64(STAT_REJECTED, group_rejected);
  }
}
