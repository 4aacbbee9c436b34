// The stats words of pb::toolkit::JobQueue (C++ and GLSL, toolkit/jobs.glsl).
#ifndef PB_TOOLKIT_JOBS_LAYOUT_H
#define PB_TOOLKIT_JOBS_LAYOUT_H

#define PB_JOBS_BINDING_COUNT 3
// The producer's counter has a 64-byte cache line to itself: every invocation of the top pass adds
// to it, so a word beside it that the same invocations read (the capacity) is fetched from a line
// that moves between cores on every add (measured on lavapipe: cluster's top pass took 1.12x the
// time of the code before the toolkit with the capacity beside the counter, 1.00x without).
#define PB_JOB_STAT_WANTED 0       // jobs the producer emitted (kept or not)
#define PB_JOB_STAT_CAPACITY 16    // jobs the list holds (set by the host each frame)
#define PB_JOB_STAT_COUNT 17       // min(wanted, capacity): the jobs kept (jobs_args)
#define PB_JOB_STAT_PER_THREAD 18  // jobs one consumer invocation takes (set by the host)
#define PB_JOB_STAT_ITEM_ARGS 20  // dispatch-indirect arguments: one invocation per job, 64 a group
#define PB_JOB_STAT_THREAD_ARGS 24  // dispatch-indirect arguments: PER_THREAD jobs per invocation
#define PB_JOB_STAT_WORDS 28

// The flag in a job's node word: the photon is stored (or deposited) at the node, no walk below it.
#define PB_JOB_WHOLE 0x80000000u

#endif
