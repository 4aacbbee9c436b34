#version 460
// splat/count and splat/insert (Paper I §4.3, the leaf passes, run twice: "We calculate the
// required array size for each node in a first pass (traversing the hierarchy exactly as we do when
// inserting photons)"): each invocation takes a run of consecutive jobs of the list sorted by node
// (toolkit/jobs.glsl). A "store here" job stores at its node; a "descend" job walks its node's
// subtree down to the leaves. CLUSTER_MODE_COUNT counts entries per node (and applies cone rejects
// and trivial accepts), CLUSTER_MODE_INSERT writes photon ids (toolkit/photon_lists.glsl).
#define PB_PROFILE_SLOT (1u + push.mode)
#include "cluster_splat.glsl"
layout(local_size_x = 64) in;
void store(uint cid) {
  if (push.mode == CLUSTER_MODE_COUNT)
    pb_list_count(cid);
  else
    pb_list_insert(cid, ph_id);
}
void on_store(uint level, uint cid) { store(cid); }
void on_descend_stop(uint level, uint cid) {}  // the walk stops at the leaves, which never descend
void main() {
  uvec2 run = pb_job_run();
  pb_budget = push.budget;
  for (uint j = run.x; j < run.y; ++j) {
    if (!pb_step()) {
      local_truncated += run.y - j;
      break;
    }
    uvec2 job = pb_jobs[j];
    uint cid = job.y & ~PB_JOB_WHOLE;
    ph_id = job.x;
    if ((job.y & PB_JOB_WHOLE) != 0u) {
      store(cid);
      continue;
    }
    photon_begin(job.x, push.mode == CLUSTER_MODE_COUNT);
    if (!pb_traverse_job(hier_level_of_cid(cid), cid, hier_leaf_level())) {
      local_truncated += run.y - j;
      break;
    }
  }
  // The insert run repeats the count run's walks: only the count run reports truncation.
  if (push.mode != CLUSTER_MODE_COUNT) local_truncated = 0u;
  flush_counters();
}
