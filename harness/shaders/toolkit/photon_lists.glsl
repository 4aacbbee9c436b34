// Per-bin photon lists built by Paper I's two splatting runs (§4.3: "We calculate the required
// array size for each node in a first pass (traversing the hierarchy exactly as we do when
// inserting photons)"): a count run adds 1 per (bin, photon), a prefix sum turns the counts into
// offsets, an insert run writes each photon id at offset + cursor. Bins are tiles (tiled) or
// hierarchy nodes (cluster). C++ side: pb::toolkit::PhotonLists
// (photonbench/toolkit/photon_lists.h).
//
// The two runs must agree bin for bin, and the lists are not cleared between frames, so an insert
// never writes past its bin's count (it would land in the next bin's range), and the check pass
// (lists_check.comp, after the insert run) counts the bins where the runs differ (counter
// list_mismatches, with a warning) and leaves in each bin's count the entries an estimate may read:
// those both runs agree on (min(count, inserted): never an entry left from an earlier frame) and
// that fit the capacity.
//
// Use: define PB_LISTS_BINDING (first of PB_LISTS_BINDING_COUNT bindings), include this, bind
// PhotonLists::bindings() there.
#ifndef PB_TOOLKIT_PHOTON_LISTS_GLSL
#define PB_TOOLKIT_PHOTON_LISTS_GLSL

#include "photonbench/toolkit/photon_lists_layout.h"
#include "toolkit/counters.glsl"

#ifndef PB_LISTS_BINDING
#error "define PB_LISTS_BINDING before including photon_lists.glsl"
#endif

layout(std430, binding = PB_LISTS_BINDING + 0) buffer PbListCounts { uint pb_list_counts[]; };
layout(std430, binding = PB_LISTS_BINDING + 1) buffer PbListOffsets { uint pb_list_offsets[]; };
layout(std430, binding = PB_LISTS_BINDING + 2) buffer PbListCursors { uint pb_list_cursors[]; };
layout(std430, binding = PB_LISTS_BINDING + 3) buffer PbLists { uint pb_lists[]; };
layout(std430, binding = PB_LISTS_BINDING + 4) buffer PbListStats { uint pb_list_stats[]; };

// Count run: one more entry for `bin`.
void pb_list_count(uint bin) {
  atomicAdd(pb_list_counts[bin], 1u);
  ++pb_prof_atomics;
}

// Insert run: `photon` into `bin`'s list. Entries past the end of the lists are not written (the
// host reports the entries past the capacity as overflows: entries wanted - capacity; the check
// pass keeps estimates within the capacity); entries past the bin's count are not written either (a
// count/insert disagreement, which the check pass reports).
void pb_list_insert(uint bin, uint photon) {
  uint k = atomicAdd(pb_list_cursors[bin], 1u);
  ++pb_prof_atomics;
  if (k >= pb_list_counts[bin]) return;
  uint slot = pb_list_offsets[bin] + k;
  if (slot < uint(pb_lists.length())) pb_lists[slot] = photon;
}

// After the check pass: the entries of `bin` an estimate reads, [x, x + y) of pb_lists.
uvec2 pb_list_range(uint bin) { return uvec2(pb_list_offsets[bin], pb_list_counts[bin]); }

#endif
