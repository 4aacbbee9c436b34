#version 460
// splat/count and splat/insert (Paper I §5.1's tiled splatting, after Mara et al. 2013, in the
// count / prefix-sum / insert scheme of toolkit/photon_lists.glsl): one invocation per photon tests
// its sphere of influence against the tiles under its screen rectangle, the rectangle of the
// projections of its bounding cube's eight corners (conservative: the cube contains the sphere, and
// while every corner lies in front of the camera the projected hull contains the projected sphere;
// otherwise the whole screen), then per tile the depth-range test [z - r, z + r] against the tile's
// [zmin, zmax]. The count run adds 1 per touched tile, the insert run writes the photon's index:
// one shader, so both runs take the same tests.
#include "tiled_common.glsl"
layout(local_size_x = 64) in;

bool photon_tile_rect(vec3 p, float r, out uvec2 lo, out uvec2 hi) {
  vec2 nlo = vec2(1e30), nhi = vec2(-1e30);
  bool behind = false;
  for (int c = 0; c < 8; ++c) {
    vec3 corner = p + r * vec3((c & 1) != 0 ? 1.0 : -1.0, (c & 2) != 0 ? 1.0 : -1.0,
                               (c & 4) != 0 ? 1.0 : -1.0);
    vec4 clip = push.view_projection * vec4(corner, 1.0);
    if (clip.w <= 1e-6) {
      behind = true;
    } else {
      vec2 ndc = clip.xy / clip.w;
      nlo = min(nlo, ndc);
      nhi = max(nhi, ndc);
    }
  }
  if (behind) {
    nlo = vec2(-1.0);
    nhi = vec2(1.0);
  }
  if (any(greaterThan(nlo, vec2(1.0))) || any(lessThan(nhi, vec2(-1.0)))) return false;
  vec2 size = vec2(push.width, push.height);
  vec2 plo = clamp((nlo * 0.5 + 0.5) * size, vec2(0.0), size - 1.0);
  vec2 phi = clamp((nhi * 0.5 + 0.5) * size, vec2(0.0), size - 1.0);
  lo = uvec2(plo) / push.tile_size;
  hi = uvec2(phi) / push.tile_size;
  return true;
}

bool tile_overlaps(uint t, float z, float r) {
  float zmin = uintBitsToFloat(bounds[t]);
  float zmax = uintBitsToFloat(bounds[push.tile_count + t]);
  return z - r <= zmax && z + r >= zmin;
}

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.photon_count) return;
  vec3 p = photons[i].position;
  float r = push.radius;
  uvec2 lo, hi;
  if (!photon_tile_rect(p, r, lo, hi)) return;
  float z = dot(push.depth_plane.xyz, p) + push.depth_plane.w;
  for (uint ty = lo.y; ty <= hi.y; ++ty)
    for (uint tx = lo.x; tx <= hi.x; ++tx) {
      uint t = ty * push.tiles_x + tx;
      if (!tile_overlaps(t, z, r)) continue;
      if (push.mode == TILED_MODE_COUNT)
        pb_list_count(t);
      else
        pb_list_insert(t, i);
    }
}
