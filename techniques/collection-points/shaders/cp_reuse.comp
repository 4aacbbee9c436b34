#version 460
// Pass "reuse" (Paper V §3.1, Eqs. 3-4): per CP of this frame a point walk of last frame's CP BVH
// at c_i.p; each c_{i-1} whose cylinder contains it and that passes the bilateral gates
// (|c_{i-1}.p - c_i.p| <= c_i.r, n . n' >= 0.9, the same material) adds its blended radiance L~
// with weight exp(-|dp|^2 / (2 sigma^2)), sigma = 3/4 c_i.r. The weighted mean (weights
// normalised, as the authors' code does) goes to radiance[i].xyz, w = 1 when any was taken.
#include "cp_common.glsl"
layout(local_size_x = 64) in;

CpPoint current;
vec3 sum = vec3(0.0);
float weights = 0.0;

bool pb_bvh_hit(uint item) {
  float w = cp_reuse_weight(prev_points[item], current, push.sigma_scale, push.normal_min);
  if (w > 0.0) {
    sum += w * prev_radiance[item].xyz;
    weights += w;
  }
  return true;
}

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.points) return;
  current = points[i];
  vec4 reused = vec4(0.0);
  if (push.prev_points > 0u && current.material != CP_NONE) {  // (not an empty pixel slot)
    pb_bvh_budget = push.budget;
    if (!pb_bvh_point_walk(current.position)) atomicAdd(stats[CP_STAT_TRUNCATED], 1u);
    PB_ADD64(stats, CP_STAT_REUSE_TESTED, pb_bvh_boxes_tested);
    if (weights > 0.0) {
      reused = vec4(sum / weights, 1.0);
      atomicAdd(stats[CP_STAT_REUSED], 1u);
    }
  }
  radiance[i] = reused;
}
