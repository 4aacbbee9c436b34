#version 460
// splat/regroup (Paper I §4.3: "it is rearranged into local groups that are used in the following
// insertion passes"; §5.2: "two lists are needed in practice"): a counting sort of the top pass's jobs
// by node, so each leaf-pass invocation's contiguous run of jobs shares nodes. MODE_COUNT counts jobs
// per node; after a scan of the counts, MODE_INSERT scatters jobs_a into jobs_b.
#include "cluster_common.h"
layout(local_size_x = 64) in;
void main() {
  uint j = gl_GlobalInvocationID.x;
  if (j >= stats[STAT_JOB_COUNT]) return;
  uvec2 job = jobs_a[j];
  uint cid = job.y & ~JOB_WHOLE;
  if (push.mode == MODE_COUNT) {
    atomicAdd(job_bins[cid], 1u);
  } else {
    jobs_b[job_offsets[cid] + atomicAdd(job_cursors[cid], 1u)] = job;
  }
}
