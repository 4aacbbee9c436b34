#version 460
// radiance-estimate (Paper I §4.7): "we no longer have to process a list but simply evaluate the
// incoming flux from each direction, for all nodes that contain the view sample". One invocation
// per pixel reads the buckets of its stop-level node (accumulation level or leaf) and its ancestors
// (the nodes a photon can have deposited into for this sample) and sums E = sum_o w_o(n) Phi_o /
// (pi r^2), n the view-space normal and w_o the octant weight (2cos(n, d_o) by default). Only
// diffuse (and emissive, which the tracer treats as diffuse) samples are lit, as in tiled: the path
// class is C D (D|S)* D (D|S)* L. The result is irradiance (W/m^2); the blur applies the BRDF.
#include "scene_layout.h"
#include "directional_common.h"
#define HIER_BINDING 5
#include "../../cluster/shaders/hierarchy.glsl"
#include "octants.h"
layout(local_size_x = 8, local_size_y = 8) in;
layout(push_constant) uniform Push { DirParams params; };
layout(std430, binding = 0) readonly buffer Flux { uint flux[]; };
layout(binding = 1, rgba32f) readonly uniform image2D gbuffer_position;
layout(binding = 2, rgba32f) readonly uniform image2D gbuffer_normal;
layout(binding = 3, rgba32f) readonly uniform image2D gbuffer_albedo;
layout(binding = 4, rgba32f) writeonly uniform image2D irradiance_out;

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pixel.x >= int(params.size.x) || pixel.y >= int(params.size.y)) return;
  vec3 e = vec3(0.0);
  int type = int(imageLoad(gbuffer_albedo, pixel).w);
  uint leaf = hier_sample_leaf(pixel);
  if (imageLoad(gbuffer_position, pixel).w > 0.0 && leaf != HIER_NO_LEAF &&
      (type == PB_MATERIAL_DIFFUSE || type == PB_MATERIAL_EMISSIVE)) {
    vec3 n_world = imageLoad(gbuffer_normal, pixel).xyz;
    if ((params.counts.z & DIR_FLAG_DEBUG_NORMAL) != 0u) {
      e = abs(n_world);
    } else {
      vec3 n = normalize(mat3(params.view) * n_world);
      float weights[8];
      if ((params.counts.z & DIR_FLAG_WEIGHT_CLIP) != 0u) {
        octant_weights_clip(n, weights);
      } else {
        for (uint o = 0u; o < 8u; ++o) weights[o] = octant_weight_cos2(n, o);
      }
      uint leaf_level = hier_leaf_level();
      for (int level = int(params.counts.y); level >= 0; --level) {
        uint key = leaf >> (5u * (leaf_level - uint(level)));
        uint at = hier_cid(uint(level), key) * 24u;
        for (uint o = 0u; o < 8u; ++o)
          e += weights[o] * vec3(flux[at + 3u * o], flux[at + 3u * o + 1u], flux[at + 3u * o + 2u]);
      }
      e *= params.radius.y * params.radius.w;  // fixed point -> W, then / (pi r^2)
    }
  }
  imageStore(irradiance_out, pixel, vec4(e, 1.0));
}
