#version 460
// splat/count and splat/insert (Paper I §4.3, the leaf passes, run twice: "We calculate the required
// array size for each node in a first pass (traversing the hierarchy exactly as we do when inserting
// photons)"): persistent-style threads, each taking push.jobs_per_thread consecutive regrouped jobs
// (bounded so that no invocation exceeds llvmpipe's loop limit). A "store here" job stores at its
// node; a "descend" job traverses its node's subtree down to the leaves. MODE_COUNT counts entries per
// node (and applies cone rejects / trivial accepts); MODE_INSERT writes photon ids at the node's
// offset + cursor, dropping and counting entries past the list capacity.
#include "cluster_common.h"
layout(local_size_x = 64) in;
uint photon_id, local_dropped = 0u;
void on_store(uint cid) {
  if (push.mode == MODE_COUNT) {
    atomicAdd(list_counts[cid], 1u);
  } else {
    uint slot = list_offsets[cid] + atomicAdd(list_cursors[cid], 1u);
    if (slot < push.list_capacity) lists[slot] = photon_id; else ++local_dropped;
  }
}
void on_descend_stop(uint cid) {}  // the leaf level never descends
#include "cluster_traverse.h"
void main() {
  uint n = stats[STAT_JOB_COUNT];
  uint first = gl_GlobalInvocationID.x * push.jobs_per_thread;
  uint last = min(first + push.jobs_per_thread, n);
  uint budget = LOOP_BUDGET;
  bool complete = true;
  for (uint j = first; j < last && budget > 0u; ++j) {
    --budget;
    uvec2 job = jobs_b[j];
    photon_id = job.x;
    uint cid = job.y & ~JOB_WHOLE;
    if ((job.y & JOB_WHOLE) != 0u) {
      on_store(cid);
      continue;
    }
    photon_begin(photon_id, push.mode == MODE_COUNT);
    complete = traverse(hier_level_of_cid(cid), hier_key(cid), hier_leaf_level(), budget) && complete;
  }
  if (first < last && budget == 0u) complete = false;
  if (!complete && push.mode == MODE_COUNT) atomicAdd(stats[STAT_TRUNCATED], 1u);
  if (local_dropped != 0u) atomicAdd(stats[STAT_DROPPED], local_dropped);
  flush_effects();
}
