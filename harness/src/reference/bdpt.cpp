#include "reference/bdpt.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "trace/bsdf.h"
#include "trace/sampling.h"

namespace pb::trace::detail {
namespace {

// Subpath vertices at most: the camera (or light) vertex plus every scattering vertex a path within
// the bounce budget can have, plus the emitter a camera subpath may end on.
constexpr int kMaxVertices = int(kUntruncatedBounces) + 2;

struct Vertex {
  enum Kind : uint8_t { camera, light, surface };
  Kind kind = surface;
  glm::vec3 p{0.0f};
  glm::vec3 ng{0.0f};  // geometric normal; a light's emitting normal (0 for points, directions)
  glm::vec3 wo{0.0f};  // towards the previous vertex of its own subpath
  Hit hit;             // surfaces
  // Camera subpath: the throughput arriving here (path tracing's beta). Light subpath: the power
  // arriving here, like a photon's (Veach's alpha times the geometric cosine towards the previous
  // vertex, which the generation density divides by and the path contribution does not contain).
  glm::vec3 beta{0.0f};
  // Densities per unit area of this vertex: from its own subpath's previous vertices, and from the
  // other side (the next vertex of its subpath and the one after). A delta factor is 1.
  float pdf_fwd = 0, pdf_rev = 0;
  bool delta = false;     // a surface whose BSDF is a delta (connections cannot use it)
  bool diffuse = false;   // D in the light path expression
  bool infinite = false;  // a directional light: its "position" is a direction
  bool on_light = false;  // a camera vertex on a quad light's geometry (the luminaire absorbs)
  int emitter = -1;       // light vertex; camera vertex on an emitter's surface
  ClassState cls;         // camera subpath: the class state after this vertex
};

float cos_g(const Vertex& v, const glm::vec3& dir) { return std::abs(glm::dot(v.ng, dir)); }

// Density per unit area at `to` of a direction sampled at `from` with solid-angle density pdf.
float to_area(float pdf, const Vertex& from, const Vertex& to) {
  glm::vec3 d = to.p - from.p;
  float d2 = glm::dot(d, d);
  if (!(d2 > 0)) return 0;
  if (to.kind == Vertex::camera) return 0;  // a pinhole cannot be hit
  if (to.kind == Vertex::light && (to.infinite || to.ng == glm::vec3(0.f)))
    return 0;  // neither can a point or a direction
  return pdf * std::abs(glm::dot(to.ng, d)) / (d2 * std::sqrt(d2));
}

// Density per unit area with which the light side generates `to` from light vertex `l` (y_0):
// its emission direction density converted at `to` (directional lights: the emission square's
// density projected onto the surface).
float light_to_area(const LightSet& lights, const Vertex& l, const Vertex& to) {
  if (l.infinite)  // l.ng holds the direction the light travels
    return lights.direction_pdf(uint32_t(l.emitter), glm::vec3(0.f), l.ng) * cos_g(to, l.ng);
  glm::vec3 dir = glm::normalize(to.p - l.p);
  return to_area(lights.direction_pdf(uint32_t(l.emitter), l.ng, dir), l, to);
}

// No default member initialisers: each strategy's evaluation declares an array of these for the
// longest path (kMaxVertices, 66 entries) and writes the k + 1 it reads (camera_entries,
// light_entries and the connection's own), so zeroing the rest cost a 1.6-3.2 KB memset per
// strategy, per connection.
struct MisVertex {
  double pc, pl;  // densities from the camera side and from the light side
  bool connectable;
};

// Light tracing (t = 1) is run for paths with at least two scattering vertices only: for direct
// light (C D L) next-event estimation is as good as a strategy gets (exact for a point light but
// for the pixel position), and the power heuristic would still hand light tracing a share of it, at
// a fraction of a sample per pixel per iteration (measured: the point-light-over-a-plane image went
// from 0.1% to 3% noise at 64 iterations with it). Emitters seen directly (C L) come from s = 0.
bool runs_light_tracing(int k) { return k >= 3; }

// Power-heuristic weight of strategy s (s light vertices) for the full path x_0 .. x_k described by
// x[0..k]: p_j = prod_{i > k-j} pl_i * prod_{0 < i <= k-j} pc_i, so p_{j+1} / p_j = pl / pc at
// vertex k - j, walked outwards from p_s. Strategy j needs its connection's two vertices to be
// connectable and to be among those run; j = 0 needs an emitter with area.
// With the uniform heuristic every strategy that can sample the path gets the same weight (unbiased
// too, and noisier: for tests, where it makes every strategy's share large enough to be checked).
// A zero density ends the walk in its direction: the strategies beyond share that factor.
double mis_weight(const MisVertex* x, int k, int s, bool light_has_area, MisHeuristic heuristic) {
  auto valid = [&](int j) {
    if (j == 0) return light_has_area;
    if (j == k && !runs_light_tracing(k)) return false;
    return x[k - j].connectable && x[k - j + 1].connectable;
  };
  auto term = [&](double r) {
    return heuristic == MisHeuristic::power ? r * r : r > 0 ? 1.0 : 0.0;
  };
  double sum = 1, r = 1;
  for (int j = s + 1; j <= k; ++j) {
    const MisVertex& v = x[k - j + 1];
    if (!(v.pc > 0)) break;
    r *= v.pl / v.pc;
    if (valid(j)) sum += term(r);
  }
  r = 1;
  for (int j = s - 1; j >= 0; --j) {
    const MisVertex& v = x[k - j];
    if (!(v.pl > 0)) break;
    r *= v.pc / v.pl;
    if (valid(j)) sum += term(r);
  }
  return 1.0 / sum;
}

struct Splat {
  uint32_t pixel;
  uint8_t path_class;
  glm::vec3 value;
};

class PixelSampler {
 public:
  PixelSampler(const EmbreeScene& world, const LightSet& lights, const Rig& rig, uint32_t wanted,
               uint32_t budget, MisHeuristic heuristic, int stride, uint64_t& rays)
      : world_(world),
        scene_(world.scene()),
        lights_(lights),
        rig_(rig),
        wanted_(wanted),
        budget_(budget),
        heuristic_(heuristic),
        stride_(stride),
        rays_(rays) {}

  // One light path and the camera path through (px, py); contributions into out[0..4], light
  // tracing splats appended to `splats`.
  void sample(float px, float py, Pcg32& camera_rng, Pcg32& light_rng, glm::vec3* out,
              std::vector<Splat>& splats) {
    // Light subpaths serve paths with at least two scattering vertices (connections and light
    // tracing), which direct light alone never needs.
    int ny = (wanted_ & ~class_bit(PathClass::direct)) && budget_ >= 2 ? light_walk(light_rng) : 0;
    for (int s = 2; s <= ny; ++s)
      if (!y_[s - 1].delta) splat_to_camera(s, splats);
    for (int c = 0; c < kClasses; ++c) out[c] = glm::vec3(0.f);
    int nz = camera_walk(px, py, camera_rng);
    for (int t = 2; t <= nz; ++t) {
      const Vertex& v = z_[t - 1];
      if (v.emitter >= 0) emitter_hit(t, out);
      if (v.on_light || v.delta || uint32_t(t - 1) > budget_) continue;  // z_{budget+1}: s = 0 only
      next_event(t, camera_rng, out);
      for (int s = 2; s <= ny; ++s)
        if (!y_[s - 1].delta) connect(s, t, out);
    }
  }

 private:
  Bsdf bsdf(const Vertex& v) const { return Bsdf(scene_.materials[v.hit.material], v.hit); }

  void add(glm::vec3* out, const ClassState& cls, bool light_side_specular, int k,
           const glm::vec3& value) const {
    if (uint32_t(k - 1) > budget_) return;  // scattering vertices: x_1 .. x_{k-1}
    if (photon_mapping_owns(cls.anchor, light_side_specular)) return;
    int c = cls.classify();
    if (!(wanted_ & (1u << c)) || !(max3(value) > 0) || !std::isfinite(max3(value))) return;
    out[c] += value;
  }

  Vertex surface_vertex(const Hit& hit, const glm::vec3& dir) const {
    Vertex v;
    v.kind = Vertex::surface;
    v.hit = hit;
    v.p = hit.position;
    v.ng = hit.geometric_normal;
    v.wo = -dir;
    v.on_light = world_.is_light_object(hit.object);
    v.emitter = lights_.emitter_of_object(hit.object);
    return v;
  }

  // z_0 (the pinhole) .. : path tracing's random walk, keeping every vertex.
  int camera_walk(float px, float py, Pcg32& rng) {
    Vertex& c = z_[0];
    c = Vertex{};
    c.kind = Vertex::camera;
    c.p = rig_.position;
    c.beta = glm::vec3(1.f);
    glm::vec3 origin = c.p, dir = rig_.direction(px, py), beta(1.f);
    float pdf = rig_.film_density(dir);
    int n = 1;
    for (; n < kMaxVertices && uint32_t(n) <= budget_ + 1; ++n) {
      Hit hit;
      ++rays_;
      if (!world_.intersect(origin, dir, kUnboundedRay, hit)) break;
      Vertex& v = z_[n];
      const Vertex& prev = z_[n - 1];
      v = surface_vertex(hit, dir);
      v.beta = beta;
      v.pdf_fwd = prev.delta ? 1.f : to_area(pdf, prev, v);
      v.cls = prev.cls;
      if (v.on_light || uint32_t(n) == budget_ + 1) return n + 1;  // only s = 0 uses it
      Bsdf b = bsdf(v);
      v.diffuse = b.is_diffuse();
      v.delta = !b.can_eval();
      v.cls = prev.cls.push(v.diffuse);
      if ((v.cls.reachable() & wanted_) == 0) return n + 1;
      BsdfSample s;
      glm::vec3 u{rng.next_float(), rng.next_float(), rng.next_float()};
      if (!b.sample(v.wo, u, Transport::radiance, s)) return n + 1;
      if (n >= 2) z_[n - 1].pdf_rev = v.delta ? 1.f : to_area(b.pdf(s.wi, v.wo), v, z_[n - 1]);
      beta *= s.weight;
      if (!(max3(beta) > 0) || !std::isfinite(max3(beta))) return n + 1;
      if (n >= 4) {  // Russian roulette on the throughput, as path tracing
        float q = std::min(0.95f, max3(beta));
        if (rng.next_float() >= q) return n + 1;
        beta /= q;
      }
      pdf = s.pdf;
      dir = s.wi;
      origin = offset_origin(hit, dir);
    }
    return n;
  }

  // y_0 (a point on an emitter, chosen by power) .. : the photon tracer's random walk, keeping
  // every vertex.
  int light_walk(Pcg32& rng) {
    if (lights_.size() == 0) return 0;
    Vertex& l = y_[0];
    l = Vertex{};
    l.kind = Vertex::light;
    l.emitter = int(lights_.choose(rng.next_float()));
    glm::vec2 uv = rng.next_2d(), u_dir = rng.next_2d();
    EmissionRay e = lights_.emit(uint32_t(l.emitter), uv, u_dir);
    float select = lights_.selection_probability(uint32_t(l.emitter));
    l.infinite = lights_.emitter(uint32_t(l.emitter)).type == EmitterType::directional;
    l.p = e.origin;
    l.ng = l.infinite ? e.direction : e.normal;  // a directional light keeps its direction here
    l.pdf_fwd = lights_.position_pdf(uint32_t(l.emitter));
    glm::vec3 power = e.power / select;
    if (!(select > 0) || !(max3(power) > 0)) return 0;
    glm::vec3 dir = e.direction;
    glm::vec3 origin = e.normal == glm::vec3(0.f)
                           ? e.origin
                           : e.origin + e.normal * EmbreeScene::ray_epsilon(e.origin);
    float pdf = 0;
    glm::vec3 first_power = power;
    int n = 1;
    for (; n < kMaxVertices && uint32_t(n) <= budget_; ++n) {
      Hit hit;
      ++rays_;
      if (!world_.intersect(origin, dir, kUnboundedRay, hit)) break;
      if (world_.is_light_object(hit.object)) break;  // a luminaire absorbs what reaches it
      Vertex& v = y_[n];
      const Vertex& prev = y_[n - 1];
      v = surface_vertex(hit, dir);
      v.beta = power;
      v.pdf_fwd = n == 1       ? light_to_area(lights_, prev, v)
                  : prev.delta ? 1.f
                               : to_area(pdf, prev, v);
      Bsdf b = bsdf(v);
      v.diffuse = b.is_diffuse();
      v.delta = !b.can_eval();
      if (uint32_t(n) == budget_) return n + 1;
      BsdfSample s;
      glm::vec3 u{rng.next_float(), rng.next_float(), rng.next_float()};
      if (!b.sample(v.wo, u, Transport::importance, s)) return n + 1;
      // The camera side would generate the previous vertex from this one with this density (the
      // light vertex: only surface emitters can be hit).
      y_[n - 1].pdf_rev = v.delta ? 1.f : to_area(b.pdf(s.wi, v.wo), v, y_[n - 1]);
      // Shading normals make light transport's BSDF the adjoint of radiance transport's (Veach 1997
      // eq. 5.19): |cos_s(wo)| |cos_g(wi)| / (|cos_g(wo)| |cos_s(wi)|).
      float cs_o = std::abs(glm::dot(hit.shading_normal, v.wo));
      float cs_i = std::abs(glm::dot(hit.shading_normal, s.wi));
      float cg_o = cos_g(v, v.wo), cg_i = cos_g(v, s.wi);
      if (!(cg_o > 0) || !(cs_i > 0)) return n + 1;
      power *= s.weight * (cs_o * cg_i / (cg_o * cs_i));
      if (!(max3(power) > 0) || !std::isfinite(max3(power))) return n + 1;
      if (n >= 3) {
        float q = std::min(0.95f, max3(power) / max3(first_power));
        if (rng.next_float() >= q) return n + 1;
        power /= q;
      }
      pdf = s.pdf;
      dir = s.wi;
      origin = offset_origin(hit, dir);
    }
    return n;
  }

  // The camera-side entries x_1 .. x_{t-1} of a full path whose first t vertices are z_0..z_{t-1}:
  // pc from the camera walk, pl from it where the light side's generation does not depend on the
  // connection (x_i with i <= t-3).
  void camera_entries(int t, MisVertex* x) const {
    x[0] = {0, 0, true};
    for (int i = 1; i < t; ++i) x[i] = {z_[i].pdf_fwd, z_[i].pdf_rev, !z_[i].delta};
  }
  // The light-side entries for y_{s-1} .. y_0 at x_{k-s+1} .. x_k (x_k = y_0).
  void light_entries(int s, int k, MisVertex* x) const {
    for (int j = 0; j < s; ++j) x[k - j] = {y_[j].pdf_rev, y_[j].pdf_fwd, j == 0 || !y_[j].delta};
  }

  // s = 0: the camera subpath's vertex z_{t-1} lies on an emitter.
  void emitter_hit(int t, glm::vec3* out) {
    const Vertex& v = z_[t - 1];
    glm::vec3 le = lights_.emitted(v.hit, v.wo);
    if (!(max3(le) > 0)) return;
    int k = t - 1;
    MisVertex x[kMaxVertices + 1];
    camera_entries(t, x);
    Vertex l;
    l.kind = Vertex::light;
    l.p = v.p;
    l.ng = v.ng;
    l.emitter = v.emitter;
    x[k].pl = lights_.position_pdf(uint32_t(v.emitter));
    x[k].connectable = true;
    if (k >= 2) x[k - 1].pl = light_to_area(lights_, l, z_[k - 1]);
    const Vertex& before = z_[t - 2];
    double w = mis_weight(x, k, 0, true, heuristic_);
    add(out, before.cls, k >= 2 && !before.diffuse, k, v.beta * le * float(w));
  }

  // s = 1: next-event estimation from z_{t-1} with a fresh light sample.
  void next_event(int t, Pcg32& rng, glm::vec3* out) {
    const Vertex& v = z_[t - 1];
    if (uint32_t(t - 1) > budget_ || photon_mapping_owns(v.cls.anchor, !v.diffuse) ||
        !(wanted_ & (1u << v.cls.classify())))
      return;
    IncidentSample is;
    float u_select = rng.next_float();
    glm::vec2 u = rng.next_2d();
    if (!lights_.sample_incident(v.p, u_select, u, is)) return;
    Bsdf b = bsdf(v);
    glm::vec3 f = b.eval(v.wo, is.wi, Transport::radiance);
    if (!(max3(f) > 0)) return;
    int k = t;
    MisVertex x[kMaxVertices + 1];
    camera_entries(t, x);
    Vertex l;
    l.kind = Vertex::light;
    l.emitter = int(is.emitter);
    l.infinite = std::isinf(is.distance);
    l.p = l.infinite ? v.p + is.wi : is.point;
    l.ng = l.infinite ? -is.wi : is.normal;
    bool area = lights_.has_area(is.emitter);
    x[k].pl = lights_.position_pdf(is.emitter);
    x[k].pc = area ? to_area(b.pdf(v.wo, is.wi), v, l) : 0.0;
    x[k].connectable = true;
    x[k - 1].pl = light_to_area(lights_, l, v);
    if (k >= 3) x[k - 2].pl = to_area(b.pdf(is.wi, v.wo), v, z_[t - 2]);
    double w = mis_weight(x, k, 1, area, heuristic_);
    ++rays_;
    if (!(l.infinite ? direction_clear(world_, v.hit, is.wi)
                     : segment_clear(world_, v.hit, is.point)))
      return;
    add(out, v.cls, !v.diffuse, k, v.beta * f * is.weight * float(w));
  }

  // The class state of a full path: the camera part's state, then the light subpath's scattering
  // vertices y_{s-1} .. y_1 pushed in camera order.
  ClassState with_light_part(ClassState cls, int s) const {
    for (int j = s - 1; j >= 1; --j) cls = cls.push(y_[j].diffuse);
    return cls;
  }

  // s >= 2, t >= 2: a shadow ray between z_{t-1} and y_{s-1}.
  void connect(int s, int t, glm::vec3* out) {
    const Vertex& v = z_[t - 1];
    const Vertex& u = y_[s - 1];
    int k = s + t - 1;
    if (uint32_t(k - 1) > budget_) return;
    ClassState cls = with_light_part(v.cls, s);
    bool light_side_specular = !y_[1].diffuse;
    if (photon_mapping_owns(cls.anchor, light_side_specular) || !(wanted_ & (1u << cls.classify())))
      return;
    glm::vec3 d = u.p - v.p;
    float d2 = glm::dot(d, d);
    if (!(d2 > 0)) return;
    glm::vec3 dir = d / std::sqrt(d2);
    Bsdf bv = bsdf(v), bu = bsdf(u);
    glm::vec3 fv = bv.eval(v.wo, dir, Transport::radiance);
    glm::vec3 fu = bu.eval(-dir, u.wo, Transport::radiance);
    float cu = cos_g(u, u.wo);
    if (!(max3(fv) > 0) || !(max3(fu) > 0) || !(cu > 0)) return;
    glm::vec3 value = v.beta * fv * (cos_g(u, dir) / d2) * fu * (u.beta / cu);
    if (!(max3(value) > 0)) return;
    MisVertex x[2 * kMaxVertices + 1];
    camera_entries(t, x);
    light_entries(s, k, x);
    // The four densities the connection decides: each end generated from the other end, and the
    // vertex behind each end generated through it.
    x[t].pc = to_area(bv.pdf(v.wo, dir), v, u);
    x[t - 1].pl = to_area(bu.pdf(u.wo, -dir), u, v);
    x[t + 1].pc =
        s == 2 ? (lights_.has_area(uint32_t(y_[0].emitter)) ? to_area(bu.pdf(-dir, u.wo), u, y_[0])
                                                            : 0.0)
               : to_area(bu.pdf(-dir, u.wo), u, y_[s - 2]);
    if (t >= 3) x[t - 2].pl = to_area(bv.pdf(dir, v.wo), v, z_[t - 2]);
    double w = mis_weight(x, k, s, lights_.has_area(uint32_t(y_[0].emitter)), heuristic_);
    ++rays_;
    if (!hits_clear(v.hit, u.hit)) return;
    add(out, cls, light_side_specular, k, value * float(w));
  }

  // t = 1: y_{s-1} seen by the camera, splatted into the pixel it lands in.
  void splat_to_camera(int s, std::vector<Splat>& splats) {
    const Vertex& u = y_[s - 1];
    int k = s;
    if (uint32_t(k - 1) > budget_ || !runs_light_tracing(k)) return;
    ClassState cls = with_light_part(ClassState{}, s);
    bool light_side_specular = !y_[1].diffuse;
    if (photon_mapping_owns(cls.anchor, light_side_specular) || !(wanted_ & (1u << cls.classify())))
      return;
    glm::vec3 d = rig_.position - u.p;
    float d2 = glm::dot(d, d);
    if (!(d2 > 0)) return;
    glm::vec3 to_camera = d / std::sqrt(d2);
    glm::vec2 raster;
    if (!rig_.raster(-to_camera, raster)) return;
    uint32_t px = std::min(uint32_t(raster.x), uint32_t(rig_.width - 1));
    uint32_t py = std::min(uint32_t(raster.y), uint32_t(rig_.height - 1));
    if (!in_grid(int(px), int(py), stride_)) return;
    Bsdf bu = bsdf(u);
    glm::vec3 fu = bu.eval(to_camera, u.wo, Transport::radiance);
    float cu = cos_g(u, u.wo);
    if (!(max3(fu) > 0) || !(cu > 0)) return;
    float importance = rig_.film_density(-to_camera);
    glm::vec3 value = fu * (importance * cos_g(u, to_camera) / d2) * (u.beta / cu);
    if (!(max3(value) > 0) || !std::isfinite(max3(value))) return;
    MisVertex x[kMaxVertices + 1];
    x[0] = {0, 0, true};
    light_entries(s, k, x);
    Vertex cam;
    cam.kind = Vertex::camera;
    cam.p = rig_.position;
    x[1].pc = importance * cos_g(u, to_camera) / d2;
    x[2].pc = s == 2 ? (lights_.has_area(uint32_t(y_[0].emitter))
                            ? to_area(bu.pdf(to_camera, u.wo), u, y_[0])
                            : 0.0)
                     : to_area(bu.pdf(to_camera, u.wo), u, y_[s - 2]);
    double w = mis_weight(x, k, s, lights_.has_area(uint32_t(y_[0].emitter)), heuristic_);
    ++rays_;
    glm::vec3 origin = offset_origin(u.hit, to_camera);
    glm::vec3 rest = rig_.position - origin;
    float length = glm::length(rest);
    if (world_.occluded(origin, rest / length, length * (1.f - 1e-5f))) return;
    // On the pilot's grid, one light path in stride^2 runs, and stands for them all.
    float count = float(stride_) * float(stride_);
    splats.push_back(
        {py * uint32_t(rig_.width) + px, uint8_t(cls.classify()), value * float(w) * count});
  }

  // A shadow ray between two surface points, each end off its own surface towards the other.
  bool hits_clear(const Hit& a, const Hit& b) const {
    glm::vec3 oa = offset_origin(a, b.position - a.position);
    glm::vec3 ob = offset_origin(b, a.position - b.position);
    glm::vec3 d = ob - oa;
    float length = glm::length(d);
    return !(length > 0) || !world_.occluded(oa, d / length, length * (1.f - 1e-5f));
  }

  const EmbreeScene& world_;
  const scene::Scene& scene_;
  const LightSet& lights_;
  const Rig& rig_;
  uint32_t wanted_, budget_;
  MisHeuristic heuristic_;
  int stride_;
  uint64_t& rays_;
  Vertex z_[kMaxVertices], y_[kMaxVertices];
};

}  // namespace

BdptPass::BdptPass(const EmbreeScene& world, const LightSet& lights, const Rig& rig,
                   uint32_t wanted, uint32_t budget, MisHeuristic heuristic)
    : world_(world),
      lights_(lights),
      rig_(rig),
      wanted_(wanted),
      budget_(budget),
      heuristic_(heuristic) {}

uint64_t BdptPass::run(uint32_t iteration_seed, tbb::task_arena& arena,
                       tbb::combinable<uint64_t>& ray_count, std::vector<glm::vec3>& frame,
                       int stride, std::vector<glm::vec3>* splat_frame) {
  const int width = rig_.width, height = rig_.height;
  std::vector<std::vector<Splat>> row_splats(height);
  uint32_t light_seed = hash_combine(iteration_seed, 0x11647u);
  tbb::combinable<uint64_t> traced([] { return uint64_t(0); });
  arena.execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<int>(0, height, 1), [&](const tbb::blocked_range<int>& rows) {
          uint64_t rays = 0;
          PixelSampler sampler(world_, lights_, rig_, wanted_, budget_, heuristic_, stride, rays);
          for (int y = rows.begin(); y != rows.end(); ++y)
            for (int x = 0; x < width; ++x) {
              if (!in_grid(x, y, stride)) continue;
              size_t i = size_t(y) * width + x;
              Pcg32 camera_rng(iteration_seed, i), light_rng(light_seed, i);
              glm::vec2 j = camera_rng.next_2d();
              sampler.sample(x + j.x, y + j.y, camera_rng, light_rng, &frame[i * kClasses],
                             row_splats[y]);
            }
          traced.local() += rays;
          ray_count.local() += rays;
        });
  });
  // Light tracing lands anywhere: added afterwards in light path order, so the sums do not depend
  // on the thread count.
  std::vector<glm::vec3>& to = splat_frame ? *splat_frame : frame;
  if (splat_frame)
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        if (in_grid(x, y, stride))
          for (int c = 0; c < kClasses; ++c)
            to[(size_t(y) * width + x) * kClasses + c] = glm::vec3(0.f);
  for (const auto& splats : row_splats)
    for (const Splat& s : splats) to[size_t(s.pixel) * kClasses + s.path_class] += s.value;
  return traced.combine(std::plus<uint64_t>());
}

}  // namespace pb::trace::detail
