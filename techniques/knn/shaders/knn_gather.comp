#version 460
// gather: classic photon mapping's density estimate per view sample (seed 003 §3.1; Jensen 1996).
// The k nearest photons within r_max that arrive from above the sample's tangent plane are found
// by searching the uniform grid in growing shells of cells around the sample's cell, keeping the
// candidates in a fixed-size max-heap of k entries (the heap's top is the current k-th distance,
// which bounds the search once k are held: seed 003's "temporary set of k candidate hits ...
// updated as closer ones are found"). The bandwidth r is the radius of the found photons'
// bounding sphere around x, i.e. the k-th distance (fewer than k within r_max: r_max, or the
// farthest found, by `sparse`); L = (albedo / pi) * sum(Phi_i K_i) with K = 1 / (pi r^2)
// (uniform) or 2 / (pi r^2) (1 - d_i^2 / r^2) (Epanechnikov).
//
// Every loop step counts against push.budget (llvmpipe ends an invocation's loops after 65535
// iterations in all, silently): a query that reaches it stops where it is, is counted
// (KNN_STAT_TRUNCATED) and estimates from what it holds.
#define KNN_GATHER
#include "knn_common.glsl"
#include "toolkit/atomics.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

float heap_d[KNN_MAX_K];  // squared distances; a max-heap on them
uint heap_i[KNN_MAX_K];   // the photons' places in `compact`
uint heap_n = 0u;
uint steps = 0u;

void heap_push(float d, uint at) {
  uint j = heap_n++;
  while (j > 0u) {
    ++steps;
    uint parent = (j - 1u) / 2u;
    if (heap_d[parent] >= d) break;
    heap_d[j] = heap_d[parent];
    heap_i[j] = heap_i[parent];
    j = parent;
  }
  heap_d[j] = d;
  heap_i[j] = at;
}

// Replaces the farthest entry (the top) and sifts the new one down.
void heap_replace_top(float d, uint at) {
  uint j = 0u;
  while (true) {
    ++steps;
    uint l = 2u * j + 1u;
    if (l >= heap_n) break;
    uint r = l + 1u;
    uint m = (r < heap_n && heap_d[r] > heap_d[l]) ? r : l;
    if (heap_d[m] <= d) break;
    heap_d[j] = heap_d[m];
    heap_i[j] = heap_i[m];
    j = m;
  }
  heap_d[j] = d;
  heap_i[j] = at;
}

shared uint group_visited, group_cells, group_found, group_queries, group_short, group_truncated;

void main() {
  if (gl_LocalInvocationIndex == 0u) {
    group_visited = 0u;
    group_cells = 0u;
    group_found = 0u;
    group_queries = 0u;
    group_short = 0u;
    group_truncated = 0u;
  }
  barrier();

  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (pb_in_frame(pixel, uvec2(push.width, push.height))) {
    vec3 x, n, albedo, radiance = vec3(0.0);
    float radius = 0.0;
    if (pb_lit_sample(pixel, x, n, albedo)) {
      uint visited = 0u, opened = 0u;
      bool stop = false;
      float r_max2 = push.r_max * push.r_max;
      float bound2 = r_max2;  // r_max^2 until k are held, then the k-th squared distance
      // Nothing within r_max when x is farther than r_max from the grid's box.
      vec3 outside = max(max(push.origin - x, x - push.grid_max), vec3(0.0));
      if (dot(outside, outside) <= r_max2) {
        ivec3 dims = ivec3(knn_dims());
        vec3 rel = (x - push.origin) / push.cell;
        ivec3 c0 = ivec3(floor(rel));
        vec3 f = rel - vec3(c0);
        // Distance from x to the nearest wall of its own cell: shell s >= 1 lies at least
        // (s - 1) cells plus this far away.
        float d0 = min(min(min(f.x, f.y), f.z), min(min(1.0 - f.x, 1.0 - f.y), 1.0 - f.z));
        d0 = clamp(d0, 0.0, 1.0) * push.cell;
        int shells = int(ceil(push.r_max / push.cell)) + 1;
        for (int s = 0; s <= shells && !stop; ++s) {
          ++steps;
          if (s > 0) {
            float lower = float(s - 1) * push.cell + d0;
            if (lower * lower > bound2) break;
          }
          for (int dz = -s; dz <= s && !stop; ++dz) {
            ++steps;
            int cz = c0.z + dz;
            if (cz < 0 || cz >= dims.z) continue;
            for (int dy = -s; dy <= s && !stop; ++dy) {
              ++steps;
              int cy = c0.y + dy;
              if (cy < 0 || cy >= dims.y) continue;
              // The shell's cells only: whole rows on its faces, the two ends elsewhere.
              bool face = s == 0 || abs(dz) == s || abs(dy) == s;
              int stride = face ? 1 : 2 * s;
              for (int dx = -s; dx <= s; dx += stride) {
                if (++steps >= push.budget) {
                  stop = true;
                  break;
                }
                int cx = c0.x + dx;
                if (cx < 0 || cx >= dims.x) continue;
                vec3 lo = push.origin + vec3(cx, cy, cz) * push.cell;
                vec3 gap = max(max(lo - x, x - (lo + push.cell)), vec3(0.0));
                if (dot(gap, gap) > bound2) continue;
                ++opened;
                uvec2 range = cells[knn_cell_index(uvec3(cx, cy, cz))];
                for (uint i = range.x; i < range.y; ++i) {
                  if (++steps >= push.budget) {
                    stop = true;
                    break;
                  }
                  ++visited;
                  KnnPhoton p = compact[i];
                  vec3 d = p.position - x;
                  float d2 = dot(d, d);
                  // Tangent-plane test: only photons arriving from the side the normal faces.
                  if (d2 > bound2 || dot(n, p.direction) >= 0.0) continue;
                  if (heap_n < push.k) {
                    heap_push(d2, i);
                    if (heap_n == push.k) bound2 = heap_d[0];
                  } else if (d2 < heap_d[0]) {
                    heap_replace_top(d2, i);
                    bound2 = heap_d[0];
                  }
                }
              }
            }
          }
        }
      }

      // ---- the estimate over what was found ----
      float r2 = 0.0;
      if (heap_n > 0u) {
        r2 = (heap_n == push.k || push.sparse == KNN_SPARSE_FARTHEST) ? heap_d[0] : r_max2;
        r2 = max(r2, 1e-12);
        vec3 flux = vec3(0.0);
        for (uint j = 0u; j < heap_n; ++j) {
          float w = push.kernel == KNN_KERNEL_EPANECHNIKOV ? 2.0 * (1.0 - heap_d[j] / r2) : 1.0;
          flux += compact[heap_i[j]].power * w;
        }
        radiance = albedo * PB_INV_PI * flux / (PB_PI * r2);
        radius = sqrt(r2);
        uint bin = uint(min(radius / push.bin_width, float(KNN_RADIUS_BINS - 1u)));
        atomicAdd(stats[KNN_STAT_HISTOGRAM + bin], 1u);
      }
      atomicAdd(group_visited, visited);
      atomicAdd(group_cells, opened);
      atomicAdd(group_found, heap_n);
      atomicAdd(group_queries, 1u);
      if (heap_n < push.k) atomicAdd(group_short, 1u);
      if (stop) atomicAdd(group_truncated, 1u);

      if (push.debug != 0u) {
        uint base = (uint(pixel.y) * push.width + uint(pixel.x)) * push.debug_stride;
        debug_words[base] = heap_n;
        debug_words[base + 1u] = floatBitsToUint(radius);
        for (uint j = 0u; j < heap_n; ++j) debug_words[base + 2u + j] = compact[heap_i[j]].index;
      }
    }
    imageStore(indirect_out, pixel, vec4(radiance, 1.0));
  }

  barrier();
  if (gl_LocalInvocationIndex == 0u) {
    PB_ADD64(stats, KNN_STAT_VISITED, group_visited);
    PB_ADD64(stats, KNN_STAT_CELLS, group_cells);
    PB_ADD64(stats, KNN_STAT_FOUND, group_found);
    atomicAdd(stats[KNN_STAT_QUERIES], group_queries);
    atomicAdd(stats[KNN_STAT_SHORT], group_short);
    atomicAdd(stats[KNN_STAT_TRUNCATED], group_truncated);
  }
}
