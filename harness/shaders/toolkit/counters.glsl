// Per-invocation work counters the toolkit's GLSL modules keep (loop steps, hierarchy nodes
// visited, global atomics issued, SIMD lanes active and present per loop step), for
// toolkit/profile.glsl to write out when a pass is profiled. Locals: free when not written.
#ifndef PB_TOOLKIT_COUNTERS_GLSL
#define PB_TOOLKIT_COUNTERS_GLSL
uint pb_prof_steps = 0u, pb_prof_visits = 0u, pb_prof_atomics = 0u;
uint pb_prof_active_lanes = 0u, pb_prof_lanes = 0u;
#endif
