#include "scene/shapes.h"

#include <cmath>
#include <glm/gtc/constants.hpp>

namespace pb::scene {

namespace {

constexpr float kTwoPi = glm::two_pi<float>();

// Collects vertices and triangles; `triangle` winds each one counter-clockwise about its vertex
// normals, so every shape's geometric normal agrees with its shading normal without per-shape
// bookkeeping.
class Builder {
 public:
  uint32_t vertex(glm::vec3 position, glm::vec3 normal) {
    mesh_.positions.push_back(position);
    mesh_.normals.push_back(normal);
    return uint32_t(mesh_.positions.size() - 1);
  }
  void triangle(uint32_t a, uint32_t b, uint32_t c) {
    const auto& p = mesh_.positions;
    const auto& n = mesh_.normals;
    glm::vec3 geometric = glm::cross(p[b] - p[a], p[c] - p[a]);
    if (glm::dot(geometric, n[a] + n[b] + n[c]) < 0) std::swap(b, c);
    mesh_.triangles.emplace_back(a, b, c);
  }
  // A (nu + 1) x (nv + 1) vertex grid from f(i, j) -> {position, normal}; each cell is two
  // triangles (a, b, c) and (a, c, d) with a = (i, j), b = (i+1, j), c = (i+1, j+1), d = (i, j+1).
  // A row whose vertices all coincide (a sphere's pole) makes one of them degenerate:
  // `collapsed_first` / `collapsed_last` drop those.
  template <class F>
  void grid(uint32_t nu, uint32_t nv, F f, bool collapsed_first = false,
            bool collapsed_last = false) {
    uint32_t base = uint32_t(mesh_.positions.size());
    for (uint32_t j = 0; j <= nv; ++j)
      for (uint32_t i = 0; i <= nu; ++i) {
        auto [position, normal] = f(i, j);
        vertex(position, normal);
      }
    auto index = [&](uint32_t i, uint32_t j) { return base + j * (nu + 1) + i; };
    for (uint32_t j = 0; j < nv; ++j)
      for (uint32_t i = 0; i < nu; ++i) {
        uint32_t a = index(i, j), b = index(i + 1, j), c = index(i + 1, j + 1), d = index(i, j + 1);
        if (!(collapsed_first && j == 0)) triangle(a, b, c);
        if (!(collapsed_last && j + 1 == nv)) triangle(a, c, d);
      }
  }
  Mesh take() { return std::move(mesh_); }

 private:
  Mesh mesh_;
};

struct Vertex {
  glm::vec3 position, normal;
};

// A disc (inner == 0) or annulus in the plane y, facing `facing` (+1 up, -1 down).
void add_cap(Builder& b, float y, float outer, float inner, uint32_t segments, float facing) {
  glm::vec3 normal(0, facing, 0);
  auto ring = [&](float r, uint32_t i) {
    float phi = kTwoPi * float(i) / float(segments);
    return glm::vec3(r * std::cos(phi), y, -r * std::sin(phi));
  };
  if (inner <= 0) {
    uint32_t centre = b.vertex(glm::vec3(0, y, 0), normal);
    uint32_t first = b.vertex(ring(outer, 0), normal);
    for (uint32_t i = 1; i <= segments; ++i) b.vertex(ring(outer, i), normal);
    for (uint32_t i = 0; i < segments; ++i) b.triangle(centre, first + i, first + i + 1);
    return;
  }
  b.grid(segments, 1, [&](uint32_t i, uint32_t j) {
    return Vertex{ring(j == 0 ? outer : inner, i), normal};
  });
}

}  // namespace

Mesh QuadShape::tessellate(float) const {
  Builder b;
  glm::vec2 h = size_ * 0.5f;
  glm::vec3 up(0, 1, 0);
  uint32_t v0 = b.vertex({-h.x, 0, -h.y}, up), v1 = b.vertex({h.x, 0, -h.y}, up);
  uint32_t v2 = b.vertex({h.x, 0, h.y}, up), v3 = b.vertex({-h.x, 0, h.y}, up);
  b.triangle(v0, v1, v2);
  b.triangle(v0, v2, v3);
  return b.take();
}

Mesh BoxShape::tessellate(float) const {
  Builder b;
  glm::vec3 h = size_ * 0.5f;
  for (int axis = 0; axis < 3; ++axis)
    for (float sign : {-1.0f, 1.0f}) {
      glm::vec3 normal(0.0f);
      normal[axis] = sign;
      int u = (axis + 1) % 3, v = (axis + 2) % 3;
      uint32_t corner[4];
      for (int k = 0; k < 4; ++k) {
        glm::vec3 p(0.0f);
        p[axis] = sign * h[axis];
        p[u] = (k == 1 || k == 2) ? h[u] : -h[u];
        p[v] = (k >= 2) ? h[v] : -h[v];
        corner[k] = b.vertex(p, normal);
      }
      b.triangle(corner[0], corner[1], corner[2]);
      b.triangle(corner[0], corner[2], corner[3]);
    }
  return b.take();
}

Mesh SphereShape::tessellate(float) const {
  Builder b;
  const uint32_t stacks = this->stacks();
  b.grid(
      segments_, stacks,
      [&](uint32_t i, uint32_t j) {
        float theta = glm::pi<float>() * float(j) / float(stacks);
        float phi = kTwoPi * float(i) / float(segments_);
        glm::vec3 n(std::sin(theta) * std::cos(phi), std::cos(theta),
                    -std::sin(theta) * std::sin(phi));
        if (j == 0) n = {0, 1, 0};  // exact poles, so the collapsed rows really are degenerate
        if (j == stacks) n = {0, -1, 0};
        return Vertex{radius_ * n, n};
      },
      true, true);
  return b.take();
}

Mesh CylinderShape::tessellate(float) const {
  Builder b;
  const float half = 0.5f * height_;
  auto wall = [&](float r, float facing) {
    b.grid(segments_, 1, [&, r, facing](uint32_t i, uint32_t j) {
      float phi = kTwoPi * float(i) / float(segments_);
      glm::vec3 radial(std::cos(phi), 0, -std::sin(phi));
      return Vertex{r * radial + glm::vec3(0, j == 0 ? -half : half, 0), facing * radial};
    });
  };
  wall(radius_, 1.0f);
  if (inner_radius_ > 0) wall(inner_radius_, -1.0f);
  if (caps_) {
    add_cap(b, half, radius_, inner_radius_, segments_, 1.0f);
    add_cap(b, -half, radius_, inner_radius_, segments_, -1.0f);
  }
  return b.take();
}

Mesh TorusShape::tessellate(float) const {
  Builder b;
  b.grid(major_segments_, minor_segments_, [&](uint32_t i, uint32_t j) {
    float phi = kTwoPi * float(i) / float(major_segments_);
    float theta = kTwoPi * float(j) / float(minor_segments_);
    glm::vec3 radial(std::cos(phi), 0, -std::sin(phi));
    glm::vec3 n = std::cos(theta) * radial + glm::vec3(0, std::sin(theta), 0);
    return Vertex{major_ * radial + minor_ * n, n};
  });
  return b.take();
}

bool HeightFieldShape::animated() const {
  for (const auto& w : waves_)
    if (w.speed != 0 && w.amplitude != 0) return true;
  return false;
}

float HeightFieldShape::height(float x, float z, float time) const {
  float h = 0;
  for (const auto& w : waves_) {
    float k = kTwoPi / w.wavelength;
    h += w.amplitude *
         std::sin(k * (w.direction.x * x + w.direction.y * z - w.speed * time) + w.phase);
  }
  return h;
}

glm::vec3 HeightFieldShape::normal(float x, float z, float time) const {
  // n ~ (-dh/dx, 1, -dh/dz) for the surface y = h(x, z).
  float dx = 0, dz = 0;
  for (const auto& w : waves_) {
    float k = kTwoPi / w.wavelength;
    float slope = w.amplitude * k *
                  std::cos(k * (w.direction.x * x + w.direction.y * z - w.speed * time) + w.phase);
    dx += slope * w.direction.x;
    dz += slope * w.direction.y;
  }
  return glm::normalize(glm::vec3(-dx, 1, -dz));
}

Mesh HeightFieldShape::tessellate(float time) const {
  Builder b;
  b.grid(resolution_.x, resolution_.y, [&](uint32_t i, uint32_t j) {
    float x = size_.x * (float(i) / float(resolution_.x) - 0.5f);
    float z = size_.y * (float(j) / float(resolution_.y) - 0.5f);
    return Vertex{{x, height(x, z, time), z}, normal(x, z, time)};
  });
  return b.take();
}

}  // namespace pb::scene
