#version 460
// splat/top (Paper I §4.3's first sub-pass, with §4.7's deposits): one invocation per photon walks
// from the occupied roots down to the top level (top_levels, 3 by default: the accumulation level
// of the default layout), depositing into the nodes its sphere encloses, and hands every
// intersected node at the top level to a (photon, node) job for splat/deposit, which covers the
// rest of the way down to the stop level.
#define PB_PROFILE_SLOT 0u
#define DIR_TOP_PASS
#include "directional_splat.glsl"
layout(local_size_x = 64) in;
uint local_jobs = 0u;
void on_store(uint level, uint cid) {}  // visit() never stores: it deposits
void on_descend_stop(uint level, uint cid) {
  ++local_jobs;
  pb_job_emit(ph_id, cid);
}
void main() {
  uint id = gl_GlobalInvocationID.x;
  if (id < push.counts.x) {
    photon_begin(id);
    pb_budget = push.limits.x;
    if (!pb_traverse_from_roots(push.counts.w))
      ++local_truncated;
    else if (local_deposits == 0u && local_jobs == 0u)
      ++local_missed;
  }
  flush_counters();
}
