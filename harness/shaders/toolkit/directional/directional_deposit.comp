#version 460
// splat/deposit (Paper I §4.3's per-node jobs, with §4.7's deposits): each invocation takes a run
// of consecutive jobs of the list sorted by node (toolkit/jobs.glsl), so neighbouring invocations
// work on the same nodes; a job at the stop level deposits the photon's flux times the node's
// coverage; a job above it walks the node's subtree down to the stop level
// (directional_splat.glsl).
#define PB_PROFILE_SLOT 1u
#include "directional_splat.glsl"
layout(local_size_x = 64) in;
void on_store(uint level, uint cid) {}         // visit() never stores: it deposits
void on_descend_stop(uint level, uint cid) {}  // visit() deposits at the stop level
void main() {
  uvec2 run = pb_job_run();
  pb_budget = push.limits.x;
  uint stop = push.counts.y;
  for (uint j = run.x; j < run.y; ++j) {
    if (!pb_step()) {
      local_truncated += run.y - j;
      break;
    }
    uvec2 job = pb_jobs[j];
    photon_begin(job.x);
    uint level = hier_level_of_cid(job.y);
    bool complete =
        level == stop ? deposit_covered(level, job.y) : pb_traverse_job(level, job.y, stop);
    if (!complete) {
      local_truncated += run.y - j;
      break;
    }
  }
  flush_counters();
}
