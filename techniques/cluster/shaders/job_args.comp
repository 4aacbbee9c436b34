#version 460
// splat/top, last step: the dispatch-indirect arguments of the per-job passes from the number of jobs
// the top pass kept (so regroup and the leaf passes launch only as many groups as there is work).
#include "cluster_common.h"
layout(local_size_x = 1) in;
void main() {
  uint n = min(stats[STAT_JOBS], push.job_capacity);
  stats[STAT_JOB_COUNT] = n;
  stats[STAT_JOB_ARGS] = (n + 63u) / 64u;
  stats[STAT_JOB_ARGS + 1u] = 1u;
  stats[STAT_JOB_ARGS + 2u] = 1u;
  uint per_group = 64u * push.jobs_per_thread;
  stats[STAT_LEAF_ARGS] = (n + per_group - 1u) / per_group;
  stats[STAT_LEAF_ARGS + 1u] = 1u;
  stats[STAT_LEAF_ARGS + 2u] = 1u;
}
