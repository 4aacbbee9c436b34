#version 460
// splat (Paper I §4.3 traversal, §4.7 deposit): one invocation per photon walks the view-sample
// cluster hierarchy from the occupied roots down to the stop level (the accumulation
// level, Paper I's "level 4", one above the leaves; or the leaves with accumulate_at = leaves),
// iteratively with a small stack of child masks (§4.3). A node its
// sphere encloses (any level up to the stop level) gets the photon's whole flux; a stop-level node
// it only intersects gets the flux times the node's coverage (deposit =
// coverage, see below) or the whole flux (deposit = paper, as §4.7 states: "When a photon is found
// to enclose a node, or intersect a leaf node, it adds its contribution"). The flux goes to the
// bucket of the octant of the photon's view-space incident direction.
//
// Coverage: the share of the node's view samples inside the sphere, estimated from its children
// (the leaves): each child weighs its sample count (leaf_counts.comp) times a ramp in the distance
// d from the photon to the mean position of the child's samples, clamp(0.5 + (r' - d) / w, 0, 1)
// with w = min(child extent, r) and r'^2 = r^2 - w^2 / 12. The ramp is a smoothed "mean position
// inside the sphere", whose integral over photon positions on a plane is pi r^2, as is that of the
// exact share of a planar child's samples inside the sphere: over many photons the deposits are
// unbiased for planar children, only noisier than the exact share. Without it, at low resolution
// (nodes much larger than r) every intersected node would receive the whole flux and the estimate
// would be many times too bright (README: deviations).
#include "photon_layout.h"
#include "directional_common.h"
#define HIER_BINDING 4
#include "../../cluster/shaders/hierarchy.glsl"
#include "octants.h"
layout(local_size_x = 64) in;
layout(push_constant) uniform Push { DirParams params; };
layout(std430, binding = 0) readonly buffer Photons { PhotonRecord photons[]; };
layout(std430, binding = 1) buffer Flux { uint flux[]; };
layout(std430, binding = 2) readonly buffer LeafStats { uint leaf_stats[]; };
layout(std430, binding = 3) buffer Stats { uint stats[]; };
const float PI = 3.14159265358979;
// Per invocation (locals of main, passed inout: llvmpipe keeps them in registers, and the shader
// has no barrier): `budget` is the loop iterations it has left (llvmpipe ends an invocation's loops
// after 65535 iterations in all, silently, so the traversal keeps its own count and stops, counted,
// first), `deposits` the bucket adds it made.
void deposit(uint cid, uint octant, vec3 phi, inout uint deposits) {
  if (all(equal(phi, vec3(0.0)))) return;
  // Fixed point (see directional_common.h): one integer atomic per channel, no float atomics.
  uvec3 q = uvec3(round(phi * params.radius.z));
  uint at = cid * 24u + octant * 3u;
  atomicAdd(flux[at], q.r);
  atomicAdd(flux[at + 1u], q.g);
  atomicAdd(flux[at + 2u], q.b);
  ++deposits;
}

// Ramp share of leaf `cid` inside the sphere (c, r), and its sample count: see the header comment.
float leaf_share(uint cid, vec3 c, float r, out float n) {
  uint at = 4u * (cid - hier.level[hier_leaf_level()].z);
  uint count = leaf_stats[at];
  n = float(count);
  if (count == 0u) return 0.0;
  vec3 lo, hi;
  hier_aabb(cid, lo, hi);
  vec3 extent = hi - lo;
  vec3 sums = vec3(leaf_stats[at + 1u], leaf_stats[at + 2u], leaf_stats[at + 3u]);
  vec3 sample_mean = lo + extent * sums / (n * DIR_CENTROID_SCALE);
  float w = max(min(max(extent.x, max(extent.y, extent.z)), r), 1e-6);
  float reff = sqrt(r * r - w * w / 12.0);
  return clamp(0.5 + (reff - distance(c, sample_mean)) / w, 0.0, 1.0);
}

// Share of an intersected node's samples inside the sphere: its leaves' shares weighted by their
// sample counts (the node is the leaves' parent, or a leaf itself with accumulate_at = leaves).
float coverage(uint level, uint key, uint cid, vec3 c, float r, inout uint budget) {
  float n;
  if (level == hier_leaf_level()) return leaf_share(cid, c, r, n);
  uint mask = hier_mask(level, key);
  if (mask == 0u) return 0.0;
  // A node's leaves have consecutive cids in child-mask bit order (hierarchy_layout.h).
  uint leaf_cid = hier_cid(level + 1u, hier_child_key(key, findLSB(mask)));
  float total = 0.0, inside = 0.0;
  for (; mask != 0u && budget > 0u; mask &= mask - 1u, ++leaf_cid) {
    --budget;
    float f = leaf_share(leaf_cid, c, r, n);
    total += n;
    inside += n * f;
  }
  return total > 0.0 ? inside / total : 0.0;
}

// Visits node (level, key): deposits where the photon stops, returns true to descend.
bool visit(uint level, uint key, vec3 c, float r, uint octant, vec3 phi, uint acc,
           inout uint budget, inout uint deposits) {
  uint cid = hier_cid(level, key);
  vec3 lo, hi;
  hier_aabb(cid, lo, hi);
  if (!hier_sphere_intersects(lo, hi, c, r)) return false;
  if (hier_sphere_encloses(lo, hi, c, r)) {
    deposit(cid, octant, phi, deposits);
    return false;
  }
  if (level < acc) return true;
  bool paper = (params.counts.z & DIR_FLAG_DEPOSIT_PAPER) != 0u;
  deposit(cid, octant, paper ? phi : phi * coverage(level, key, cid, c, r, budget), deposits);
  return false;
}

void main() {
  uint id = gl_GlobalInvocationID.x;
  if (id < params.counts.x) {
    uint budget = 60000u, deposits = 0u;
    PhotonRecord photon = photons[id];
    float r = params.radius.x;
    vec3 c = (params.view * vec4(photon.position, 1.0)).xyz;
    uint octant = octant_of(mat3(params.view) * -photon.direction);
    uint acc = params.counts.y;
    uint max_visits = params.counts.w;
    uint visits = 0u;
    bool overflow = false;
    // Every occupied root, as cluster's top pass: the sphere/AABB test rejects far roots at once.
    uint stack[HIER_MAX_LEVELS];
    uint roots = hier_count(0u);
    for (uint ri = 0u; ri < roots && !overflow; ++ri) {
      uint root = hier_key(hier_level_cid(0u, ri));
      --budget;
      if (++visits > max_visits || budget == 0u) {
        overflow = true;
        break;
      }
      if (!visit(0u, root, c, r, octant, photon.power, acc, budget, deposits)) continue;
      uint level = 0u, key = root;
      stack[0] = hier_mask(0u, root);
      while (true) {
        if (budget == 0u) {
          overflow = true;
          break;
        }
        --budget;
        if (stack[level] == 0u) {
          if (level == 0u) break;
          --level;
          key = hier_parent_key(key);
          continue;
        }
        uint i = findLSB(stack[level]);
        stack[level] &= stack[level] - 1u;
        uint child = hier_child_key(key, i);
        if (++visits > max_visits) {
          overflow = true;
          break;
        }
        if (visit(level + 1u, child, c, r, octant, photon.power, acc, budget, deposits)) {
          ++level;
          key = child;
          stack[level] = hier_mask(level, child);
        }
      }
    }
    if (overflow) atomicAdd(stats[DIR_STAT_OVERFLOWS], 1u);
    if (deposits == 0u && !overflow) atomicAdd(stats[DIR_STAT_MISSED], 1u);
    DIR_ADD64(stats, DIR_STAT_DEPOSITS, deposits);
  }
}
