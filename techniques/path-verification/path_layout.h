// The data layout of Paper II §4 on the CPU side of path verification: the 32-bit path-information
// word, the distribution-map cell of a path, the bounce-major photon map and the memory of each
// structure as Paper II Table 1 reports it. Header-only, so that the tests check these very
// functions.
#pragma once

#include <fmt/format.h>

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "photonbench/error.h"
#include "photonbench/photons.h"

namespace pb::pathverification {

// §4: "22 bits for the ID of the DM_C cell, 4 for the number of segments, 4 for the segment to
// re-trace from, 1 for the replace flag, 1 for the reuse-light flag" (low bits first).
struct PathInfo {
  static constexpr uint32_t kCellBits = 22, kSegmentBits = 4;
  static constexpr uint32_t kMaxCells = 1u << kCellBits;              // 4,194,304
  static constexpr uint32_t kMaxSegments = (1u << kSegmentBits) - 1;  // 15
  uint32_t cell = 0;
  uint32_t segments = 0;
  uint32_t restart_segment = 0;  // meaningful when replace is set and reuse_light too
  bool replace = false;          // some segment is re-traced this frame
  bool reuse_light = true;       // the light sample (origin and first direction) is kept

  uint32_t pack() const;
  static PathInfo unpack(uint32_t word);
};

// The limits of the packing, checked by the descriptor's check (Paper II §4: "limited to at most 16
// bounces, or to having at most 4 million cells in a distribution map"). `max_segments` is the most
// segments a path can have (max_bounces: one per surface interaction, the last one possibly
// escaping). "" within them, else "<parameter>: why".
std::string check_packing_limits(uint32_t max_segments, uint64_t cells_per_map);

// Segments of a kept path (its rays when traced afresh).
uint32_t path_segments(const trace::LightPath& path, std::span<const trace::PathVertex> vertices);

// The photon map of §4, bounce-major: row i holds the i-th stored photon of every path that has
// one, so threads that each read the i-th photon of consecutive paths read consecutive records.
// Rows are compacted (no empty slot for a path that stored fewer photons, unlike the paper's fixed
// paths x max_photons_per_path array; its size is reported beside ours). Throws pb::Error if a
// path stored more than `max_photons_per_path` photons.
struct PhotonMap {
  std::vector<trace::PhotonRecord> records;
  std::vector<uint32_t> row_start;  // rows + 1 offsets into records
  void build(const trace::PhotonBatch& batch, uint32_t max_photons_per_path);
};

// Bytes of each structure, named as Paper II Table 1 names its rows.
struct LayoutBytes {
  uint64_t path_information = 0, path_origins = 0, distribution_maps = 0, pruned_paths = 0;
  uint64_t photon_map = 0;        // ours: the compacted rows of PhotonRecord (96 B)
  uint64_t photon_map_paper = 0;  // the paper's: paths x max_photons_per_path x 32 B
};

// ---- implementation

inline uint32_t PathInfo::pack() const {
  return (cell & (kMaxCells - 1)) | (segments & kMaxSegments) << kCellBits |
         (restart_segment & kMaxSegments) << (kCellBits + kSegmentBits) | uint32_t(replace) << 30 |
         uint32_t(reuse_light) << 31;
}

inline PathInfo PathInfo::unpack(uint32_t word) {
  PathInfo info;
  info.cell = word & (kMaxCells - 1);
  info.segments = (word >> kCellBits) & kMaxSegments;
  info.restart_segment = (word >> (kCellBits + kSegmentBits)) & kMaxSegments;
  info.replace = (word >> 30) & 1u;
  info.reuse_light = (word >> 31) & 1u;
  return info;
}

inline std::string check_packing_limits(uint32_t max_segments, uint64_t cells_per_map) {
  if (max_segments > PathInfo::kMaxSegments)
    return fmt::format(
        "max_bounces: {} allows paths of {} segments; the path-information word holds at most {} "
        "(4 bits, Paper II §4)",
        max_segments, max_segments, PathInfo::kMaxSegments);
  if (cells_per_map > PathInfo::kMaxCells)
    return fmt::format(
        "dm_position_cells: a distribution map of {} cells (dm_position_cells^2 x "
        "dm_direction_cells^2 for area lights) exceeds the {} cells the path-information word "
        "can name (22 bits, Paper II §4)",
        cells_per_map, PathInfo::kMaxCells);
  return "";
}

inline uint32_t path_segments(const trace::LightPath& path,
                              std::span<const trace::PathVertex> vertices) {
  if (path.vertex_count == 0) return 0;
  bool escapes =
      vertices[path.first_vertex + path.vertex_count - 1].flags & trace::PathVertex::kEscapes;
  return path.vertex_count - 1 + (escapes ? 1 : 0);
}

inline void PhotonMap::build(const trace::PhotonBatch& batch, uint32_t max_photons_per_path) {
  const auto& paths = batch.paths.paths;
  records.clear();
  records.reserve(batch.photons.size());
  row_start.assign(1, 0);
  for (const auto& path : paths)
    if (path.photon_count > max_photons_per_path)
      throw Error(fmt::format(
          "path-verification: a path stored {} photons, more than max_photons_per_path = {}",
          path.photon_count, max_photons_per_path));
  for (uint32_t row = 0; row < max_photons_per_path; ++row) {
    for (const auto& path : paths)
      if (path.photon_count > row) records.push_back(batch.photons[path.first_photon + row]);
    row_start.push_back(uint32_t(records.size()));
    if (records.size() == batch.photons.size()) break;
  }
}

}  // namespace pb::pathverification
