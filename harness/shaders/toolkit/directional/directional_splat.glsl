// The photon walk of directional's splat passes (Paper I §4.3 traversal, §4.7 deposit), shared by
// splat/top and splat/deposit: a node the sphere encloses (any level down to the stop level) gets
// the photon's whole flux; a stop-level node it only intersects gets the flux times the node's
// coverage (deposit = coverage) or the whole flux (deposit = paper, as §4.7 states: "When a photon
// is found to enclose a node, or intersect a leaf node, it adds its contribution"). The flux goes
// to the bucket of the octant of the photon's view-space incident direction.
//
// Coverage: the share of the node's view samples inside the sphere, estimated from its children
// (the leaves): each child weighs its sample count (directional_leaf_counts.comp) times a ramp in
// the distance d from the photon to the mean position of the child's samples, clamp(0.5 + (r' - d)
// / w, 0, 1) with w = min(child extent, r) and r'^2 = r^2 - w^2 / 12. The ramp is a smoothed "mean
// position inside the sphere", whose integral over photon positions on a plane is pi r^2, as is
// that of the exact share of a planar child's samples inside the sphere: over many photons the
// deposits are unbiased for planar children, only noisier than the exact share. Without it, at low
// resolution (nodes much larger than r) every intersected node would receive the whole flux and the
// estimate would be many times too bright (techniques/directional/README.md: deviations).
#include "directional_common.glsl"
#include "octants.glsl"
#include "toolkit/traverse.glsl"

uint ph_id, ph_octant;
vec3 ph_center, ph_power;
uint local_deposits = 0u, local_truncated = 0u, local_missed = 0u;

void photon_begin(uint index) {
  PhotonRecord ph = photons[index];
  ph_id = index;
  ph_center = (push.view * vec4(ph.position, 1.0)).xyz;
  ph_octant = octant_of(mat3(push.view) * -ph.direction);
  ph_power = ph.power;
}

void deposit(uint cid, vec3 phi) {
  uvec3 units = pb_flux_units(phi, push.scale_radius.xyz);
  if (all(equal(units, uvec3(0u)))) return;
  uint at = cid * 24u + ph_octant * 3u;
  PB_FLUX_ADD(flux_lo, at, flux_hi, at, units);
  pb_prof_atomics += 3u;
  ++local_deposits;
}

// Ramp share of leaf `cid` inside the sphere, and its sample count: see the header comment.
float leaf_share(uint cid, out float n) {
  uint at = 4u * (cid - hier.level[hier_leaf_level()].z);
  uint count = leaf_stats[at];
  n = float(count);
  if (count == 0u) return 0.0;
  vec3 lo, hi;
  hier_aabb(cid, lo, hi);
  vec3 extent = hi - lo;
  vec3 sums = vec3(leaf_stats[at + 1u], leaf_stats[at + 2u], leaf_stats[at + 3u]);
  vec3 sample_mean = lo + extent * sums / (n * DIR_CENTROID_SCALE);
  float r = push.scale_radius.w;
  float w = max(min(max(extent.x, max(extent.y, extent.z)), r), 1e-6);
  float reff = sqrt(r * r - w * w / 12.0);
  return clamp(0.5 + (reff - distance(ph_center, sample_mean)) / w, 0.0, 1.0);
}

// Deposits into an intersected (not enclosed) stop-level node: the flux times its coverage, its
// leaves' shares weighted by their sample counts (the node is the leaves' parent, or a leaf itself
// with accumulate_at = leaves). False if the loop budget ran out (nothing deposited).
bool deposit_covered(uint level, uint cid) {
  if ((push.counts.z & DIR_FLAG_DEPOSIT_PAPER) != 0u) {
    deposit(cid, ph_power);
    return true;
  }
  float n, share;
  if (level == hier_leaf_level()) {
    share = leaf_share(cid, n);
  } else {
    uint key = hier_key(cid);
    uint mask = hier_mask(level, key);
    // A node's leaves have consecutive cids in child-mask bit order (hierarchy_layout.h).
    uint leaf_cid = hier_cid(level + 1u, hier_child_key(key, uint(findLSB(mask))));
    float total = 0.0, inside = 0.0;
    for (; mask != 0u; mask &= mask - 1u, ++leaf_cid) {
      if (!pb_step()) return false;
      float f = leaf_share(leaf_cid, n);
      total += n;
      inside += n * f;
    }
    share = total > 0.0 ? inside / total : 0.0;
  }
  deposit(cid, ph_power * share);
  return true;
}

// toolkit/traverse.glsl's visit. Enclosed nodes are deposited into at once; intersected nodes above
// the stop level are descended into (or, at the top pass's stop level, handed to a job); an
// intersected stop-level node is deposited into with its coverage by the deposit pass.
#ifdef DIR_TOP_PASS
const bool dir_top_pass = true;
#else
const bool dir_top_pass = false;
#endif
int visit(uint level, uint cid) {
  vec3 lo, hi;
  hier_aabb(cid, lo, hi);
  float r = push.scale_radius.w;
  if (!hier_sphere_intersects(lo, hi, ph_center, r)) return PB_VISIT_SKIP;
  if (hier_sphere_encloses(lo, hi, ph_center, r)) {
    deposit(cid, ph_power);
    return PB_VISIT_SKIP;
  }
  if (level < push.counts.y || dir_top_pass) return PB_VISIT_DESCEND;
  // Out of budget: nothing deposited; the walk's next step fails and reports the truncation.
  deposit_covered(level, cid);
  return PB_VISIT_SKIP;
}

void flush_counters() {
  if (local_deposits != 0u) PB_ADD64(stats, DIR_STAT_DEPOSITS, local_deposits);
  if (local_truncated != 0u) atomicAdd(stats[DIR_STAT_TRUNCATED], local_truncated);
  if (local_missed != 0u) atomicAdd(stats[DIR_STAT_MISSED], local_missed);
  pb_profile_flush();
}
