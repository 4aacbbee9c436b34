#version 460
// radiance-estimate (Paper I §4.7): "we no longer have to process a list but simply evaluate the
// incoming flux from each direction, for all nodes that contain the view sample". One invocation
// per pixel reads the buckets of its stop-level node (accumulation level or leaf) and its ancestors
// (the nodes a photon can have deposited into for this sample) and sums E = sum_o w_o(n) Phi_o /
// (pi r^2), n the view-space normal and w_o the octant weight (2cos(n, d_o) by default). Only
// diffuse (and emissive) samples are lit, as in tiled. The result is irradiance (W/m^2); the blur
// applies the BRDF.
#define PB_PROFILE_SLOT 0u
#include "directional_common.glsl"
#include "octants.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (!pb_in_frame(pixel, push.limits.yz)) return;
  vec3 e = vec3(0.0), x, n_world, albedo;
  uint leaf = hier_sample_leaf(pixel);
  if (pb_lit_sample(pixel, x, n_world, albedo) && leaf != HIER_NO_LEAF) {
    if ((push.counts.z & DIR_FLAG_DEBUG_NORMAL) != 0u) {
      e = abs(n_world);
    } else {
      vec3 n = normalize(mat3(push.view) * n_world);
      float weights[8];
      if ((push.counts.z & DIR_FLAG_WEIGHT_CLIP) != 0u) {
        octant_weights_clip(n, weights);
      } else {
        for (uint o = 0u; o < 8u; ++o) weights[o] = octant_weight_cos2(n, o);
      }
      uint leaf_level = hier_leaf_level();
      for (int level = int(push.counts.y); level >= 0; --level) {
        uint key = leaf >> (5u * (leaf_level - uint(level)));
        uint at = hier_cid(uint(level), key) * 24u;
        for (uint o = 0u; o < 8u; ++o, at += 3u)  // watts (resolved after the splat)
          e += weights[o] * uintBitsToFloat(uvec3(flux_lo[at], flux_lo[at + 1u], flux_lo[at + 2u]));
      }
      e *= push.inverse_area.w;  // / (pi r^2)
    }
  }
  imageStore(irradiance_out, pixel, vec4(e, 1.0));
}
