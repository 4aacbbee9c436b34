// Where a pass's time goes (the `profile` parameter; pb::toolkit::PassProfile reads it back): per
// pass, 64-bit sums over its invocations of loop steps, hierarchy nodes visited, global atomics
// issued, the most steps one invocation took, and SIMD lane use: for each loop step of a subgroup,
// the lanes that took it (active) and the lanes it had (gl_SubgroupSize), so 1 - active / lanes is
// the share of lanes idle in the traversal loops (divergence: on lavapipe a subgroup is one SIMD
// register of invocations, and a loop runs until its slowest lane is done). The counters are kept
// in locals and written once per invocation, and only when profiling (PB_PROFILE_ON), so they cost
// nothing otherwise.
//
// Use: define PB_PROFILE_BINDING (one storage buffer) and PB_PROFILE_SLOT (a uint expression: which
// pass), include this, call pb_profile_flush() at the end. The counting is compiled in only with
// PB_PROFILED defined (the toolkit embeds a profiled variant of each splat pass: even a branch
// never taken cost 15% of directional's frame on lavapipe), so the counters are free otherwise.
#ifndef PB_TOOLKIT_PROFILE_GLSL
#define PB_TOOLKIT_PROFILE_GLSL

#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require

#include "toolkit/atomics.glsl"
#include "toolkit/counters.glsl"

#ifdef PB_PROFILED
#define PB_PROFILE_ON true
#else
#define PB_PROFILE_ON false
#endif

layout(std430, binding = PB_PROFILE_BINDING) buffer PbProfile { uint pb_profile[]; };

// Words per pass slot (mirrors pb::toolkit::PassProfile): five 64-bit sums.
#define PB_PROFILE_STEPS 0u
#define PB_PROFILE_VISITS 2u
#define PB_PROFILE_ATOMICS 4u
#define PB_PROFILE_ACTIVE_LANES 6u
#define PB_PROFILE_LANES 8u
#define PB_PROFILE_MAX_STEPS 10u  // the most loop steps one invocation took (atomicMax)
#define PB_PROFILE_SLOT_WORDS 16u

// One loop step of this invocation; with profiling, one lane of the subgroup's step.
void pb_profile_step() {
  ++pb_prof_steps;
  if (PB_PROFILE_ON) {
    uvec4 ballot = subgroupBallot(true);
    if (subgroupElect()) {
      pb_prof_active_lanes += subgroupBallotBitCount(ballot);
      pb_prof_lanes += gl_SubgroupSize;
    }
  }
}

void pb_profile_flush() {
  if (!(PB_PROFILE_ON)) return;
  uint at = PB_PROFILE_SLOT * PB_PROFILE_SLOT_WORDS;
  PB_ADD64(pb_profile, at + PB_PROFILE_STEPS, pb_prof_steps);
  PB_ADD64(pb_profile, at + PB_PROFILE_VISITS, pb_prof_visits);
  PB_ADD64(pb_profile, at + PB_PROFILE_ATOMICS, pb_prof_atomics);
  PB_ADD64(pb_profile, at + PB_PROFILE_ACTIVE_LANES, pb_prof_active_lanes);
  PB_ADD64(pb_profile, at + PB_PROFILE_LANES, pb_prof_lanes);
  atomicMax(pb_profile[at + PB_PROFILE_MAX_STEPS], pb_prof_steps);
}

#endif
