#version 460
// After a producer pass: the jobs kept and the dispatch-indirect arguments of the passes that read
// them (toolkit/jobs.glsl), so they launch only as many groups as there are jobs.
#define PB_JOBS_BINDING 0
#include "toolkit/jobs.glsl"
layout(local_size_x = 1) in;
void main() {
  uint n = min(pb_job_stats[PB_JOB_STAT_WANTED], pb_job_stats[PB_JOB_STAT_CAPACITY]);
  pb_job_stats[PB_JOB_STAT_COUNT] = n;
  pb_job_stats[PB_JOB_STAT_ITEM_ARGS] = (n + 63u) / 64u;
  pb_job_stats[PB_JOB_STAT_ITEM_ARGS + 1] = 1u;
  pb_job_stats[PB_JOB_STAT_ITEM_ARGS + 2] = 1u;
  uint per_group = 64u * max(pb_job_stats[PB_JOB_STAT_PER_THREAD], 1u);
  pb_job_stats[PB_JOB_STAT_THREAD_ARGS] = (n + per_group - 1u) / per_group;
  pb_job_stats[PB_JOB_STAT_THREAD_ARGS + 1] = 1u;
  pb_job_stats[PB_JOB_STAT_THREAD_ARGS + 2] = 1u;
}
