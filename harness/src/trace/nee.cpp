#include "trace/nee.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "scene/emissive_triangles.h"
#include "trace/bsdf.h"
#include "trace/photon_paths.h"
#include "trace/sampling.h"

namespace pb::trace {
namespace {

uint64_t hit_key(uint32_t object, uint32_t triangle) { return (uint64_t(object) << 32) | triangle; }

// The power heuristic with exponent 2 for one sample of each strategy.
float power_heuristic(float mine, float other) {
  float a = mine * mine, b = other * other;
  return a + b > 0 ? a / (a + b) : 0.f;
}

// The solid-angle density of choosing direction towards y on area light l from distance^2 r2 with
// cos_y at the light, given the probability of choosing the light.
float solid_angle_pdf(const NeeLight& l, float pick_pdf, float r2, float cos_y) {
  return cos_y > 0 && l.area > 0 ? pick_pdf * r2 / (cos_y * l.area) : 0.f;
}

Bsdf surface_bsdf(const scene::Scene& scene, uint32_t material, glm::vec3 p, glm::vec3 n) {
  Hit hit;
  hit.position = p;
  hit.geometric_normal = hit.shading_normal = n;
  hit.material = material;
  return Bsdf(scene.materials[material], hit);
}

// Where a G-buffer sample's rays start: off its surface along the normal (float precision).
glm::vec3 ray_origin(const GBufferSamples& gbuffer, uint32_t pixel) {
  glm::vec3 p = gbuffer.point(pixel);
  return p + gbuffer.unit_normal(pixel) * EmbreeScene::ray_epsilon(p);
}

// The frame's stream of pixel `pixel` (independent PCG32 streams, as the reference renderer's).
Pcg32 pixel_stream(uint64_t seed, uint32_t pixel) { return Pcg32(seed, pixel); }

}  // namespace

glm::vec3 area_point(const NeeLight& l, glm::vec2 u) {
  switch (l.shape) {
    case NeeLight::Shape::triangle: {
      glm::vec2 b = triangle_from_unit(u);
      return l.origin + b.x * l.edge_u + b.y * l.edge_v;
    }
    case NeeLight::Shape::quad:
      return l.origin + u.x * l.edge_u + u.y * l.edge_v;
    default: {  // disc: polar, equal-area (scene::Light::surface_point's mapping)
      float rho = std::sqrt(u.x), phi = 2.f * kPi * u.y;
      return l.origin + rho * (std::cos(phi) * l.edge_u + std::sin(phi) * l.edge_v);
    }
  }
}

uint32_t NeeLightSet::find(uint32_t object, uint32_t primitive, const EmbreeScene& world) const {
  uint64_t key = world.is_light_object(object) ? hit_key(object, ~0u) : hit_key(object, primitive);
  auto it = by_hit.find(key);
  return it == by_hit.end() ? ~0u : it->second;
}

NeeLightSet gather_nee_lights(const scene::Scene& scene, const scene::FrameState& state) {
  NeeLightSet set;
  auto add = [&](const NeeLight& l, const LightPrimitive& primitive, uint32_t group) {
    set.lights.push_back(l);
    set.primitives.push_back(primitive);
    set.group.push_back(group);
  };
  const uint32_t objects = uint32_t(scene.objects.size());
  std::vector<scene::EmissiveTriangle> triangles = scene::emissive_triangles(scene, state);
  // Culled: the emissive objects' triangles that emissive_triangles() left out.
  uint64_t emissive_total = 0;
  for (size_t i = 0; i < scene.objects.size(); ++i)
    if (scene::is_emissive(scene, i)) emissive_total += scene.objects[i].mesh.triangles.size();
  set.culled = uint32_t(emissive_total - std::min<uint64_t>(emissive_total, triangles.size()));
  for (const scene::EmissiveTriangle& t : triangles) {
    NeeLight l;
    l.shape = NeeLight::Shape::triangle;
    l.origin = t.p[0];
    l.edge_u = t.p[1] - t.p[0];
    l.edge_v = t.p[2] - t.p[0];
    l.normal = t.normal;
    l.radiance = t.radiance;
    l.area = t.area;
    set.by_hit[hit_key(t.object, t.triangle)] = uint32_t(set.lights.size());
    add(l, primitive(t), t.object);
  }
  for (uint32_t i = 0; i < state.lights.size(); ++i) {
    const scene::Light& s = state.lights[i];
    NeeLight l;
    l.radiance = s.radiant;
    LightPrimitive prim;
    switch (s.type) {
      case scene::LightType::directional:
        set.directional.push_back(i);
        continue;
      case scene::LightType::point:
        l.shape = NeeLight::Shape::point;
        l.origin = s.position;
        prim = point_primitive(s.position, 4.f * kPi * detail::mean3(s.radiant));
        break;
      case scene::LightType::spot: {
        l.shape = NeeLight::Shape::spot;
        l.origin = s.position;
        l.normal = glm::normalize(s.direction);
        l.cos_outer = std::cos(s.spot_outer);
        l.cos_inner = std::cos(s.spot_inner);
        // The flux inside the outer cone, at full intensity (an upper bound for the smooth edge).
        float flux = 2.f * kPi * (1.f - l.cos_outer) * detail::mean3(s.radiant);
        prim = spot_primitive(s.position, l.normal, s.spot_outer, flux);
        break;
      }
      case scene::LightType::quad:
      case scene::LightType::disc: {
        bool quad = s.type == scene::LightType::quad;
        l.shape = quad ? NeeLight::Shape::quad : NeeLight::Shape::disc;
        l.origin = s.position;
        l.edge_u = s.edge_u;
        l.edge_v = s.edge_v;
        l.normal = s.normal();
        l.area = s.area();
        if (quad) {
          for (float a : {0.f, 1.f})
            for (float b : {0.f, 1.f}) prim.box.extend(s.position + a * s.edge_u + b * s.edge_v);
        } else {
          for (float a : {-1.f, 1.f})
            for (float b : {-1.f, 1.f}) prim.box.extend(s.position + a * s.edge_u + b * s.edge_v);
        }
        prim.cone = {l.normal, 0.f, 0.5f * kPi};
        prim.flux = kPi * l.area * detail::mean3(s.radiant);
        set.by_hit[hit_key(objects + i, ~0u)] = uint32_t(set.lights.size());
        break;
      }
    }
    add(l, prim, objects + i);
  }
  return set;
}

NextEventEstimator::NextEventEstimator(const DirectLightSettings& settings,
                                       const LightBvhOptions& bvh)
    : settings_(settings), bvh_options_(bvh) {
  bvh_options_.importance = LightImportance(uint32_t(settings.importance));
  validate(bvh_options_, "direct_light: nee");
}

void NextEventEstimator::build(const scene::Scene& scene, const scene::FrameState& state) {
  set_ = gather_nee_lights(scene, state);
  bvh_ = one_level_ = nullptr;
  two_level_ = nullptr;
  switch (settings_.sampler) {
    case NeeSampler::uniform:
      sampler_ = make_uniform_sampler(uint32_t(set_.lights.size()));
      break;
    case NeeSampler::power:
      sampler_ = make_power_sampler(set_.primitives);
      break;
    case NeeSampler::bvh:
      if (settings_.levels == NeeLevels::two) {
        auto trees = std::make_unique<TwoLevelLightBvh>(set_.primitives, set_.group, bvh_options_);
        two_level_ = trees.get();
        sampler_ = std::move(trees);
      } else {
        auto tree = std::make_unique<LightBvh>(set_.primitives, bvh_options_);
        bvh_ = one_level_ = tree.get();
        sampler_ = std::move(tree);
      }
      break;
  }
}

bool NextEventEstimator::refit_possible() const {
  return settings_.update == NeeUpdate::refit && (one_level_ || two_level_);
}

void NextEventEstimator::update(const scene::Scene& scene, const scene::FrameState& state) {
  if (!refit_possible()) return build(scene, state);
  NeeLightSet next = gather_nee_lights(scene, state);
  // A light that went dark (culled) or lit up changes the set: only a rebuild fits it.
  if (next.lights.size() != set_.lights.size() || next.group != set_.group)
    return build(scene, state);
  set_ = std::move(next);
  if (two_level_)
    two_level_->refit(set_.primitives);
  else
    one_level_->refit(set_.primitives);
}

size_t NextEventEstimator::tree_nodes() const {
  return two_level_ ? two_level_->node_count() : bvh_ ? bvh_->nodes().size() : 0;
}

size_t NextEventEstimator::tree_bytes() const {
  return two_level_ ? two_level_->bytes() : bvh_ ? bvh_->bytes() : 0;
}

void NextEventEstimator::sample(const scene::Scene& scene, const GBufferSamples& gbuffer,
                                uint64_t seed) {
  gbuffer_ = &gbuffer;
  stats_ = {};
  pixels_.clear();
  for (uint32_t i = 0; i < gbuffer.width * gbuffer.height; ++i)
    if ((*gbuffer.position)[size_t(i) * 4 + 3] > 0) pixels_.push_back(i);
  const uint32_t per_pixel = settings_.light_samples;
  samples_.assign(pixels_.size() * per_pixel, LightSample{});
  std::vector<uint32_t> visited(pixels_.size(), 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, pixels_.size(), 256), [&](const auto& range) {
    for (size_t k = range.begin(); k < range.end(); ++k) {
      const uint32_t pixel = pixels_[k];
      glm::vec3 p = gbuffer.point(pixel);
      glm::vec3 n = gbuffer.unit_normal(pixel);
      const uint32_t material = gbuffer.material(pixel);
      const Bsdf bsdf = surface_bsdf(scene, material, p, n);
      const glm::vec3 wo = glm::normalize(gbuffer.camera - p);
      Pcg32 rng = pixel_stream(seed, pixel);
      for (uint32_t s = 0; s < per_pixel; ++s) {
        LightSample& out = samples_[k * per_pixel + s];
        out.pixel = pixel;
        const float u_select = rng.next_float();
        const glm::vec2 u_point = rng.next_2d();
        const glm::vec3 u_bsdf(rng.next_2d(), rng.next_float());
        // Smooth mirrors and glass get no direct light from these lights (as the GPU pass).
        if (!bsdf.can_eval()) continue;
        LightPick pick;
        if (sampler_ && sampler_->sample(p, n, u_select, pick)) {
          visited[k] += pick.nodes_visited;
          const NeeLight& l = set_.lights[pick.light];
          out.light = pick.light;
          out.pick_pdf = pick.pdf;
          out.point = l.area_light() ? area_point(l, u_point) : l.origin;
        }
        if (settings_.mis) {
          BsdfSample b;
          if (bsdf.sample(wo, u_bsdf, Transport::radiance, b) && !b.delta && b.pdf > 0) {
            out.bsdf_dir = b.wi;
            out.bsdf_pdf = b.pdf;
            out.bsdf_weight = b.weight;
          }
        }
      }
    }
  });
  for (uint32_t v : visited) stats_.nodes_visited += v;
  stats_.samples = samples_.size();
  // The rays, compacted: one shadow ray per chosen light, one BSDF ray per BSDF sample, one shadow
  // ray per directional light and surface pixel.
  shadow_rays_.clear();
  bsdf_rays_.clear();
  directional_rays_.clear();
  for (const LightSample& s : samples_) {
    glm::vec3 origin = ray_origin(gbuffer, s.pixel);
    // Stops short of the light's own surface, which would otherwise block its own ray.
    if (s.light != ~0u) shadow_rays_.push_back({origin, s.point - origin, 1.f - 1e-3f});
    if (s.bsdf_pdf > 0) bsdf_rays_.push_back({origin, s.bsdf_dir, kUnboundedRay});
  }
  // Their directions are the frame's (trace() sets them from the world's lights).
  for (uint32_t pixel : pixels_)
    directional_rays_.insert(directional_rays_.end(), set_.directional.size(),
                             Ray{ray_origin(gbuffer, pixel), glm::vec3(0.f), kUnboundedRay});
}

void NextEventEstimator::trace(const EmbreeScene& world) {
  // Directional rays point against each light's propagation, at this frame's direction.
  const size_t directional = set_.directional.size();
  for (size_t r = 0; r < directional_rays_.size(); ++r)
    directional_rays_[r].dir =
        -glm::normalize(world.state().lights[set_.directional[r % directional]].direction);
  blocked_.assign(shadow_rays_.size(), 0);
  directional_blocked_.assign(directional_rays_.size(), 0);
  bsdf_found_.assign(bsdf_rays_.size(), 0);
  bsdf_hits_.resize(bsdf_rays_.size());
  constexpr size_t kChunk = 4096;
  auto chunked = [&](size_t n, const auto& run) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, kChunk),
                      [&](const auto& range) { run(range.begin(), range.end() - range.begin()); });
  };
  chunked(shadow_rays_.size(), [&](size_t first, size_t count) {
    world.occluded_stream(std::span(shadow_rays_).subspan(first, count),
                          std::span(blocked_).subspan(first, count), false);
  });
  chunked(directional_rays_.size(), [&](size_t first, size_t count) {
    world.occluded_stream(std::span(directional_rays_).subspan(first, count),
                          std::span(directional_blocked_).subspan(first, count), true);
  });
  chunked(bsdf_rays_.size(), [&](size_t first, size_t count) {
    world.intersect_stream(std::span(bsdf_rays_).subspan(first, count),
                           std::span(bsdf_hits_).subspan(first, count),
                           std::span(bsdf_found_).subspan(first, count), false);
  });
  stats_.shadow_rays = shadow_rays_.size() + directional_rays_.size();
  stats_.bsdf_rays = bsdf_rays_.size();
  for (uint8_t b : blocked_) stats_.occluded += b;
  for (uint8_t b : directional_blocked_) stats_.occluded += b;
}

void NextEventEstimator::shade(const scene::Scene& scene, const EmbreeScene& world,
                               std::vector<float>& rgba) {
  const GBufferSamples& g = *gbuffer_;
  rgba.assign(size_t(g.width) * g.height * 4, 0.f);
  const uint32_t per_pixel = settings_.light_samples;
  // Where each sample's rays sit in the compacted arrays (prefix counts).
  std::vector<uint32_t> shadow_at(samples_.size() + 1, 0), bsdf_at(samples_.size() + 1, 0);
  for (size_t i = 0; i < samples_.size(); ++i) {
    shadow_at[i + 1] = shadow_at[i] + (samples_[i].light != ~0u);
    bsdf_at[i + 1] = bsdf_at[i] + (samples_[i].bsdf_pdf > 0);
  }
  const size_t directional = set_.directional.size();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, pixels_.size(), 256), [&](const auto& range) {
    for (size_t k = range.begin(); k < range.end(); ++k) {
      const uint32_t pixel = pixels_[k];
      glm::vec3 p = g.point(pixel);
      glm::vec3 n = g.unit_normal(pixel);
      const Bsdf bsdf = surface_bsdf(scene, g.material(pixel), p, n);
      const glm::vec3 wo = glm::normalize(g.camera - p);
      glm::vec3 sum(0.f);
      for (uint32_t s = 0; s < per_pixel; ++s) {
        const size_t i = k * per_pixel + s;
        const LightSample& ls = samples_[i];
        if (ls.light != ~0u && !blocked_[shadow_at[i]]) {
          const NeeLight& l = set_.lights[ls.light];
          glm::vec3 d = ls.point - p;
          float r2 = glm::dot(d, d);
          if (r2 > 0) {
            glm::vec3 wi = d / std::sqrt(r2);
            glm::vec3 f = bsdf.eval(wo, wi, Transport::radiance);  // f |cos_i|
            if (l.area_light()) {
              float cos_y = -glm::dot(l.normal, wi);
              float pdf = solid_angle_pdf(l, ls.pick_pdf, r2, cos_y);
              if (pdf > 0) {
                float weight = settings_.mis ? power_heuristic(pdf, bsdf.pdf(wo, wi)) : 1.f;
                sum += f * l.radiance * (weight / pdf);
              }
            } else {
              float falloff = 1;
              if (l.shape == NeeLight::Shape::spot) {
                float c = glm::dot(-wi, l.normal);
                float t = std::clamp((c - l.cos_outer) / std::max(l.cos_inner - l.cos_outer, 1e-6f),
                                     0.f, 1.f);
                falloff = t * t * (3.f - 2.f * t);  // GLSL smoothstep, as the GPU pass
              }
              sum += f * l.radiance * (falloff / (r2 * ls.pick_pdf));
            }
          }
        }
        if (ls.bsdf_pdf > 0 && bsdf_found_[bsdf_at[i]]) {
          const Hit& hit = bsdf_hits_[bsdf_at[i]];
          uint32_t light = set_.find(hit.object, hit.primitive, world);
          if (light != ~0u) {
            const NeeLight& l = set_.lights[light];
            float cos_y = -glm::dot(l.normal, ls.bsdf_dir);
            if (cos_y > 0) {
              float r2 = hit.t * hit.t;
              float light_pdf =
                  solid_angle_pdf(l, sampler_ ? sampler_->pdf(p, n, light) : 0.f, r2, cos_y);
              sum += ls.bsdf_weight * l.radiance * power_heuristic(ls.bsdf_pdf, light_pdf);
            }
          }
        }
      }
      sum /= float(per_pixel);
      for (size_t d = 0; d < directional; ++d) {
        if (directional_blocked_[k * directional + d]) continue;
        const scene::Light& l = world.state().lights[set_.directional[d]];
        glm::vec3 wi = -glm::normalize(l.direction);
        sum += bsdf.eval(wo, wi, Transport::radiance) * l.radiant;
      }
      rgba[pixel * 4] = sum.x;
      rgba[pixel * 4 + 1] = sum.y;
      rgba[pixel * 4 + 2] = sum.z;
      rgba[pixel * 4 + 3] = 1.f;
    }
  });
}

}  // namespace pb::trace
