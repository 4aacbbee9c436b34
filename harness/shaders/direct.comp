#version 460
// Direct lighting (path class C D L) at each G-buffer sample, with shadow-map visibility. Point,
// spot, quad and disc lights use a 6-face cube of atlas tiles around the light (an area light's
// from its centre, so its shadows are hard: a documented approximation); directional lights one
// orthographic tile. Emissive triangles (the scene's emissive surfaces, Phi = pi A L each) are
// polygon lights like the quads, shadowed from their object's own cube (at its area-weighted
// centroid; the emitter is not drawn into it). Diffuse and emissive surfaces are Lambertian; rough
// conductors use GGX (Walter et al. 2007) with Schlick's Fresnel; smooth specular surfaces receive
// no direct light from delta or small lights here.
#include "photonbench/scene_layout.h"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer FrameBlock { GpuFrame frame; };
layout(std430, binding = 1) readonly buffer MaterialBlock { GpuMaterial materials[]; };
layout(std430, binding = 2) readonly buffer LightBlock { GpuLight lights[]; };
layout(std430, binding = 3) readonly buffer TileBlock { mat4 tiles[]; };
layout(binding = 4, rgba32f) readonly uniform image2D gbuffer_position;
layout(binding = 5, rgba32f) readonly uniform image2D gbuffer_normal;
layout(binding = 6) uniform sampler2D shadow_atlas;
layout(binding = 7, rgba32f) writeonly uniform image2D direct_out;
struct EmissiveTriangle {
  vec4 a_first_tile;   // xyz: vertex 0; w: the first of its object's 6 shadow tiles
  vec4 b;              // vertex 1 (the three wound to face the emitting side)
  vec4 c;              // vertex 2
  vec4 radiance;       // rgb: W/(m^2 sr)
  vec4 shadow_origin;  // xyz: the centre of its object's shadow cube
};
layout(std430, binding = 8) readonly buffer EmissiveBlock { EmissiveTriangle emissive[]; };
// relative_bias: a receiver is lit when its light-space depth * (1 - relative_bias) <= the stored
// depth. Cube tiles are perspective (near/far given), directional tiles orthographic (depth already
// linear).
layout(push_constant) uniform Push {
  float relative_bias;
  float normal_offset;
  float near;
  float far;
  uint emissive_count;
}
push;

const float PI = 3.14159265358979;

uint cube_face(vec3 d) {
  vec3 a = abs(d);
  if (a.x >= a.y && a.x >= a.z) return d.x > 0.0 ? 0u : 1u;
  if (a.y >= a.z) return d.y > 0.0 ? 2u : 3u;
  return d.z > 0.0 ? 4u : 5u;
}

// Distance along the light's view axis from a stored [0,1] depth (perspectiveRH_ZO inverted).
float linear_depth(float z, bool orthographic) {
  if (orthographic) return z;
  return push.far * push.near / (push.far - z * (push.far - push.near));
}

// 3x3 percentage-closer filtering inside one tile.
float visibility(uint tile, vec3 p) {
  vec4 clip = tiles[tile] * vec4(p, 1.0);
  vec3 ndc = clip.xyz / clip.w;
  if (any(greaterThan(abs(ndc.xy), vec2(1.0))) || ndc.z > 1.0) return 1.0;
  uint size = frame.size_lights.w;
  uint per_row = frame.shadow_atlas.z;
  ivec2 origin = ivec2((tile % per_row) * size, (tile / per_row) * size);
  vec2 texel = (ndc.xy * 0.5 + 0.5) * float(size);
  bool orthographic = tiles[tile][3][3] == 1.0;
  float receiver = linear_depth(ndc.z, orthographic) * (1.0 - push.relative_bias);
  float lit = 0.0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      ivec2 t = clamp(ivec2(texel) + ivec2(dx, dy), ivec2(0), ivec2(size - 1));
      float stored = texelFetch(shadow_atlas, origin + t, 0).r;
      lit += receiver <= linear_depth(stored, orthographic) ? 1.0 : 0.0;
    }
  return lit / 9.0;
}

// Lambert's contour integral over a polygon's edge a -> b seen from p (normal n): the angle p sees
// the edge under times n . (unit normal of the plane through p and the edge).
float edge_term(vec3 p, vec3 n, vec3 a, vec3 b) {
  vec3 da = normalize(a - p), db = normalize(b - p);
  float angle = acos(clamp(dot(da, db), -1.0, 1.0));
  vec3 c = cross(da, db);
  float lc = length(c);
  return lc > 1e-8 ? angle * dot(c / lc, n) : 0.0;
}

// Irradiance at p (normal n) from a Lambertian quad of radiance L, by Lambert's polygon formula;
// zero behind the quad. No horizon clipping: a quad crossing the tangent plane is slightly
// overestimated.
float quad_form_factor(vec3 p, vec3 n, vec3 corner, vec3 eu, vec3 ev) {
  vec3 qn = normalize(cross(eu, ev));
  if (dot(p - corner, qn) <= 0.0) return 0.0;
  vec3 v[4] = vec3[4](corner, corner + eu, corner + eu + ev, corner + ev);
  float sum = 0.0;
  for (int i = 0; i < 4; ++i) sum += edge_term(p, n, v[i], v[(i + 1) % 4]);
  return max(0.5 * abs(sum), 0.0);
}

// The same for a disc of radii eu, ev, as the regular 32-gon of the disc's area (its circumradius
// sqrt(2 pi / (32 sin(2 pi / 32))) = 1.00322 radii): against a 4096-gon, within 1e-5 of the disc
// at receivers 0.3 radii or more from its rim, 0.4% at 0.1 radii, tens of percent within 0.01
// radii of the rim itself; no horizon clipping either.
const int DISC_SIDES = 32;
float disc_form_factor(vec3 p, vec3 n, vec3 centre, vec3 eu, vec3 ev) {
  if (dot(p - centre, cross(eu, ev)) <= 0.0) return 0.0;
  float scale = 1.00322;
  float sum = 0.0;
  vec3 a = centre + scale * eu;
  for (int i = 1; i <= DISC_SIDES; ++i) {
    float phi = 2.0 * PI * float(i) / float(DISC_SIDES);
    vec3 b = centre + scale * (cos(phi) * eu + sin(phi) * ev);
    sum += edge_term(p, n, a, b);
    a = b;
  }
  return max(0.5 * abs(sum), 0.0);
}

// The same for a Lambertian triangle a, b, c (facing cross(b - a, c - a)).
float triangle_form_factor(vec3 p, vec3 n, vec3 a, vec3 b, vec3 c) {
  if (dot(p - a, cross(b - a, c - a)) <= 0.0) return 0.0;
  float sum = edge_term(p, n, a, b) + edge_term(p, n, b, c) + edge_term(p, n, c, a);
  return max(0.5 * abs(sum), 0.0);
}

vec3 brdf(GpuMaterial m, vec3 n, vec3 wo, vec3 wi) {
  int type = int(m.albedo_type.w);
  if (type == PB_MATERIAL_DIFFUSE || type == PB_MATERIAL_EMISSIVE) return m.albedo_type.rgb / PI;
  if (type == PB_MATERIAL_ROUGH_CONDUCTOR) {
    float alpha = max(m.emission_roughness.w, 1e-3);
    vec3 h = normalize(wo + wi);
    float nh = max(dot(n, h), 0.0), no = max(dot(n, wo), 1e-4), ni = max(dot(n, wi), 1e-4);
    float a2 = alpha * alpha;
    float d = a2 / (PI * pow(nh * nh * (a2 - 1.0) + 1.0, 2.0));
    float lo = (-1.0 + sqrt(1.0 + a2 * (1.0 - no * no) / (no * no))) * 0.5;
    float li = (-1.0 + sqrt(1.0 + a2 * (1.0 - ni * ni) / (ni * ni))) * 0.5;
    float g = 1.0 / (1.0 + lo + li);
    vec3 f0 = m.specular_ior.rgb;
    vec3 f = f0 + (1.0 - f0) * pow(1.0 - max(dot(wi, h), 0.0), 5.0);
    return f * d * g / (4.0 * no * ni);
  }
  return vec3(0.0);
}

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pixel.x >= int(frame.size_lights.x) || pixel.y >= int(frame.size_lights.y)) return;
  vec4 pos = imageLoad(gbuffer_position, pixel);
  if (pos.w <= 0.0) {
    imageStore(direct_out, pixel, vec4(0.0));
    return;
  }
  vec4 nm = imageLoad(gbuffer_normal, pixel);
  vec3 p = pos.xyz, n = normalize(nm.xyz);
  GpuMaterial m = materials[uint(nm.w)];
  vec3 wo = normalize(frame.camera_position.xyz - p);
  vec3 shadow_p = p + n * push.normal_offset;
  vec3 result = vec3(0.0);
  for (uint i = 0; i < frame.size_lights.z; ++i) {
    GpuLight light = lights[i];
    int type = int(light.position_type.w);
    uint first_tile = uint(light.edge_v_first_tile.w);
    vec3 wi;
    vec3 irradiance_rgb;
    uint tile;
    if (type == PB_LIGHT_DIRECTIONAL) {
      wi = -light.direction_cos_outer.xyz;
      irradiance_rgb = light.radiant.rgb * max(dot(n, wi), 0.0);
      tile = first_tile;
    } else if (type == PB_LIGHT_QUAD) {
      vec3 eu = light.edge_u_cos_inner.xyz, ev = light.edge_v_first_tile.xyz;
      vec3 centre = light.position_type.xyz + 0.5 * (eu + ev);
      wi = normalize(centre - p);
      irradiance_rgb = light.radiant.rgb * quad_form_factor(p, n, light.position_type.xyz, eu, ev);
      tile = first_tile + cube_face(shadow_p - centre);
    } else if (type == PB_LIGHT_DISC) {
      vec3 centre = light.position_type.xyz;
      vec3 eu = light.edge_u_cos_inner.xyz, ev = light.edge_v_first_tile.xyz;
      wi = normalize(centre - p);
      irradiance_rgb = light.radiant.rgb * disc_form_factor(p, n, centre, eu, ev);
      tile = first_tile + cube_face(shadow_p - centre);
    } else {
      vec3 to_light = light.position_type.xyz - p;
      float r2 = max(dot(to_light, to_light), 1e-8);
      wi = to_light * inversesqrt(r2);
      float falloff = 1.0;
      if (type == PB_LIGHT_SPOT)
        falloff = smoothstep(light.direction_cos_outer.w, light.edge_u_cos_inner.w,
                             dot(-wi, light.direction_cos_outer.xyz));
      // I cos(theta) / r^2
      irradiance_rgb = light.radiant.rgb * falloff * max(dot(n, wi), 0.0) / r2;
      tile = first_tile + cube_face(shadow_p - light.position_type.xyz);
    }
    if (all(equal(irradiance_rgb, vec3(0.0)))) continue;
    result += brdf(m, n, wo, wi) * irradiance_rgb * visibility(tile, shadow_p);
  }
  for (uint i = 0; i < push.emissive_count; ++i) {
    EmissiveTriangle e = emissive[i];
    vec3 a = e.a_first_tile.xyz, b = e.b.xyz, c = e.c.xyz;
    float form_factor = triangle_form_factor(p, n, a, b, c);
    if (form_factor <= 0.0) continue;
    vec3 wi = normalize((a + b + c) / 3.0 - p);
    uint tile = uint(e.a_first_tile.w) + cube_face(shadow_p - e.shadow_origin.xyz);
    result += brdf(m, n, wo, wi) * e.radiance.rgb * form_factor * visibility(tile, shadow_p);
  }
  imageStore(direct_out, pixel, vec4(result, 1.0));
}
