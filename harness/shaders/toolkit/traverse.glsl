// A photon sphere's walk through the view-sample cluster hierarchy (Paper I §4.3), shared by every
// splatter on it (cluster's top and leaf passes, directional's top and job passes): iterative, with
// a stack of the remaining child masks, one per level, started from a node's child mask; take the
// first set bit, clear it, visit that child (§4.3: "the node key is simply shifted five bits to the
// left, and i is appended"), then skip it, store at it, or descend (or, at the stop level, hand it
// on); a pop shifts the key back.
//
// The including shader includes toolkit/hierarchy.glsl and toolkit/profile.glsl, then defines:
//   int  visit(uint level, uint cid)            PB_VISIT_SKIP, PB_VISIT_STORE or PB_VISIT_DESCEND
//   void on_store(uint level, uint cid)         the photon is stored at (deposited into) the node
//   void on_descend_stop(uint level, uint cid)  an intersected node at the stop level
//
// Budget (llvmpipe's loop limit, photonbench/toolkit/limits.h): every loop step of the invocation
// (the walks' and any other loop's that calls pb_step) takes one unit of pb_budget, which the
// shader sets at the start of main (the `loop_budget` parameter, PB_LOOP_BUDGET by default). A walk
// with no unit left before its work is done stops and returns false: truncated, for the caller to
// count. A walk whose last step takes the last unit is complete. The check comes before every step,
// so the budget never wraps below zero. (A global rather than an inout parameter, so that loops
// inside visit() draw on the same budget.)
#ifndef PB_TOOLKIT_TRAVERSE_GLSL
#define PB_TOOLKIT_TRAVERSE_GLSL

#define PB_VISIT_SKIP 0
#define PB_VISIT_STORE 1
#define PB_VISIT_DESCEND 2

int visit(uint level, uint cid);
void on_store(uint level, uint cid);
void on_descend_stop(uint level, uint cid);

uint pb_budget = 0u;

// Takes one unit of the budget for a loop step; false (and nothing taken) when none is left.
bool pb_step() {
  if (pb_budget == 0u) return false;
  --pb_budget;
  pb_profile_step();
  return true;
}

int pb_visit(uint level, uint cid) {
  ++pb_prof_visits;
  return visit(level, cid);
}

void pb_act(int action, uint level, uint cid, uint stop_level, out bool push) {
  push = false;
  if (action == PB_VISIT_STORE) {
    on_store(level, cid);
  } else if (action == PB_VISIT_DESCEND) {
    if (level >= stop_level)
      on_descend_stop(level, cid);
    else
      push = true;
  }
}

// The descendants of node (start_level, start_key) down to stop_level. False: truncated.
bool pb_traverse(uint start_level, uint start_key, uint stop_level) {
  uint stack[HIER_MAX_LEVELS];
  uint level = start_level, key = start_key;
  stack[level] = hier_mask(level, key);
  while (pb_step()) {
    if (stack[level] == 0u) {
      if (level == start_level) return true;
      --level;
      key = hier_parent_key(key);
      continue;
    }
    uint i = uint(findLSB(stack[level]));
    stack[level] &= stack[level] - 1u;
    uint child = hier_child_key(key, i);
    uint cid = hier_cid(level + 1u, child);
    bool push;
    pb_act(pb_visit(level + 1u, cid), level + 1u, cid, stop_level, push);
    if (push) {
      ++level;
      key = child;
      stack[level] = hier_mask(level, key);
    }
  }
  return false;
}

// Every occupied root and its descendants down to stop_level (a top pass; the sphere/AABB test
// rejects far roots at once). False: truncated (the remaining roots are not visited).
bool pb_traverse_from_roots(uint stop_level) {
  uint roots = hier_count(0u);
  for (uint r = 0u; r < roots; ++r) {
    if (!pb_step()) return false;
    uint cid = hier_level_cid(0u, r);
    bool push;
    pb_act(pb_visit(0u, cid), 0u, cid, stop_level, push);
    if (push && !pb_traverse(0u, hier_key(cid), stop_level)) return false;
  }
  return true;
}

// From a job's node (any level): the node itself was visited by the pass that emitted the job.
bool pb_traverse_job(uint level, uint cid, uint stop_level) {
  return pb_traverse(level, hier_key(cid), stop_level);
}

#endif
