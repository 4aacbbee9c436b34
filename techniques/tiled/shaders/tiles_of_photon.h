// The tiles a photon's sphere of influence may touch (Mara et al.'s tiled splatting as Paper I
// describes it): the screen rectangle of the sphere, from the projections of its bounding cube's
// eight corners (conservative: the cube contains the sphere, and while every corner lies in front of
// the camera the projected hull contains the projected sphere; otherwise the whole screen), then per
// tile the depth-range test [z - r, z + r] against the tile's [zmin, zmax].
bool photon_tile_rect(vec3 p, out uvec2 lo, out uvec2 hi) {
  float r = push.radius;
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

bool tile_overlaps(uint t, float z) {
  float zmin = uintBitsToFloat(bounds[t]);
  float zmax = uintBitsToFloat(bounds[push.tile_count + t]);
  return z - push.radius <= zmax && z + push.radius >= zmin;
}
