// The stats words of pb::toolkit::JobQueue (C++ and GLSL, toolkit/jobs.glsl).
#ifndef PB_TOOLKIT_JOBS_LAYOUT_H
#define PB_TOOLKIT_JOBS_LAYOUT_H

#define PB_JOBS_BINDING_COUNT 3
#define PB_JOB_STAT_WANTED 0       // jobs the producer emitted (kept or not)
#define PB_JOB_STAT_CAPACITY 1     // jobs the list holds (set by the host each frame)
#define PB_JOB_STAT_COUNT 2        // min(wanted, capacity): the jobs kept (jobs_args)
#define PB_JOB_STAT_PER_THREAD 3   // jobs one consumer invocation takes (set by the host)
#define PB_JOB_STAT_ITEM_ARGS 4    // dispatch-indirect arguments: one invocation per job, 64 a group
#define PB_JOB_STAT_THREAD_ARGS 8  // dispatch-indirect arguments: PER_THREAD jobs per invocation
#define PB_JOB_STAT_WORDS 12

// The flag in a job's node word: the photon is stored (or deposited) at the node, no walk below it.
#define PB_JOB_WHOLE 0x80000000u

#endif
