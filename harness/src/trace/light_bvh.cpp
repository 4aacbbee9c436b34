#include "trace/light_bvh.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <unordered_map>

#include "photonbench/error.h"
#include "trace/photon_paths.h"

namespace pb::trace {
namespace {

constexpr float kPiF = std::numbers::pi_v<float>;
// Slack added to a merged cone's theta_o: the axis rotation below is exact only up to float
// rounding, and a cone must bound its children's normals (CEK18's importance is a bound).
constexpr float kConeSlack = 1e-5f;

float surface_area(const Aabb& b) {
  if (b.empty()) return 0;
  glm::vec3 d = b.hi - b.lo;
  return 2.f * (d.x * d.y + d.y * d.z + d.z * d.x);
}

// Volume with every side padded by `pad`: lights on one plane (a ceiling of lamps) have flat boxes,
// whose true volume of 0 would make every volume-heuristic split cost the same.
float padded_volume(const Aabb& b, float pad) {
  if (b.empty()) return 0;
  glm::vec3 d = b.hi - b.lo + glm::vec3(pad);
  return d.x * d.y * d.z;
}

Aabb united(Aabb a, const Aabb& b) {
  if (b.empty()) return a;
  a.extend(b.lo);
  a.extend(b.hi);
  return a;
}

// A cluster being summed: box, cone, flux and count of some lights.
struct Cluster {
  Aabb box;
  OrientationCone cone;
  float flux = 0;
  uint32_t count = 0;
  void add(const LightPrimitive& l) { add(l.box, l.cone, l.flux, l.count); }
  void add(const Aabb& b, const OrientationCone& c, float f, uint32_t n) {
    if (n == 0) return;
    box = united(box, b);
    cone = count == 0 ? c : merge(cone, c);
    flux += f;
    count += n;
  }
  void add(const Cluster& o) { add(o.box, o.cone, o.flux, o.count); }
};

glm::vec3 perpendicular(glm::vec3 a) {
  glm::vec3 other = std::abs(a.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
  return glm::normalize(glm::cross(a, other));
}

template <class Enum, size_t N>
Enum parse_enum(const std::string& name, const std::string& where, const char* key,
                const std::array<std::pair<const char*, Enum>, N>& names) {
  std::string accepted;
  for (const auto& [text, value] : names) {
    if (name == text) return value;
    accepted += accepted.empty() ? text : std::string(", ") + text;
  }
  throw InputError(
      fmt::format("{}: {}: unknown value '{}' (expected one of {})", where, key, name, accepted));
}

}  // namespace

float OrientationCone::measure() const {
  // CEK18 eq. (1): the solid angle the cone's normals may send light into, cosine-weighted.
  float theta_w = std::min(theta_o + theta_e, kPiF);
  float s = std::sin(theta_o), c = std::cos(theta_o);
  return 2.f * kPiF * (1.f - c) +
         0.5f * kPiF *
             (2.f * theta_w * s - std::cos(theta_o - 2.f * theta_w) - 2.f * theta_o * s + c);
}

OrientationCone::OrientationCone(glm::vec3 axis_, float theta_o_, float theta_e_)
    : axis(axis_),
      theta_o(theta_o_),
      theta_e(theta_e_),
      cos_o(std::cos(theta_o_)),
      sin_o(std::sin(theta_o_)),
      cos_e(std::cos(theta_e_)) {}

OrientationCone merge(const OrientationCone& first, const OrientationCone& second) {
  // CEK18 Algorithm 1: the wider cone, grown and turned towards the other until it holds both.
  const OrientationCone& a = first.theta_o >= second.theta_o ? first : second;
  const OrientationCone& b = first.theta_o >= second.theta_o ? second : first;
  float theta_d = std::acos(std::clamp(glm::dot(a.axis, b.axis), -1.f, 1.f));
  float theta_e = std::max(a.theta_e, b.theta_e);
  if (std::min(theta_d + b.theta_o, kPiF) <= a.theta_o) return {a.axis, a.theta_o, theta_e};
  float theta_o = 0.5f * (a.theta_o + theta_d + b.theta_o) + kConeSlack;
  if (theta_o >= kPiF) return {a.axis, kPiF, theta_e};
  float theta_r = theta_o - a.theta_o;
  glm::vec3 w = b.axis - a.axis * glm::dot(a.axis, b.axis);
  w = glm::length(w) > 1e-6f ? glm::normalize(w) : perpendicular(a.axis);
  glm::vec3 axis = glm::normalize(std::cos(theta_r) * a.axis + std::sin(theta_r) * w);
  return {axis, theta_o, theta_e};
}

LightPrimitive primitive(const scene::EmissiveTriangle& triangle) {
  LightPrimitive l;
  for (const auto& p : triangle.p) l.box.extend(p);
  l.cone = {triangle.normal, 0.f, 0.5f * kPiF};  // one-sided Lambertian: the hemisphere
  l.flux = detail::mean3(triangle.flux);
  return l;
}

LightPrimitive point_primitive(glm::vec3 position, float flux) {
  LightPrimitive l;
  l.box.extend(position);
  l.cone = {{0, 0, 1}, kPiF, 0.5f * kPiF};
  l.flux = flux;
  return l;
}

LightPrimitive spot_primitive(glm::vec3 position, glm::vec3 direction, float outer_angle,
                              float flux) {
  LightPrimitive l;
  l.box.extend(position);
  l.cone = {glm::normalize(direction), 0.f, outer_angle};
  l.flux = flux;
  return l;
}

void validate(const LightBvhOptions& o, const std::string& where) {
  if (o.bins < 2 || o.bins > 256)
    throw InputError(fmt::format("{}: bins: {} outside [2, 256]", where, o.bins));
  if (o.leaf_size < 1 || o.leaf_size > 10)
    throw InputError(fmt::format("{}: leaf_size: {} outside [1, 10]", where, o.leaf_size));
}

LightSamplerKind parse_sampler(const std::string& name, const std::string& where) {
  return parse_enum<LightSamplerKind, 3>(name, where, "sampler",
                                         {{{"uniform", LightSamplerKind::uniform},
                                           {"power", LightSamplerKind::power},
                                           {"bvh", LightSamplerKind::bvh}}});
}

SplitHeuristic parse_split(const std::string& name, const std::string& where) {
  return parse_enum<SplitHeuristic, 4>(name, where, "split",
                                       {{{"sah", SplitHeuristic::sah},
                                         {"saoh", SplitHeuristic::saoh},
                                         {"vh", SplitHeuristic::vh},
                                         {"voh", SplitHeuristic::voh}}});
}

LightImportance parse_importance(const std::string& name, const std::string& where) {
  return parse_enum<LightImportance, 4>(name, where, "importance",
                                        {{{"d", LightImportance::d},
                                          {"df", LightImportance::df},
                                          {"dfb", LightImportance::dfb},
                                          {"dfbo", LightImportance::dfbo}}});
}

// ---- flat samplers ------------------------------------------------------------------------------

namespace {

class UniformSampler final : public LightSampler {
 public:
  explicit UniformSampler(uint32_t n) : n_(n) {}
  bool sample(const glm::vec3&, const glm::vec3&, float u, LightPick& out) const override {
    if (n_ == 0) return false;
    out.light = std::min(uint32_t(u * float(n_)), n_ - 1);
    out.pdf = 1.f / float(n_);
    out.nodes_visited = 0;
    return true;
  }
  float pdf(const glm::vec3&, const glm::vec3&, uint32_t i) const override {
    return i < n_ ? 1.f / float(n_) : 0.f;
  }

 private:
  uint32_t n_;
};

class PowerSampler final : public LightSampler {
 public:
  explicit PowerSampler(const std::vector<LightPrimitive>& lights) {
    double total = 0;
    for (const auto& l : lights) total += std::max(0.f, l.flux);
    cdf_.assign(lights.size() + 1, 0.0);
    pmf_.assign(lights.size(), 0.f);
    for (size_t i = 0; i < lights.size(); ++i) {
      double p = total > 0 ? std::max(0.f, lights[i].flux) / total : 0.0;
      pmf_[i] = float(p);
      cdf_[i + 1] = cdf_[i] + p;
    }
  }
  bool sample(const glm::vec3&, const glm::vec3&, float u, LightPick& out) const override {
    if (pmf_.empty() || cdf_.back() <= 0) return false;
    double x = double(u) * cdf_.back();
    size_t i = size_t(std::upper_bound(cdf_.begin() + 1, cdf_.end(), x) - cdf_.begin()) - 1;
    i = std::min(i, pmf_.size() - 1);
    while (pmf_[i] <= 0 && i + 1 < pmf_.size()) ++i;  // land on a light with power
    out.light = uint32_t(i);
    out.pdf = pmf_[i];
    out.nodes_visited = 0;
    return out.pdf > 0;
  }
  float pdf(const glm::vec3&, const glm::vec3&, uint32_t i) const override {
    return i < pmf_.size() ? pmf_[i] : 0.f;
  }

 private:
  std::vector<double> cdf_;
  std::vector<float> pmf_;
};

}  // namespace

std::unique_ptr<LightSampler> make_uniform_sampler(uint32_t light_count) {
  return std::make_unique<UniformSampler>(light_count);
}

std::unique_ptr<LightSampler> make_power_sampler(const std::vector<LightPrimitive>& lights) {
  return std::make_unique<PowerSampler>(lights);
}

// ---- the light BVH ------------------------------------------------------------------------------

LightBvh::LightBvh(std::vector<LightPrimitive> lights, const LightBvhOptions& options)
    : options_(options), lights_(std::move(lights)) {
  validate(options_, "light BVH");
  order_.resize(lights_.size());
  std::iota(order_.begin(), order_.end(), 0u);
  leaf_of_.assign(lights_.size(), 0u);
  if (lights_.empty()) return;
  nodes_.reserve(2 * lights_.size());
  build(0, uint32_t(lights_.size()), ~0u);
  for (uint32_t k = 0; k < nodes_.size(); ++k)
    if (nodes_[k].leaf())
      for (uint32_t j = 0; j < nodes_[k].leaf_lights; ++j)
        leaf_of_[order_[nodes_[k].first + j]] = k;
}

uint32_t LightBvh::build(uint32_t begin, uint32_t end, uint32_t parent) {
  const uint32_t index = uint32_t(nodes_.size());
  nodes_.emplace_back();
  Cluster all;
  Aabb centroids;
  for (uint32_t k = begin; k < end; ++k) {
    const LightPrimitive& l = lights_[order_[k]];
    all.add(l);
    centroids.extend(0.5f * (l.box.lo + l.box.hi));
  }
  {
    Node& node = nodes_[index];
    node.box = all.box;
    node.cone = all.cone;
    node.flux = all.flux;
    node.count = all.count;
    node.parent = parent;
  }
  if (end - begin <= options_.leaf_size) {
    nodes_[index].first = begin;
    nodes_[index].leaf_lights = end - begin;
    return index;
  }

  // Binned split search (Wald 2007) along the largest centroid axis, or all three.
  const uint32_t bins = options_.bins;
  glm::vec3 extent = centroids.hi - centroids.lo;
  glm::vec3 box_extent = all.box.hi - all.box.lo;
  float longest = std::max({box_extent.x, box_extent.y, box_extent.z});
  float pad = std::max(1e-3f * longest, 1e-6f);
  int largest = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  bool orientation =
      options_.split == SplitHeuristic::saoh || options_.split == SplitHeuristic::voh;
  bool volume = options_.split == SplitHeuristic::vh || options_.split == SplitHeuristic::voh;
  auto size_of = [&](const Aabb& b) { return volume ? padded_volume(b, pad) : surface_area(b); };
  auto bin_of = [&](const LightPrimitive& l, int axis) {
    float c = 0.5f * (l.box.lo[axis] + l.box.hi[axis]);
    int b = int(float(bins) * (c - centroids.lo[axis]) / extent[axis]);
    return uint32_t(std::clamp(b, 0, int(bins) - 1));
  };
  float best_cost = std::numeric_limits<float>::infinity();
  int best_axis = -1;
  uint32_t best_split = 0;
  std::vector<Cluster> bin(bins), right(bins);
  for (int axis = 0; axis < 3; ++axis) {
    if (!options_.all_axes && axis != largest) continue;
    if (!(extent[axis] > 0)) continue;
    std::fill(bin.begin(), bin.end(), Cluster{});
    for (uint32_t k = begin; k < end; ++k)
      bin[bin_of(lights_[order_[k]], axis)].add(lights_[order_[k]]);
    right[bins - 1] = bin[bins - 1];
    for (int b = int(bins) - 2; b >= 0; --b) {
      right[b] = right[b + 1];
      right[b].add(bin[b]);
    }
    // Paper III's k_r: long thin boxes are penalised when split across their short side.
    float regulariser = orientation ? longest / std::max(box_extent[axis], 1e-12f) : 1.f;
    Cluster left;
    for (uint32_t s = 1; s < bins; ++s) {
      left.add(bin[s - 1]);
      const Cluster& r = right[s];
      if (left.count == 0 || r.count == 0) continue;
      float cost;
      if (orientation)
        cost = regulariser *
               (left.flux * size_of(left.box) * left.cone.measure() +
                r.flux * size_of(r.box) * r.cone.measure()) /
               std::max(size_of(all.box) * all.cone.measure(), 1e-30f);
      else
        cost = (float(left.count) * size_of(left.box) + float(r.count) * size_of(r.box)) /
               std::max(float(all.count) * size_of(all.box), 1e-30f);
      if (cost < best_cost) best_cost = cost, best_axis = axis, best_split = s;
    }
  }
  uint32_t mid;
  if (best_axis >= 0) {
    auto first_right =
        std::partition(order_.begin() + begin, order_.begin() + end,
                       [&](uint32_t i) { return bin_of(lights_[i], best_axis) < best_split; });
    mid = uint32_t(first_right - order_.begin());
  } else {
    // Every centroid in one place: halve the list.
    mid = begin + (end - begin) / 2;
  }
  uint32_t left = build(begin, mid, index);
  uint32_t right_child = build(mid, end, index);
  nodes_[index].left = left;
  nodes_[index].right = right_child;
  return index;
}

float LightBvh::importance(const glm::vec3& p, const glm::vec3& n, const Aabb& box,
                           const OrientationCone& cone, float flux, uint32_t count) const {
  // Paper III: Phi / d^2 x |cos theta'_i| x cos theta' (0 beyond theta_e), d to the box centre,
  // clamped below by the box's bounding radius so that a point inside a box does not dominate.
  glm::vec3 centre = 0.5f * (box.lo + box.hi);
  glm::vec3 to_centre = centre - p;
  float d2 = glm::dot(to_centre, to_centre);
  float r2 = 0.25f * glm::dot(box.hi - box.lo, box.hi - box.lo);
  // `d` weighs by distance alone: the node's light count stands in for its flux, so that a node
  // of many lights is not chosen as often as a single one.
  float weight = options_.importance == LightImportance::d ? float(count) : flux;
  float value = weight / std::max({d2, r2, 1e-12f});
  if (options_.importance == LightImportance::d || options_.importance == LightImportance::df)
    return value;
  if (d2 <= r2) return value;  // p inside the bounding sphere: every direction is possible
  float d = std::sqrt(d2);
  glm::vec3 wi = to_centre / d;
  float sin_u = std::sqrt(r2 / d2), cos_u = std::sqrt(std::max(0.f, 1.f - r2 / d2));
  // cos(max(0, a - theta_u)) for an angle a given by its cosine.
  auto widened = [&](float cos_a) {
    if (cos_a >= cos_u) return 1.f;
    float sin_a = std::sqrt(std::max(0.f, 1.f - cos_a * cos_a));
    return cos_a * cos_u + sin_a * sin_u;
  };
  if (glm::dot(n, n) > 0) value *= std::abs(widened(glm::dot(n, wi)));
  if (options_.importance == LightImportance::dfb) return value;
  // theta' = max(0, theta - theta_o - theta_u), the smallest angle between a normal in the cone
  // and the direction towards p, by its cosine: each difference of angles in [0, pi] from their
  // cosines and sines (cos(a - b) = cos a cos b + sin a sin b, sin(a - b) = sin a cos b -
  // cos a sin b), 0 where a <= b, so that the walk's inner loop calls no trigonometry.
  float cos_t = std::clamp(glm::dot(cone.axis, -wi), -1.f, 1.f);
  float sin_t = std::sqrt(std::max(0.f, 1.f - cos_t * cos_t));
  float cos_x = 1, sin_x = 0;  // x = max(0, theta - theta_o)
  if (cos_t < cone.cos_o) {
    cos_x = cos_t * cone.cos_o + sin_t * cone.sin_o;
    sin_x = sin_t * cone.cos_o - cos_t * cone.sin_o;
  }
  float cos_p = cos_x < cos_u ? cos_x * cos_u + sin_x * sin_u : 1.f;
  if (cos_p <= cone.cos_e) return 0;  // theta' >= theta_e
  return value * cos_p;
}

float LightBvh::leaf_probability(const Node& leaf, uint32_t j, const glm::vec3& p,
                                 const glm::vec3& n) const {
  if (options_.leaf_choice == LeafChoice::uniform) return 1.f / float(leaf.leaf_lights);
  float total = 0, mine = 0;
  for (uint32_t k = 0; k < leaf.leaf_lights; ++k) {
    const LightPrimitive& l = lights_[order_[leaf.first + k]];
    float w = importance(p, n, l.box, l.cone, l.flux, l.count);
    total += w;
    if (k == j) mine = w;
  }
  return total > 0 ? mine / total : 0.f;
}

bool LightBvh::walk(const glm::vec3& p, const glm::vec3& n, double u, LightPick& out,
                    double* rest) const {
  if (nodes_.empty()) return false;
  // One number for the whole walk, rescaled into [0, 1) at each level (Paper III); in double, so
  // that twenty levels still leave it enough bits.
  double xi = std::clamp(u, 0.0, std::nextafter(1.0, 0.0));
  double pdf = 1;
  uint32_t visited = 1, k = 0;
  while (!nodes_[k].leaf()) {
    const Node& a = nodes_[nodes_[k].left];
    const Node& b = nodes_[nodes_[k].right];
    double ia = importance(p, n, a.box, a.cone, a.flux, a.count);
    double ib = importance(p, n, b.box, b.cone, b.flux, b.count);
    visited += 2;
    if (!(ia + ib > 0)) return false;
    double p_left = ia / (ia + ib);
    if (xi < p_left) {
      xi /= p_left;
      pdf *= p_left;
      k = nodes_[k].left;
    } else {
      xi = (xi - p_left) / (1 - p_left);
      pdf *= 1 - p_left;
      k = nodes_[k].right;
    }
    xi = std::min(xi, std::nextafter(1.0, 0.0));
  }
  const Node& leaf = nodes_[k];
  uint32_t j = 0;
  if (options_.leaf_choice == LeafChoice::uniform) {
    j = std::min(uint32_t(xi * leaf.leaf_lights), leaf.leaf_lights - 1);
  } else {
    double total = 0;
    std::array<double, 10> w{};
    for (uint32_t m = 0; m < leaf.leaf_lights; ++m) {
      const LightPrimitive& l = lights_[order_[leaf.first + m]];
      w[m] = importance(p, n, l.box, l.cone, l.flux, l.count);
      total += w[m];
    }
    if (!(total > 0)) return false;
    double acc = 0, target = xi * total;
    j = leaf.leaf_lights - 1;
    for (uint32_t m = 0; m < leaf.leaf_lights; ++m) {
      if (target < acc + w[m] && w[m] > 0) {
        j = m;
        break;
      }
      acc += w[m];
    }
    if (rest) *rest = std::clamp((target - acc) / w[j], 0.0, std::nextafter(1.0, 0.0));
  }
  if (rest && options_.leaf_choice == LeafChoice::uniform) {
    double scaled = xi * leaf.leaf_lights - j;
    *rest = std::clamp(scaled, 0.0, std::nextafter(1.0, 0.0));
  }
  out.light = order_[leaf.first + j];
  out.pdf = float(pdf * leaf_probability(leaf, j, p, n));
  out.nodes_visited = visited;
  return out.pdf > 0;
}

float LightBvh::pdf(const glm::vec3& p, const glm::vec3& n, uint32_t i) const {
  if (i >= lights_.size()) return 0;
  uint32_t k = leaf_of_[i];
  const Node& leaf = nodes_[k];
  uint32_t j = 0;
  while (order_[leaf.first + j] != i) ++j;
  double pdf = leaf_probability(leaf, j, p, n);
  while (nodes_[k].parent != ~0u) {
    const Node& parent = nodes_[nodes_[k].parent];
    const Node& a = nodes_[parent.left];
    const Node& b = nodes_[parent.right];
    double ia = importance(p, n, a.box, a.cone, a.flux, a.count);
    double ib = importance(p, n, b.box, b.cone, b.flux, b.count);
    if (!(ia + ib > 0)) return 0;
    double p_left = ia / (ia + ib);
    pdf *= parent.left == k ? p_left : 1 - p_left;
    k = nodes_[k].parent;
  }
  return float(pdf);
}

glm::vec3 irradiance_sample(const LightSampler& sampler,
                            const std::vector<scene::EmissiveTriangle>& triangles,
                            const glm::vec3& p, const glm::vec3& n, float u_select, glm::vec2 u,
                            LightPick* pick) {
  LightPick chosen;
  if (!sampler.sample(p, n, u_select, chosen)) return glm::vec3(0.f);
  if (pick) *pick = chosen;
  const scene::EmissiveTriangle& t = triangles[chosen.light];
  float s = std::sqrt(u.x);  // uniform on the triangle (Shirley's square-root mapping)
  glm::vec3 y = t.p[0] + s * (1 - u.y) * (t.p[1] - t.p[0]) + s * u.y * (t.p[2] - t.p[0]);
  glm::vec3 d = y - p;
  float r2 = glm::dot(d, d);
  if (!(r2 > 0)) return glm::vec3(0.f);
  glm::vec3 w = d / std::sqrt(r2);
  float cos_p = glm::dot(n, w), cos_y = -glm::dot(t.normal, w);
  if (cos_p <= 0 || cos_y <= 0) return glm::vec3(0.f);
  return t.radiance * (cos_p * cos_y * t.area / (r2 * chosen.pdf));
}

void LightBvh::refit(std::vector<LightPrimitive> lights) {
  if (lights.size() != lights_.size())
    throw Error(fmt::format("light BVH refit: {} lights for a tree over {}", lights.size(),
                            lights_.size()));
  lights_ = std::move(lights);
  // build() numbers a node before its children, so the reverse order visits children first.
  for (uint32_t k = uint32_t(nodes_.size()); k-- > 0;) {
    Node& node = nodes_[k];
    Cluster c;
    if (node.leaf()) {
      for (uint32_t j = 0; j < node.leaf_lights; ++j) c.add(lights_[order_[node.first + j]]);
    } else {
      for (uint32_t child : {node.left, node.right}) {
        const Node& m = nodes_[child];
        c.add(m.box, m.cone, m.flux, m.count);
      }
    }
    node.box = c.box;
    node.cone = c.cone;
    node.flux = c.flux;
  }
}

TwoLevelLightBvh::TwoLevelLightBvh(const std::vector<LightPrimitive>& lights,
                                   const std::vector<uint32_t>& group,
                                   const LightBvhOptions& options)
    : options_(options) {
  validate(options_, "light BVH");
  if (group.size() != lights.size())
    throw Error(
        fmt::format("two-level light BVH: {} groups for {} lights", group.size(), lights.size()));
  std::unordered_map<uint32_t, uint32_t> index;  // group id -> group, in first-seen order
  light_group_.resize(lights.size());
  light_local_.resize(lights.size());
  for (uint32_t i = 0; i < lights.size(); ++i) {
    auto [it, added] = index.try_emplace(group[i], uint32_t(members_.size()));
    if (added) members_.emplace_back();
    const uint32_t g = it->second;
    light_group_[i] = g;
    light_local_[i] = uint32_t(members_[g].size());
    members_[g].push_back(i);
  }
  for (const auto& m : members_) {
    std::vector<LightPrimitive> own;
    for (uint32_t i : m) own.push_back(lights[i]);
    bottoms_.push_back(std::make_unique<LightBvh>(std::move(own), options_));
  }
  build_top();
}

void TwoLevelLightBvh::build_top() {
  std::vector<LightPrimitive> roots;
  for (const auto& b : bottoms_) {
    const LightBvh::Node& r = b->nodes()[0];
    roots.push_back({r.box, r.cone, r.flux, r.count});
  }
  top_ = std::make_unique<LightBvh>(std::move(roots), options_);
}

void TwoLevelLightBvh::refit(const std::vector<LightPrimitive>& lights) {
  if (lights.size() != light_group_.size())
    throw Error(fmt::format("two-level light BVH refit: {} lights for trees over {}", lights.size(),
                            light_group_.size()));
  for (size_t g = 0; g < bottoms_.size(); ++g) {
    std::vector<LightPrimitive> own;
    for (uint32_t i : members_[g]) own.push_back(lights[i]);
    bottoms_[g]->refit(std::move(own));
  }
  build_top();
}

bool TwoLevelLightBvh::sample(const glm::vec3& p, const glm::vec3& n, float u,
                              LightPick& out) const {
  LightPick group, light;
  double rest = 0;
  if (!top_->walk(p, n, u, group, &rest)) return false;
  if (!bottoms_[group.light]->walk(p, n, rest, light, nullptr)) return false;
  out.light = members_[group.light][light.light];
  out.pdf = group.pdf * light.pdf;
  out.nodes_visited = group.nodes_visited + light.nodes_visited;
  return out.pdf > 0;
}

float TwoLevelLightBvh::pdf(const glm::vec3& p, const glm::vec3& n, uint32_t i) const {
  if (i >= light_group_.size()) return 0;
  uint32_t g = light_group_[i];
  return top_->pdf(p, n, g) * bottoms_[g]->pdf(p, n, light_local_[i]);
}

size_t TwoLevelLightBvh::node_count() const {
  size_t n = top_->nodes().size();
  for (const auto& b : bottoms_) n += b->nodes().size();
  return n;
}

size_t TwoLevelLightBvh::bytes() const {
  size_t n = top_->bytes() + (light_group_.size() + light_local_.size()) * sizeof(uint32_t);
  for (const auto& b : bottoms_) n += b->bytes();
  return n;
}

size_t LightBvh::bytes() const {
  return nodes_.size() * sizeof(Node) + order_.size() * sizeof(uint32_t) +
         leaf_of_.size() * sizeof(uint32_t) + lights_.size() * sizeof(LightPrimitive);
}

}  // namespace pb::trace
