// Closest-hit rays over the scene's triangles (pb::SceneTriangles) on the CPU, with Embree: for a
// technique that casts its own rays (a final gather's hemisphere rays) and needs the hit's triangle
// in the scene-wide numbering that photon records and draw_scene use. One static Embree scene of
// the triangles' world positions; rebuild it (a new caster) when SceneTriangles::changed_frame
// moves. Thread-safe for queries.
//
//   const pb::toolkit::TriangleRayCaster caster(ctx.shared().scene_triangles());
//   if (auto hit = caster.closest(origin, direction, t_max)) hit->triangle;
#pragma once

#include <cstdint>
#include <glm/glm.hpp>
#include <memory>
#include <optional>

#include "photonbench/scene_triangles.h"

namespace pb::toolkit {

class TriangleRayCaster {
 public:
  struct Hit {
    uint32_t triangle;  // scene-wide index (photonbench/scene_layout.h)
    float distance;     // along the unit direction, metres
  };

  // Builds over the host records (throws pb::Error when Embree fails).
  explicit TriangleRayCaster(const SceneTriangles& triangles);
  ~TriangleRayCaster();
  TriangleRayCaster(const TriangleRayCaster&) = delete;
  TriangleRayCaster& operator=(const TriangleRayCaster&) = delete;

  // The closest triangle along `origin + t direction` (unit direction) for t in (t_min, t_max),
  // either side of it.
  std::optional<Hit> closest(glm::vec3 origin, glm::vec3 direction, float t_min, float t_max) const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace pb::toolkit
