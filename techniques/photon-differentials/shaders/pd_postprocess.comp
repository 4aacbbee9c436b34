#version 460
// Pass "postprocess" (seed 003 §4.3, §7, Fig. 1; footprint.h's make_footprint): per photon the
// compressed, smoothed and clamped semi-axes, the skewed ellipsoid's inverse and box, Table 3's
// histogram of the semi-axes before the clamp and this group's sum of footprint areas (for
// T_auto). The boxes are what the toolkit's BVH is built over (a degenerate footprint's is the
// point where it landed).
#include "pd_common.glsl"
layout(local_size_x = 256) in;
shared float group_area[256];
shared uint group_histogram[PD_RADIUS_BINS];
shared uint group_clamped, group_degenerate;

bool specular_only(PhotonRecord p) {
  uint before = p.bounce >= 32u ? 0xffffffffu : ((1u << p.bounce) - 1u);
  return (p.specular_mask & before) == before;
}
uint photon_kind(PhotonRecord p) {  // pb::trace::photon_kind
  if (p.bounce == 0u) return 1u;
  uint before = p.bounce >= 32u ? 0xffffffffu : ((1u << p.bounce) - 1u);
  bool all_specular = (p.specular_mask & before) == before;
  if ((p.specular_mask & 1u) != 0u) return all_specular ? 2u : 8u;
  return 4u;
}
vec3 compressed(vec3 a, float delta) {
  float len = length(a);
  float base =
      (push.flags & PD_FLAG_COMPRESS_SEMIAXIS) != 0u ? len : (delta > 0.0 ? len / delta : 0.0);
  return base > 0.0 ? a * pow(base, push.exponent) : a;
}
vec3 clamped(vec3 a) {
  float len = length(a);
  if (len <= push.r_max) return a;
  atomicAdd(group_clamped, 1u);
  return a * (push.r_max / len);
}

void main() {
  uint id = gl_LocalInvocationID.x, i = gl_GlobalInvocationID.x;
  if (id < PD_RADIUS_BINS) group_histogram[id] = 0u;
  if (id == 0u) group_clamped = 0u, group_degenerate = 0u;
  barrier();
  float area = 0.0;
  if (i < push.count) {
    PhotonRecord p = photons[i];
    vec3 a1 = p.footprint_u, a2 = p.footprint_v;
    bool specular = specular_only(p);
    if (!specular && push.exponent != 0.0) {
      float delta = uintBitsToFloat(p.flags);
      a1 = compressed(a1, delta);
      a2 = compressed(a2, delta);
    }
    float s = specular ? push.smoothing_specular : push.smoothing;
    a1 *= s;
    a2 *= s;
    atomicAdd(group_histogram[min(PD_RADIUS_BINS - 1u, uint(length(a1) / PD_RADIUS_BIN_WIDTH))],
              1u);
    atomicAdd(group_histogram[min(PD_RADIUS_BINS - 1u, uint(length(a2) / PD_RADIUS_BIN_WIDTH))],
              1u);
    a1 = clamped(a1);
    a2 = clamped(a2);
    PdFootprint f;
    f.position = p.position;
    f.kind = photon_kind(p);
    f.photon = i;
    f.incoming = -p.direction;
    f.pad = 0.0;
    float l1 = length(a1), l2 = length(a2);
    f.radius_major = max(l1, l2);
    f.radius_minor = min(l1, l2);
    vec3 c3 = push.normal_extent * sqrt(l1 * l2) * p.normal;
    float cross_len = length(cross(a1, a2));
    float det = dot(a1, cross(a2, c3));
    BvhBox box;
    box.lo = p.position;
    box.hi = p.position;
    box.pad0 = 0u;
    box.pad1 = 0u;
    f.area = 0.0;
    f.flux_density = vec3(0.0);
    f.inverse0 = f.inverse1 = f.inverse2 = vec3(0.0);
    if (cross_len > 1e-6 * l1 * l2 && abs(det) > 0.0 && cross_len > 0.0) {
      f.area = float(PD_PI) * cross_len;
      f.flux_density = p.power / f.area;
      f.inverse0 = cross(a2, c3) / det;
      f.inverse1 = cross(c3, a1) / det;
      f.inverse2 = cross(a1, a2) / det;
      vec3 half_extent = sqrt(a1 * a1 + a2 * a2 + c3 * c3);
      box.lo = p.position - half_extent;
      box.hi = p.position + half_extent;
      area = f.area;
    } else {
      atomicAdd(group_degenerate, 1u);
    }
    footprints[i] = f;
    boxes[i] = box;
  }
  group_area[id] = area;
  barrier();
  for (uint step = 128u; step > 0u; step >>= 1u) {
    if (id < step) group_area[id] += group_area[id + step];
    barrier();
  }
  if (id == 0u) partials[gl_WorkGroupID.x] = group_area[0];
  if (id == 0u && group_clamped != 0u) atomicAdd(control[PD_CTL_CLAMPED], group_clamped);
  if (id == 0u && group_degenerate != 0u) atomicAdd(control[PD_CTL_DEGENERATE], group_degenerate);
  if (id < PD_RADIUS_BINS && group_histogram[id] != 0u)
    atomicAdd(control[PD_CTL_HISTOGRAM + id], group_histogram[id]);
}
