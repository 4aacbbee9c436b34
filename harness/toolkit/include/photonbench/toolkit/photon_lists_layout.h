// The stats words of pb::toolkit::PhotonLists (C++ and GLSL, toolkit/photon_lists.glsl).
#ifndef PB_TOOLKIT_PHOTON_LISTS_LAYOUT_H
#define PB_TOOLKIT_PHOTON_LISTS_LAYOUT_H

#define PB_LISTS_BINDING_COUNT 5
#define PB_LIST_STAT_WANTED 0              // entries the count run wanted (the prefix sum's total)
#define PB_LIST_STAT_CAPACITY 1            // entries the lists hold (set by the host each frame)
#define PB_LIST_STAT_BINS 2                // bins in use this frame (set by the host)
#define PB_LIST_STAT_MISMATCHED_BINS 3     // bins whose count and insert runs disagree
#define PB_LIST_STAT_MISMATCHED_ENTRIES 4  // sum over bins of |inserts - counts|
#define PB_LIST_STAT_WORDS 8

#endif
