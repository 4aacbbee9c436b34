// Bindings, push constants and stats words shared by every `cluster` technique shader. All of them
// bind the same list (technique.cpp: kBindings): the hierarchy's buffers first (hierarchy.glsl), then
// the technique's.
#define HIER_BINDING 0
#include "hierarchy.glsl"
#include "photon_layout.h"
#include "scene_layout.h"

layout(std430, binding = 7) readonly buffer Photons { PhotonRecord photons[]; };
layout(std430, binding = 8) buffer JobsA { uvec2 jobs_a[]; };    // top pass output, unordered
layout(std430, binding = 9) buffer JobsB { uvec2 jobs_b[]; };    // regrouped by node
layout(std430, binding = 10) buffer JobBins { uint job_bins[]; };        // per cid: jobs at the node
layout(std430, binding = 11) buffer JobOffsets { uint job_offsets[]; };  // exclusive scan of job_bins
layout(std430, binding = 12) buffer JobCursors { uint job_cursors[]; };
layout(std430, binding = 13) buffer ListCounts { uint list_counts[]; };    // per cid: list length
layout(std430, binding = 14) buffer ListOffsets { uint list_offsets[]; };  // exclusive scan
layout(std430, binding = 15) buffer ListCursors { uint list_cursors[]; };
layout(std430, binding = 16) buffer Lists { uint lists[]; };          // photon indices
layout(std430, binding = 17) buffer NodeFlux { uint node_flux[]; };   // trivial: 3 fixed-point words per cid
layout(std430, binding = 18) buffer Stats { uint stats[]; };
layout(std430, binding = 19) buffer ScanBlocks { uint scan_blocks[]; };
layout(binding = 20, rgba32f) readonly uniform image2D gbuffer_position;
layout(binding = 21, rgba32f) readonly uniform image2D gbuffer_normal;
layout(binding = 22, rgba32f) readonly uniform image2D gbuffer_albedo;
layout(binding = 23, rgba32f) uniform image2D indirect_out;

// Mirrors Push in technique.cpp (std430 push constants: mat4 then 12 words).
layout(push_constant) uniform Push {
  mat4 view;            // world -> view (the hierarchy's space)
  uint photon_count;
  float radius;
  uint variant;         // VARIANT_*
  uint top_level;       // splat/top: the level where it stops and emits (photon, node) jobs
  uint job_capacity;
  uint list_capacity;
  uint jobs_per_thread;  // leaf passes: jobs one invocation processes
  uint mode;             // regroup / leaf passes: MODE_COUNT or MODE_INSERT; scans: SCAN_JOBS / SCAN_LISTS
  float flux_scale;      // trivial: fixed-point units per watt of node flux
  uint list_first;       // radiance-estimate: the slice [list_first, + list_slice) of a sample's lists
  uint list_slice;
  uint scan_count;       // scans: items scanned (the cid capacity)
} push;

#define VARIANT_PLAIN 0u
#define VARIANT_CONE 1u
#define VARIANT_TRIVIAL 2u
#define MODE_COUNT 0u
#define MODE_INSERT 1u
#define SCAN_JOBS 0u
#define SCAN_LISTS 1u
#define JOB_WHOLE 0x80000000u  // job flag: store the photon at this node, do not descend

// Stats words (host-visible; technique.cpp reads them at the end of the frame).
#define STAT_ENTRIES 0     // list entries wanted (scan total)
#define STAT_DROPPED 1     // list entries dropped for want of capacity
#define STAT_READ 2        // 64-bit: list entries read in the estimate
#define STAT_REJECTED 4    // 64-bit: of those, outside the sphere or from below
#define STAT_JOBS 6        // jobs wanted by the top pass
#define STAT_JOBS_DROPPED 7
#define STAT_TRIVIAL 8     // trivial accepts (photon flux added to a node)
#define STAT_CONE 9        // cone rejects (nodes skipped by the normal-cone test)
#define STAT_TRUNCATED 10  // traversals cut short by the loop budget
#define STAT_JOB_ARGS 12   // dispatch-indirect args: per-job passes (64 jobs per group)
#define STAT_LEAF_ARGS 16  // dispatch-indirect args: leaf passes (64 * jobs_per_thread per group)
#define STAT_JOB_COUNT 20  // min(jobs wanted, job capacity)
#define STAT_WORDS 24

// llvmpipe (lavapipe) silently ends a shader invocation's loops after 65535 iterations in all; every
// traversal loop draws from this budget and reports when it runs out (STAT_TRUNCATED, an overflow).
#define LOOP_BUDGET 60000u

// An exact 64-bit counter from two 32-bit words: the low word's carry goes to the high word.
void add64(uint at, uint value) {
  if (value == 0u) return;
  uint old = atomicAdd(stats[at], value);
  if (old + value < old) atomicAdd(stats[at + 1u], 1u);
}
