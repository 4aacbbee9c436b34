// The procedural shapes a scene file can name, each tessellated to triangles in object space. Every
// triangle is wound counter-clockwise seen from the side its vertex normals face, so Embree's
// geometric normal and the shading normal agree. Tests check each against its closed-form area and
// volume.
#pragma once

#include <algorithm>
#include <cstdint>
#include <glm/glm.hpp>
#include <memory>
#include <string>
#include <vector>

#include "scene/scene.h"

namespace pb::scene {

// A w x d rectangle in the xz plane, centred on the origin, facing +y. 2 triangles.
class QuadShape final : public Shape {
 public:
  explicit QuadShape(glm::vec2 size) : size_(size) {}
  Mesh tessellate(float time) const override;
  std::string kind() const override { return "quad"; }

 private:
  glm::vec2 size_;
};

// An axis-aligned box centred on the origin, faces outward. 12 triangles, 4 vertices per face.
class BoxShape final : public Shape {
 public:
  explicit BoxShape(glm::vec3 size) : size_(size) {}
  Mesh tessellate(float time) const override;
  std::string kind() const override { return "box"; }

 private:
  glm::vec3 size_;
};

// A UV sphere centred on the origin: `segments` slices around y, segments / 2 (at least 2) stacks.
// 2 segments (stacks - 1) triangles.
class SphereShape final : public Shape {
 public:
  SphereShape(float radius, uint32_t segments) : radius_(radius), segments_(segments) {}
  Mesh tessellate(float time) const override;
  std::string kind() const override { return "sphere"; }
  uint32_t stacks() const { return std::max<uint32_t>(2, segments_ / 2); }

 private:
  float radius_;
  uint32_t segments_;
};

// A cylinder around the y axis from y = -height/2 to +height/2. With `inner_radius` > 0 it is a
// tube (a thick-walled ring: outer wall, inner wall facing the axis, and annular caps when `caps`).
class CylinderShape final : public Shape {
 public:
  CylinderShape(float radius, float height, uint32_t segments, bool caps, float inner_radius = 0)
      : radius_(radius),
        height_(height),
        inner_radius_(inner_radius),
        segments_(segments),
        caps_(caps) {}
  Mesh tessellate(float time) const override;
  std::string kind() const override { return "cylinder"; }

 private:
  float radius_, height_, inner_radius_;
  uint32_t segments_;
  bool caps_;
};

// A torus around the y axis: tube of radius `minor` around a circle of radius `major` in the xz
// plane.
class TorusShape final : public Shape {
 public:
  TorusShape(float major, float minor, uint32_t major_segments, uint32_t minor_segments)
      : major_(major),
        minor_(minor),
        major_segments_(major_segments),
        minor_segments_(minor_segments) {}
  Mesh tessellate(float time) const override;
  std::string kind() const override { return "torus"; }

 private:
  float major_, minor_;
  uint32_t major_segments_, minor_segments_;
};

// One travelling sine wave of a height field: a sin(k (d . x) - k c t + phase), k = 2 pi /
// wavelength, moving along the unit xz direction d at phase speed c (m/s).
struct Wave {
  float amplitude = 0.01f;
  float wavelength = 1.0f;
  float speed = 0.0f;
  glm::vec2 direction{1, 0};
  float phase = 0.0f;  // radians
};

// A grid over the xz rectangle (w x d, centred, facing +y) of resolution.x * resolution.y cells,
// whose height is a sum of sine waves: the analytic water surface (a sum of Airy waves' first-order
// term, as in Tessendorf, "Simulating Ocean Water", 2001, sec. 3). Animated when any wave moves.
class HeightFieldShape final : public Shape {
 public:
  HeightFieldShape(glm::vec2 size, glm::uvec2 resolution, std::vector<Wave> waves)
      : size_(size), resolution_(resolution), waves_(std::move(waves)) {}
  Mesh tessellate(float time) const override;
  bool animated() const override;
  std::string kind() const override { return "height_field"; }
  float height(float x, float z, float time) const;
  glm::vec3 normal(float x, float z, float time) const;  // unit, analytic gradient

 private:
  glm::vec2 size_;
  glm::uvec2 resolution_;
  std::vector<Wave> waves_;
};

// A fixed triangle mesh (an OBJ file's part): tessellation returns it as loaded.
class MeshShape final : public Shape {
 public:
  MeshShape(std::string kind, Mesh mesh) : kind_(std::move(kind)), mesh_(std::move(mesh)) {}
  Mesh tessellate(float) const override { return mesh_; }
  std::string kind() const override { return kind_; }

 private:
  std::string kind_;
  Mesh mesh_;
};

}  // namespace pb::scene
