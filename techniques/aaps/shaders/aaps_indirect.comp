#version 460
// Pass "indirect" (seed 004 §5.2, indirect: splat_bvh): caustics seen through mirrors and glass.
// Per pixel whose camera path passed S vertices before its first diffuse vertex, the path's last
// segment, limited to the raster depth test's window t_hit (1 +- depth_margin) (§3.3.4), walks the
// box BVH over the splats' quads; the any-hit hook is the fragment shader's test: the segment's
// crossing of the splat's plane inside that window and inside the ellipse (§3.3.3). The covering
// splats' brightness is the caustic irradiance E there, and tau albedo / pi E the radiance the
// pixel sees (as aaps_apply.glsl turns E into radiance on directly seen receivers).
// Writes: the indirect_caustics class image, the caustics class image (the directly seen estimate
// alone, as plain AAPS hands it to shade()) and their sum into the radiance handed to shade().
#include "../splat_bvh.h"
#include "photonbench/camera_path_layout.h"
#include "photonbench/scene_layout.h"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Paths { CameraPathRecord paths[]; };
layout(std430, binding = 1) readonly buffer Splats { SplatRecord splats[]; };
layout(std430, binding = 2) readonly buffer Materials { GpuMaterial materials[]; };
layout(std430, binding = 3) coherent buffer Stats { uint stats[]; };
layout(binding = 4, rgba32f) uniform image2D radiance;
layout(binding = 5, rgba32f) writeonly uniform image2D caustics_class;
layout(binding = 6, rgba32f) writeonly uniform image2D indirect_class;
layout(push_constant) uniform Push { IndirectPush push; };
#define PB_BVH_WALK_BINDING 7
#include "toolkit/atomics.glsl"
#include "toolkit/bvh/bvh_walk.glsl"

vec3 origin, direction, irradiance = vec3(0.0);
float t_near, t_far;
uint segment_hits = 0u, ellipse_rejected = 0u, quad_misses = 0u, box_hits = 0u;

bool pb_bvh_hit(uint item) {
  ++box_hits;
  SplatRecord s = splats[item];
  float t = aaps_plane_crossing(s, origin, direction);
  // The depth test: the splat lies on the receiver within the margin, else it is another surface's.
  if (!(t >= t_near && t <= t_far)) return true;
  vec2 bary = aaps_quad_bary(s, origin + t * direction);
  if (!aaps_in_ellipse(bary)) {
    if (aaps_in_quad(bary))
      ++ellipse_rejected;
    else
      ++quad_misses;
    return true;
  }
  ++segment_hits;
  irradiance += s.brightness;
  return true;  // IgnoreHit: every covering splat adds (the raster's additive blending)
}

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pixel.x >= int(push.width) || pixel.y >= int(push.height)) return;
  CameraPathRecord path = paths[uint(pixel.y) * push.width + uint(pixel.x)];
  vec3 seen = imageLoad(radiance, pixel).rgb;  // the directly seen caustic (apply)
  vec3 indirect = vec3(0.0);
  bool through_specular = (path.flags & PB_CAMERA_PATH_SPECULAR_MASK) != 0u &&
                          (path.flags & PB_CAMERA_PATH_NO_DIFFUSE) == 0u &&
                          path.segment_length > 0.0;
  if (through_specular) {
    origin = path.segment_origin;
    direction = path.segment_direction;
    t_near = path.segment_length * (1.0 - push.depth_margin);
    t_far = path.segment_length * (1.0 + push.depth_margin);
    pb_bvh_budget = push.budget;
    bool complete = pb_bvh_segment_walk(origin, direction, t_near, t_far);
    vec3 albedo = materials[path.material].albedo_type.rgb;
    indirect = path.throughput * albedo * (1.0 / 3.14159265358979) * irradiance;
    PB_ADD64(stats, AAPS_STAT_WALKS, 1u);
    PB_ADD64(stats, AAPS_STAT_BOX_HITS, box_hits);
    PB_ADD64(stats, AAPS_STAT_SEGMENT_HITS, segment_hits);
    PB_ADD64(stats, AAPS_STAT_ELLIPSE_REJECTED, ellipse_rejected);
    PB_ADD64(stats, AAPS_STAT_QUAD_MISSES, quad_misses);
    PB_ADD64(stats, AAPS_STAT_NODES, pb_bvh_nodes_visited);
    if (!complete) atomicAdd(stats[AAPS_STAT_TRUNCATED], 1u);
  }
  imageStore(caustics_class, pixel, vec4(seen, 1.0));
  imageStore(indirect_class, pixel, vec4(indirect, 1.0));
  imageStore(radiance, pixel, vec4(seen + indirect, 1.0));
}
