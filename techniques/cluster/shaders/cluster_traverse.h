// Photon-sphere traversal of the cluster hierarchy (Paper I §4.3): one thread per photon (or job),
// iterative, with a stack of remaining child masks (one per level) initialised from the start node's
// child mask; take the first set bit, clear it, test that child: skip it if the sphere misses its
// AABB (or, with cones, if the photon arrives from below every contained tangent plane, §4.5); with
// the trivial variant, add the photon's flux to the node if the sphere encloses it and the photon
// arrives from above every tangent plane (§4.6); store the photon at the node if the sphere encloses
// it or it is an intersected leaf; otherwise descend (key << 5 | i), or hand the node to
// on_descend_stop() at the stop level. Pops shift the key back (key >> 5).
//
// The including shader defines, before including: on_store(uint cid), on_descend_stop(uint cid),
// and the globals below are set per photon by photon_begin().
#define VISIT_SKIP 0
#define VISIT_STORE 1
#define VISIT_DESCEND 2

vec3 ph_center;     // view-space photon position
vec3 ph_incoming;   // view-space unit direction towards where the photon came from
vec3 ph_power;
bool ph_effects;    // count cone rejects and apply trivial accepts (only one of count / insert does)
uint local_cone_rejects = 0u, local_trivial = 0u;

void photon_begin(uint index, bool effects) {
  PhotonRecord ph = photons[index];
  ph_center = (push.view * vec4(ph.position, 1.0)).xyz;
  ph_incoming = -normalize(mat3(push.view) * ph.direction);
  ph_power = ph.power;
  ph_effects = effects;
}

int visit(uint level, uint cid) {
  vec3 lo, hi;
  hier_aabb(cid, lo, hi);
  if (!hier_sphere_intersects(lo, hi, ph_center, push.radius)) return VISIT_SKIP;
  bool encloses = hier_sphere_encloses(lo, hi, ph_center, push.radius);
  if (push.variant != VARIANT_PLAIN) {
    vec4 cone = hier_cone(cid);
    if (hier_cone_rejects(cone, ph_incoming)) {
      if (ph_effects) ++local_cone_rejects;
      return VISIT_SKIP;
    }
    if (push.variant == VARIANT_TRIVIAL && encloses && hier_cone_all_above(cone, ph_incoming)) {
      if (ph_effects) {
        ++local_trivial;
        for (uint k = 0u; k < 3u; ++k)
          atomicAdd(node_flux[cid * 3u + k], uint(round(ph_power[k] * push.flux_scale)));
      }
      return VISIT_SKIP;
    }
  }
  if (encloses || level == hier_leaf_level()) return VISIT_STORE;
  return VISIT_DESCEND;
}

// Visits the descendants of (start_level, start_key) down to stop_level. Returns false if the loop
// budget ran out first (the traversal was cut short).
bool traverse(uint start_level, uint start_key, uint stop_level, inout uint budget) {
  uint stack[HIER_MAX_LEVELS];
  uint level = start_level, key = start_key;
  stack[level] = hier_mask(level, key);
  while (budget > 0u) {
    --budget;
    if (stack[level] == 0u) {
      if (level == start_level) return true;
      --level;
      key = hier_parent_key(key);
      continue;
    }
    uint i = uint(findLSB(stack[level]));
    stack[level] &= stack[level] - 1u;
    uint child = hier_child_key(key, i);
    uint child_level = level + 1u;
    uint cid = hier_cid(child_level, child);
    int action = visit(child_level, cid);
    if (action == VISIT_STORE) {
      on_store(cid);
    } else if (action == VISIT_DESCEND) {
      if (child_level >= stop_level) {
        on_descend_stop(cid);
      } else {
        level = child_level;
        key = child;
        stack[level] = hier_mask(level, key);
      }
    }
  }
  return false;
}

void flush_effects() {
  if (local_cone_rejects != 0u) atomicAdd(stats[STAT_CONE], local_cone_rejects);
  if (local_trivial != 0u) atomicAdd(stats[STAT_TRIVIAL], local_trivial);
}
