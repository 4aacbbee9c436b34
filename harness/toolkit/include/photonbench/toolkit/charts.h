// Surfaces split into charts by a crease angle, seed 001's Ch. 8 partition for per-surface photon
// maps and illumination maps (from its reference [78]): "Mark all edges as either connected or
// unconnected" (connected: the two faces' normals differ by less than the crease angle), "Assign a
// unique ID to all polygons", "If two polygons share a connected edge make their ID identical"
// (union-find), "Create a photon map for each of the remaining ID's". The thesis gives no angle;
// 30 degrees is this toolkit's default (kDefaultCreaseAngleDegrees).
//
// Edges are matched by vertex position, not index: flat shapes repeat their vertices per face, and
// a seam's two copies of a vertex can differ in the last bits (a sphere's sin(2 pi)), so positions
// within a weld tolerance (1e-5 of the mesh's bounding-box diagonal) are one vertex. A degenerate
// (zero-area) triangle has no normal: it connects to nothing and is a chart of its own.
//
// Each chart gets a planar parameterisation by its dominant axis (the axis of the largest component
// of its area-weighted normal): uv = the other two coordinates, in metres, from the chart's lower
// corner. The thesis drew its charts by hand in a modelling tool; this projection is the automatic
// stand-in (it folds a chart that turns more than 90 degrees onto itself, which a 30-degree crease
// angle allows on a curved surface: a sphere is one chart).
//
//   const pb::toolkit::Charts charts = pb::toolkit::segment_charts(positions, triangles);
//   charts.chart_of[t];  charts.charts[c].uv(p);
#pragma once

#include <cstdint>
#include <glm/glm.hpp>
#include <span>
#include <vector>

namespace pb::toolkit {

inline constexpr float kDefaultCreaseAngleDegrees = 30.0f;

struct Chart {
  uint32_t axis = 2;                // the projection axis (0 x, 1 y, 2 z): uv are the other two
  glm::vec2 lower{0.0f};            // the chart's smallest uv coordinates before the shift (m)
  glm::vec2 extent{0.0f};           // the uv rectangle's size (m)
  double area = 0;                  // the sum of its triangles' areas (m^2)
  std::vector<uint32_t> triangles;  // in increasing order
  // Where `p` (a point of the chart) lands in the chart's plane, in [0, extent].
  glm::vec2 uv(glm::vec3 p) const;
};

struct Charts {
  std::vector<Chart> charts;       // ordered by their lowest triangle
  std::vector<uint32_t> chart_of;  // per triangle
};

// Charts of the triangle mesh (`triangles` index `positions`; throws pb::Error for an index out of
// range or a crease angle outside [0, 180]).
Charts segment_charts(std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
                      float crease_angle_degrees = kDefaultCreaseAngleDegrees);

}  // namespace pb::toolkit
