// illumination-maps' CPU side (seed 001, Ch. 8, 10 and 11), a static library linked into the
// plugin and the test program: the parameters, the charts with their photon maps, the approximated
// illumination maps (AIMs) and the final gather by rays; the hemi-plane's coverage.
#pragma once

#include <glm/glm.hpp>
#include <span>
#include <string>
#include <vector>

#include "photonbench/param_table.h"
#include "photonbench/photons.h"
#include "photonbench/scene_triangles.h"
#include "photonbench/toolkit/charts.h"
#include "photonbench/toolkit/kd_tree.h"
#include "photonbench/toolkit/ray_caster.h"
#include "photonbench/toolkit/selective_emission.h"
#include "photonbench/toolkit/technique.h"

namespace im {

using glm::clamp;
using glm::floor;
using glm::min;
#include "im_layout.h"
// After the layout: the rules read ImChart and the IM_SUM_* constants.
#include "im_maps.h"

enum class Gather : uint32_t { raster, rays };
enum class SumPrecision : uint32_t { bits8, floating };
enum class AimEstimate : uint32_t { nearest, texel };
enum class Emission : uint32_t { selective, fresh };

namespace tk = pb::toolkit;

// The selective emission rows' fields (halton_base_1, halton_base_2, group_size,
// divergence_tolerance) are the toolkit's.
struct ImParams : tk::SelectiveEmissionParams {
  Emission emission = Emission::selective;
  uint32_t paths = 100000;
  uint32_t max_bounces = 4;
  float crease_angle = pb::toolkit::kDefaultCreaseAngleDegrees;
  uint32_t aim_texels = 5;
  uint32_t aim_photons = 100;
  AimEstimate aim_estimate = AimEstimate::nearest;
  float aim_threshold = 0.05f;
  uint32_t charts_per_frame = 4;
  Gather gather = Gather::raster;
  uint32_t hemi_size = 16;
  SumPrecision sum_precision = SumPrecision::bits8;
  uint32_t gather_rays = 1024;
  uint32_t gather_texels = 20;
  float blend = 0.5f;
  uint32_t shadow_map_size = pb::kDefaultShadowMapSize;
};

// clang-format off
inline constexpr auto kParams = pb::params(
    pb::param("emission", &ImParams::emission, Emission::selective, "selective|fresh",
              "selective: Ch. 9's fixed Halton emission points in groups, one probe path per "
              "group a frame, a diverged group re-traced, and only the charts whose photons "
              "changed get a new photon map and are considered for an AIM; fresh: photons paths "
              "traced anew every frame"),
    pb::bind(tk::kHaltonBase1Param,
             pb::base_field<ImParams>(&tk::SelectiveEmissionParams::halton_base_1)),
    pb::bind(tk::kHaltonBase2Param,
             pb::base_field<ImParams>(&tk::SelectiveEmissionParams::halton_base_2)),
    pb::bind(tk::kGroupSizeParam,
             pb::base_field<ImParams>(&tk::SelectiveEmissionParams::group_size)),
    pb::bind(tk::kDivergenceToleranceParam,
             pb::base_field<ImParams>(&tk::SelectiveEmissionParams::divergence_tolerance)),
    pb::bind(tk::with_range(tk::kPhotonsParam, tk::kPhotonsParam.default_value,
                            tk::kPhotonsParam.min_value, tk::kPhotonsParam.max_value,
                            "fresh: light paths traced per frame (selective keeps group_size x "
                            "halton_base_1 x halton_base_2 paths a light)"),
             &ImParams::paths),
    pb::bind(tk::with_range(tk::kMaxBouncesParam, 4, 1, 31,
                            "surface interactions per light path; photons are stored at every "
                            "diffuse hit, the first included (the AIMs hold direct and indirect "
                            "light, Ch. 10)"),
             &ImParams::max_bounces),
    pb::param("crease_angle", &ImParams::crease_angle, 30, {0, 180}, "degrees",
              "two faces whose normals differ by less join one chart (Ch. 8; the thesis gives no "
              "angle)"),
    pb::param("aim_texels", &ImParams::aim_texels, 5, {1, 256}, "texels",
              "AIM and IIM texels along the largest chart's longer side; every chart gets texels "
              "of that size, at least 1 per side (Ch. 14: 5 by 5 on large walls)"),
    pb::param("aim_photons", &ImParams::aim_photons, 100, {1, 10000}, "photons",
              "the N nearest photons of a texel's radiance estimate (Ch. 10, Table 14.1: 100)"),
    pb::param("aim_estimate", &ImParams::aim_estimate, AimEstimate::nearest, "nearest|texel",
              "a texel's AIM radiance: nearest, the aim_photons nearest photons at its centre "
              "(Ch. 10, a point sample), or texel, the photons inside the texel over its area "
              "(a box filter: a hotspot smaller than a texel keeps its energy)"),
    pb::param("aim_threshold", &ImParams::aim_threshold, 0.05, {0, 1e6}, "",
              "a chart's AIM is recomputed when its photon flux per area changed (|delta f| / A) "
              "by more than this fraction of the scene's mean flux per area (Ch. 10: \"a small "
              "threshold\")"),
    pb::param("charts_per_frame", &ImParams::charts_per_frame, 4, {1, 1e6}, "charts",
              "AIMs recomputed per frame at most, the largest change first (Ch. 10: \"a limited "
              "amount\"); the first frame computes every chart's"),
    pb::param("gather", &ImParams::gather, Gather::raster, "raster|rays",
              "the final gather at IIM texels: raster draws the scene onto a hemi-plane and sums "
              "it by MIP reduction (Ch. 11), rays casts cosine-distributed rays on the CPU (the "
              "comparison of Ch. 14)"),
    pb::param("hemi_size", &ImParams::hemi_size, 16, {2, 256}, "px",
              "raster: hemi-plane pixels per side, a power of two (the MIP reduction halves it to "
              "1; Table 14.2 timed 8, 16 and 32)"),
    pb::param("sum_precision", &ImParams::sum_precision, SumPrecision::bits8, "8bit|float",
              "raster: each MIP level stored in 8 bits (the thesis's RGBA8 MIP maps) or as float"),
    pb::param("gather_rays", &ImParams::gather_rays, 1024, {1, 1e6}, "rays",
              "rays: rays per texel (Ch. 14 timed 1024)"),
    pb::param("gather_texels", &ImParams::gather_texels, 20, {1, 1e6}, "texels",
              "IIM texels gathered per frame at most, the largest change of their AIM input first "
              "(Ch. 11, Ch. 14: 20); the first frame gathers every texel"),
    pb::param("blend", &ImParams::blend, 0.5, {0, 1}, "",
              "the displayed IIM moves this fraction of the way to the newest gathered one each "
              "frame (Ch. 11's double buffer; the thesis: \"fairly fast\")"),
    pb::bind(tk::kShadowMapSizeParam, &ImParams::shadow_map_size));
// clang-format on

// "" or "<parameter>: why" (hemi_size a power of two; the selective emission's settings as
// check_selective_emission has them, at this technique's keys).
std::string check(const pb::Params& params);

// The selective emission policy's settings of `p` (Ch. 9), tracing as the fresh emission does.
tk::SelectiveEmissionSettings selective_settings(const ImParams& p);

// The fraction of the cosine-weighted hemisphere a square plane of half-width `half_width` at
// height 1 covers: (1/pi) times the integral of dA / (x^2 + y^2 + 1)^2 over it,
// (4 / pi) s atan(s) with s = a / sqrt(1 + a^2). Half-width 1 (the hemi-cube's top face): 55.4%;
// half-width 2 (Ch. 11's doubled plane): 83.1% (the thesis says 86%).
double hemi_plane_coverage(double half_width);

// The sum of Eq. 11.2's weights over the size x size pixels of the plane: its coverage as the
// pixel grid measures it, which tends to hemi_plane_coverage as size grows.
double hemi_plane_weight_sum(uint32_t size, float half_width);

// The irradiance a hemi-plane's 1 x 1 MIP level `top` stands for (Eq. 11.3 and step 4): the
// level is the weighted mean, so the sum of radiance times Eq. 11.2's weights (over pi) in the
// units of level 0 (8bit: divided by its scale); over the plane's coverage `weight_sum` (the
// missing part of the hemisphere taken as bright as the rest) and times pi.
glm::vec3 hemi_plane_irradiance(glm::vec3 top, float scale_8bit, uint32_t sum_precision,
                                float weight_sum);

// The 8bit scale: the largest level-0 value (the brightest AIM texel at the plane's centre pixel)
// at 1, the RGBA8 levels' range (the thesis leaves the exposure to the scene).
float hemi_plane_scale_8bit(float largest_radiance, uint32_t size, float half_width);

// A texel's place on its chart: the centre, where the AIM is estimated and the gather starts.
struct TexelSite {
  glm::vec3 position{0.0f};
  // The lit side: the geometric normal, turned towards the photons near the centre when they
  // arrive on the other side (a chart's AIM belongs to the side its photons arrived on).
  glm::vec3 normal{0.0f, 0.0f, 1.0f};
  glm::vec3 albedo{0.0f};  // of the surface at the centre: AIM radiance = albedo / pi * E
  uint32_t chart = 0;
};

// Per chart: its texel grid and its own photon map (Ch. 8: one map per chart).
struct ChartMap {
  ImChart grid{};
  double area = 0;
  std::vector<glm::vec3> positions;  // this frame's photons on the chart
  std::vector<glm::vec3> powers;
  std::vector<glm::vec3> normals;  // on the side each photon arrived from
  tk::KdTree tree;
  glm::dvec3 flux{0.0};         // this frame's photon flux on the chart (W)
  glm::dvec3 flux_at_aim{0.0};  // at its last AIM update
  bool aim_valid = false;
};

// What one frame's steps did, for the counters.
struct StepStats {
  uint32_t charts_updated = 0;
  uint32_t texels_gathered = 0;
};

class IlluminationMaps {
 public:
  // Charts of `triangles` (Ch. 8) and their texel grids and sites; `albedo` per material index.
  // With `keep_unmoved`, when the partition is the previous one, a chart whose grid and texel
  // sites are unchanged keeps its photons, map, AIM and its texels' gather state (selective
  // emission: its photons change only through the ledger); the others start afresh.
  void build(const pb::SceneTriangles& triangles, std::span<const glm::vec3> albedo,
             float crease_angle_degrees, uint32_t aim_texels, bool keep_unmoved = false);
  // The charts the last build started afresh (ascending; all unless keep_unmoved kept some).
  std::span<const uint32_t> fresh_charts() const { return fresh_charts_; }
  // Per texel: its index before the last build, or kNoTexel for a texel of a fresh chart.
  static constexpr uint32_t kNoTexel = ~0u;
  std::span<const uint32_t> texel_before() const { return texel_before_; }
  // Charts with no AIM yet and texels never gathered: the first call's must-do work.
  uint32_t charts_without_aim() const;
  uint32_t texels_never_gathered() const;

  // The frame's photons split per chart by their hit triangle, each chart's kd-tree balanced.
  void store_photons(std::span<const pb::trace::PhotonRecord> photons);
  // Selective emission: only the charts `charts` (ascending) take their photons among `photons`
  // (the kept paths') and get a new kd-tree, their flux the ledger's exact sum (the ledger keyed
  // by chart id); every other chart keeps its photons, tree and flux, so its AIM is not
  // reconsidered (its flux equals the one its AIM was computed from).
  void store_chart_photons(std::span<const pb::trace::PhotonRecord> photons,
                           std::span<const uint32_t> charts, const tk::SurfaceEnergyLedger& ledger);

  // Recomputes the AIMs of at most `max_charts` charts whose flux per area changed by more than
  // `threshold` times the scene's mean (all charts not yet computed first, then the largest
  // change), each texel the `k` nearest photons' radiance (all of the chart's flux over its area
  // when it holds fewer than k); adds the AIM change to every texel's
  // gather priority. Returns the charts updated.
  uint32_t update_aims(uint32_t max_charts, float threshold, uint32_t k,
                       AimEstimate estimate = AimEstimate::nearest);
  // A texel's AIM radiance from its chart's map by the k nearest photons (W / (m^2 sr)).
  glm::vec3 estimate_aim(uint32_t texel, uint32_t k) const;
  // Every texel's of chart `chart` by the photons inside each texel over the texel's area (the
  // chart's area over its texel count).
  std::vector<glm::vec3> texel_mean_aim(uint32_t chart) const;

  // The texels to gather this frame: those never gathered, then by the change of their AIM input
  // since their last gather (Ch. 11's delta i), at most `max_texels`; marks them gathered.
  std::vector<uint32_t> take_gather_texels(uint32_t max_texels);

  // The AIM's radiance at `p` on chart `chart` seen from the side of `towards_viewer` (bilinear,
  // a texel counting only where its lit side, TexelSite::normal, faces the viewer).
  glm::vec3 aim_radiance(uint32_t chart, glm::vec3 p, glm::vec3 towards_viewer) const;

  // Irradiance at texel `texel` by `rays` cosine-distributed rays (stratified, rotated per texel):
  // pi times the mean AIM radiance the rays hit (0 where they hit nothing).
  glm::vec3 gather_rays(uint32_t texel, const tk::TriangleRayCaster& caster, uint32_t rays) const;

  std::span<const ChartMap> charts() const { return charts_; }
  std::span<const uint32_t> chart_of() const { return chart_of_; }
  std::span<const TexelSite> sites() const { return sites_; }
  std::span<const glm::vec4> aim() const { return aim_; }
  std::vector<glm::vec4>& aim_mutable() { return aim_; }
  uint32_t texel_count() const { return uint32_t(sites_.size()); }
  float epsilon() const { return epsilon_; }  // ray offsets: 1e-4 of the scene's size (m)

 private:
  std::vector<ChartMap> charts_;
  std::vector<uint32_t> chart_of_;
  std::vector<TexelSite> sites_;
  std::vector<glm::vec4> aim_;        // per texel: rgb radiance
  std::vector<double> input_change_;  // per texel: delta i since its last gather
  std::vector<bool> gathered_;
  std::vector<uint32_t> fresh_charts_, texel_before_;
  double total_area_ = 0;
  float epsilon_ = 1e-4f;
};

// A unit direction about `normal` from the cosine-distributed point (u1, u2) in [0, 1)^2.
glm::vec3 cosine_direction(glm::vec3 normal, float u1, float u2);

// The hemi-plane camera of a texel (Ch. 11): at `position` + epsilon along `normal`, looking along
// it, with a square frustum through the plane of half-width `half_width` at distance 1, depth in
// [near, far] (Vulkan clip space, depth 0 to 1).
glm::mat4 hemi_plane_view_projection(glm::vec3 position, glm::vec3 normal, float half_width,
                                     float near, float far);

}  // namespace im
