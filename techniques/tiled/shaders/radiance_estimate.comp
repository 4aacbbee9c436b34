#version 460
// radiance-estimate (Paper I §4.4, the same estimator for tiled and cluster): one invocation per
// pixel loops over its tile's list, reading photons from global memory interleaved with the math (no
// shared-memory preload, as Paper I §5.1 does). A photon contributes when the sample lies inside its
// sphere and the photon arrives from above the sample's tangent plane; I += f * Phi with the
// Lambertian f = albedo / pi, and L = I / (pi r^2) (constant kernel, no smoothing). Only diffuse (and
// emissive, which the tracer treats as diffuse) samples receive indirect light: the path class is
// C D (D|S)* D (D|S)* L.
#include "photon_layout.h"
#include "scene_layout.h"
#include "tiled_common.h"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Photons { PhotonRecord photons[]; };
layout(std430, binding = 1) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = 2) readonly buffer Counts { uint counts[]; };
layout(std430, binding = 3) readonly buffer Lists { uint lists[]; };
layout(std430, binding = 4) buffer Stats { uint stats[]; };
layout(binding = 5, rgba32f) readonly uniform image2D gbuffer_position;
layout(binding = 6, rgba32f) readonly uniform image2D gbuffer_normal;
layout(binding = 7, rgba32f) readonly uniform image2D gbuffer_albedo;
layout(binding = 8, rgba32f) uniform image2D indirect_out;
const float PI = 3.14159265358979;
shared uint group_read, group_rejected;

// An exact 64-bit counter from two 32-bit words: the low word's carry goes to the high word.
void add64(uint at, uint value) {
  if (value == 0u) return;
  uint old = atomicAdd(stats[at], value);
  if (old + value < old) atomicAdd(stats[at + 1u], 1u);
}

void main() {
  if (gl_LocalInvocationIndex == 0u) {
    group_read = 0u;
    group_rejected = 0u;
  }
  barrier();
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  bool inside = pixel.x < int(push.width) && pixel.y < int(push.height);
  vec3 radiance = vec3(0.0);
  if (inside) {
    vec4 pos = imageLoad(gbuffer_position, pixel);
    vec4 albedo = imageLoad(gbuffer_albedo, pixel);
    int type = int(albedo.w);
    if (pos.w > 0.0 && (type == PB_MATERIAL_DIFFUSE || type == PB_MATERIAL_EMISSIVE)) {
      vec3 n = imageLoad(gbuffer_normal, pixel).xyz;
      uint t = (uint(pixel.y) / push.tile_size) * push.tiles_x + uint(pixel.x) / push.tile_size;
      uint begin = offsets[t];
      uint end = min(begin + counts[t], push.capacity);
      float r2 = push.radius * push.radius;
      vec3 flux = vec3(0.0);
      uint accepted = 0u;
      // One slice of the list per dispatch: llvmpipe (lavapipe) silently ends a shader invocation's
      // loops after 65535 iterations in all (gallivm's loop limiter, shared by every loop of the
      // shader), which would drop the rest of a long list without a trace. The host dispatches
      // ceil(photons / slice) times; later slices add to the image.
      uint first = min(begin + push.list_first, end);
      uint last = min(first + push.list_slice, end);
      for (uint k = first; k < last; ++k) {
        PhotonRecord ph = photons[lists[k]];
        vec3 d = ph.position - pos.xyz;
        if (dot(d, d) <= r2 && dot(n, ph.direction) < 0.0) {
          flux += ph.power;
          ++accepted;
        }
      }
      uint read = last - first;
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
