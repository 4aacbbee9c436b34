// (photon, node) jobs between the top splat pass and the per-node passes below it (Paper I §4.3:
// "the first pass traverses down 3 levels ... and outputs a list of jobs; the jobs are rearranged
// into local groups that are used in the following insertion passes"; §5.2: "two lists are needed
// in practice"). The producer emits into an unordered list; pb::toolkit::JobQueue counts them,
// writes the consumers' dispatch arguments and sorts the list by node (CountingSort), so that
// consecutive jobs, and an invocation's run of jobs, share nodes. C++ side:
// photonbench/toolkit/jobs.h.
//
// Use: define PB_JOBS_BINDING (first of PB_JOBS_BINDING_COUNT bindings), include this, bind
// JobQueue::bindings() there.
#ifndef PB_TOOLKIT_JOBS_GLSL
#define PB_TOOLKIT_JOBS_GLSL

#include "photonbench/toolkit/jobs_layout.h"
#include "toolkit/counters.glsl"

#ifndef PB_JOBS_BINDING
#error "define PB_JOBS_BINDING before including jobs.glsl"
#endif

layout(std430, binding = PB_JOBS_BINDING + 0) buffer PbJobsEmitted { uvec2 pb_jobs_emitted[]; };
layout(std430, binding = PB_JOBS_BINDING + 1) readonly buffer PbJobs { uvec2 pb_jobs[]; };
layout(std430, binding = PB_JOBS_BINDING + 2) buffer PbJobStats { uint pb_job_stats[]; };

// Producer: a job for `photon` at node word `node` (a cid, | PB_JOB_WHOLE to store there). Jobs
// past the capacity are dropped; the host reports them (job_overflows: wanted - capacity).
void pb_job_emit(uint photon, uint node) {
  uint slot = atomicAdd(pb_job_stats[PB_JOB_STAT_WANTED], 1u);
  ++pb_prof_atomics;
  if (slot < pb_job_stats[PB_JOB_STAT_CAPACITY]) pb_jobs_emitted[slot] = uvec2(photon, node);
}

// Consumer (dispatched with JobQueue::dispatch_consumers): this invocation's run of sorted jobs,
// [x, y) of pb_jobs.
uvec2 pb_job_run() {
  uint count = pb_job_stats[PB_JOB_STAT_COUNT], per = pb_job_stats[PB_JOB_STAT_PER_THREAD];
  uint first = min(gl_GlobalInvocationID.x * per, count);
  return uvec2(first, min(first + per, count));
}

#endif
