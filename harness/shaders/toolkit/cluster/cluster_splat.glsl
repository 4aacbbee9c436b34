// The photon walk of cluster's splat passes (splat/top, splat/count, splat/insert): the photon's
// state and toolkit/traverse.glsl's visit, shared by the top pass and the leaf passes.
#include "cluster_common.glsl"
#include "toolkit/traverse.glsl"

// The photon being splatted (cluster_top, cluster_leaf): set by photon_begin.
uint ph_id;
vec3 ph_center;    // view-space position
vec3 ph_incoming;  // view-space unit direction towards where the photon came from
vec3 ph_power;
bool ph_effects;  // count cone rejects and apply trivial accepts (the top and count runs only)
uint local_cone_rejects = 0u, local_trivial = 0u, local_truncated = 0u;

void photon_begin(uint index, bool effects) {
  PhotonRecord ph = photons[index];
  ph_id = index;
  ph_center = (push.view * vec4(ph.position, 1.0)).xyz;
  ph_incoming = -normalize(mat3(push.view) * ph.direction);
  ph_power = ph.power;
  ph_effects = effects;
}

// toolkit/traverse.glsl's visit: skip a node the sphere misses (or, cone and trivial, that the
// photon reaches from below every contained tangent plane, §4.5); trivial: add the flux of a photon
// that encloses the node and arrives above every tangent plane to the node (§4.6); store the photon
// at a node it encloses or an intersected leaf (§4.3); else descend.
int visit(uint level, uint cid) {
  vec3 lo, hi;
  hier_aabb(cid, lo, hi);
  if (!hier_sphere_intersects(lo, hi, ph_center, push.radius)) return PB_VISIT_SKIP;
  bool encloses = hier_sphere_encloses(lo, hi, ph_center, push.radius);
  uint variant = cluster_variant();
  if (variant != CLUSTER_VARIANT_PLAIN) {
    vec4 cone = hier_cone(cid);
    if (hier_cone_rejects(cone, ph_incoming)) {
      if (ph_effects) ++local_cone_rejects;
      return PB_VISIT_SKIP;
    }
    if (variant == CLUSTER_VARIANT_TRIVIAL && encloses && hier_cone_all_above(cone, ph_incoming)) {
      if (ph_effects) {
        ++local_trivial;
        uvec3 units = pb_flux_units(ph_power, push.units_per_watt.xyz);
        PB_FLUX_ADD(node_flux_lo, cid * 3u, node_flux_hi, cid * 3u, units);
        pb_prof_atomics += 3u;
      }
      return PB_VISIT_SKIP;
    }
  }
  if (encloses || level == hier_leaf_level()) return PB_VISIT_STORE;
  return PB_VISIT_DESCEND;
}

void flush_counters() {
  if (local_cone_rejects != 0u) atomicAdd(stats[CLUSTER_STAT_CONE], local_cone_rejects);
  if (local_trivial != 0u) atomicAdd(stats[CLUSTER_STAT_TRIVIAL], local_trivial);
  if (local_truncated != 0u) atomicAdd(stats[CLUSTER_STAT_TRUNCATED], local_truncated);
  pb_profile_flush();
}
