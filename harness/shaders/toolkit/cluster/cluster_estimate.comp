#version 460
// radiance-estimate (Paper I §4.4, the estimator of tiled, toolkit/photon_gather.glsl): one
// invocation per view sample over the photon lists of its leaf and all of the leaf's ancestors
// ("the lists of photons of the containing nodes"); trivial adds the containing nodes' accumulated
// flux (§4.6: "we add this flux multiplied by the BRDF"). A sample's lists, concatenated, hold each
// photon at most once (a photon stored at a node is not stored below it), so their total length is
// at most the photon count; this dispatch reads its slice of them.
#define PB_PROFILE_SLOT 0u
#include "cluster_common.glsl"
#include "toolkit/photon_gather.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
void main() {
  pb_gather_group_begin();
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pb_in_frame(pixel, hier.frame.xy)) {
    vec3 x, n, albedo, radiance = vec3(0.0);
    uint key = hier_sample_leaf(pixel);
    if (pb_lit_sample(pixel, x, n, albedo) && key != HIER_NO_LEAF) {
      float r2 = push.estimate_radius * push.estimate_radius;
      vec3 flux = vec3(0.0);
      uint accepted = 0u, read = 0u;
      uint base = 0u;  // where this node's list starts in the sample's concatenated lists
      bool trivial = cluster_variant() == CLUSTER_VARIANT_TRIVIAL && push.list_first == 0u;
      for (int level = int(hier_leaf_level()); level >= 0; --level) {
        uint cid = hier_cid(uint(level), key);
        uvec2 list = pb_list_range(cid);
        uvec2 part = pb_slice_of(base, list.y, push.list_first);
        accepted += pb_gather(list.x, part.x, part.y, x, n, r2, flux);
        read += part.y - part.x;
        base += list.y;
        if (trivial)  // resolved to watts (NodeFlux::resolve)
          flux += uintBitsToFloat(uvec3(node_flux_lo[cid * 3u], node_flux_lo[cid * 3u + 1u],
                                        node_flux_lo[cid * 3u + 2u]));
        key = hier_parent_key(key);
      }
      pb_gather_tally(read, accepted);
      radiance = pb_lambert_radiance(albedo, flux, r2);
      if (push.list_first > 0u) radiance += imageLoad(indirect_out, pixel).rgb;
    }
    if (push.list_first == 0u || any(notEqual(radiance, vec3(0.0))))
      imageStore(indirect_out, pixel, vec4(radiance, 1.0));
  }
  PB_GATHER_GROUP_END(stats, CLUSTER_STAT_READ, CLUSTER_STAT_REJECTED);
}
