#version 460
// splat/top (Paper I §4.3, first sub-pass): one invocation per photon traverses down from the
// occupied roots to push.top_level (3 levels by default) and pushes (photon id, node) jobs to a
// global list: a node the sphere encloses (or an intersected leaf) as a "store here" job, an
// intersected node at the stop level as a "descend" job for the leaf passes. Cone rejects and
// trivial accepts of these levels happen here, once. Jobs past the capacity are dropped and counted.
#include "cluster_common.h"
layout(local_size_x = 64) in;
uint photon_id, local_dropped = 0u;
void emit(uint node) {
  uint slot = atomicAdd(stats[STAT_JOBS], 1u);
  if (slot < push.job_capacity) jobs_a[slot] = uvec2(photon_id, node); else ++local_dropped;
}
void on_store(uint cid) { emit(cid | JOB_WHOLE); }
void on_descend_stop(uint cid) { emit(cid); }
#include "cluster_traverse.h"
void main() {
  photon_id = gl_GlobalInvocationID.x;
  if (photon_id >= push.photon_count) return;
  photon_begin(photon_id, true);
  uint budget = LOOP_BUDGET;
  bool complete = true;
  uint roots = hier_count(0u);
  for (uint r = 0u; r < roots && budget > 0u; ++r) {
    --budget;
    uint cid = hier_level_cid(0u, r);
    int action = visit(0u, cid);
    if (action == VISIT_STORE) on_store(cid);
    else if (action == VISIT_DESCEND) {
      if (push.top_level == 0u) on_descend_stop(cid);
      else complete = traverse(0u, hier_key(cid), push.top_level, budget) && complete;
    }
  }
  if (budget == 0u) complete = false;
  if (!complete) atomicAdd(stats[STAT_TRUNCATED], 1u);
  if (local_dropped != 0u) atomicAdd(stats[STAT_JOBS_DROPPED], local_dropped);
  flush_effects();
}
