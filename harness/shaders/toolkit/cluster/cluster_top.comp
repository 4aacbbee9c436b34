#version 460
// splat/top (Paper I §4.3, first sub-pass): one invocation per photon walks from the occupied roots
// down to push.top_level (3 levels by default) and emits (photon id, node) jobs: a node the sphere
// encloses (or an intersected leaf) as a "store here" job, an intersected node at the stop level as
// a "descend" job for the leaf passes. Cone rejects and trivial accepts of these levels happen
// here, once.
#define PB_PROFILE_SLOT 0u
#include "cluster_splat.glsl"
layout(local_size_x = 64) in;
void on_store(uint level, uint cid) { pb_job_emit(ph_id, cid | PB_JOB_WHOLE); }
void on_descend_stop(uint level, uint cid) { pb_job_emit(ph_id, cid); }
void main() {
  uint id = gl_GlobalInvocationID.x;
  if (id < push.photon_count) {
    photon_begin(id, true);
    pb_budget = push.budget;
    if (!pb_traverse_from_roots(push.top_level)) ++local_truncated;
  }
  flush_counters();
}
