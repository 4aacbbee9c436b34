// The toolkit's crease-angle charts (photonbench/toolkit/charts.h, seed 001 Ch. 8): a box is 6
// charts, one per face, each projected along its face's axis to the face's own size; a UV sphere
// is one chart at 30 degrees and many below its facets' angle; vertices repeated per face (with a
// seam's last-bit differences) are welded; a fold joins at a crease angle above it and splits
// below; bad input is refused with the key.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <vector>

#include "photonbench/error.h"
#include "photonbench/toolkit/charts.h"
#include "scene/shapes.h"

namespace toolkit_charts_test {

using pb::toolkit::Charts;
using pb::toolkit::segment_charts;

Charts charts_of(const pb::scene::Mesh& mesh,
                 float crease = pb::toolkit::kDefaultCreaseAngleDegrees) {
  return segment_charts(mesh.positions, mesh.triangles, crease);
}

TEST(Charts, ABoxIsSixChartsOnePerFace) {
  const glm::vec3 size{1.0f, 2.0f, 3.0f};
  const pb::scene::Mesh box = pb::scene::BoxShape(size).tessellate(0.0f);
  const Charts charts = charts_of(box);
  ASSERT_EQ(charts.charts.size(), 6u);
  ASSERT_EQ(charts.chart_of.size(), box.triangles.size());
  std::multiset<uint32_t> axes;
  double total = 0;
  for (const auto& chart : charts.charts) {
    ASSERT_EQ(chart.triangles.size(), 2u);
    axes.insert(chart.axis);
    total += chart.area;
    // Projected along its own normal, a face keeps its size: the two other sides of the box.
    const uint32_t u = (chart.axis + 1) % 3, v = (chart.axis + 2) % 3;
    EXPECT_NEAR(chart.extent.x, size[u], 1e-6f);
    EXPECT_NEAR(chart.extent.y, size[v], 1e-6f);
    for (uint32_t t : chart.triangles) {
      EXPECT_EQ(&charts.charts[charts.chart_of[t]], &chart);
      for (int c = 0; c < 3; ++c) {
        const glm::vec2 uv = chart.uv(box.positions[box.triangles[t][c]]);
        EXPECT_GE(uv.x, 0.0f);
        EXPECT_GE(uv.y, 0.0f);
        EXPECT_LE(uv.x, chart.extent.x);
        EXPECT_LE(uv.y, chart.extent.y);
      }
    }
  }
  EXPECT_EQ(axes, (std::multiset<uint32_t>{0, 0, 1, 1, 2, 2}));
  EXPECT_NEAR(total, 2.0 * (1 * 2 + 2 * 3 + 1 * 3), 1e-5);
}

TEST(Charts, ASphereIsOneChartAtThirtyDegreesAndSplitsBelowItsFacetAngle) {
  // 32 segments: neighbouring facets differ by about 360 / 32 = 11.25 degrees.
  const pb::scene::Mesh sphere = pb::scene::SphereShape(1.0f, 32).tessellate(0.0f);
  const Charts one = charts_of(sphere);
  ASSERT_EQ(one.charts.size(), 1u);
  EXPECT_EQ(one.charts[0].triangles.size(), sphere.triangles.size());
  // The facets' area: a little under the sphere's 4 pi.
  EXPECT_LT(one.charts[0].area, 4.0 * 3.14159265);
  EXPECT_GT(one.charts[0].area, 0.98 * 4.0 * 3.14159265);
  EXPECT_GT(charts_of(sphere, 5.0f).charts.size(), 100u);
}

// Two triangles sharing an edge by position only (each with its own vertices, one copy moved by
// far less than the weld tolerance), folded by `fold` degrees about the shared edge.
pb::scene::Mesh folded_pair(float fold) {
  const float a = glm::radians(fold);
  pb::scene::Mesh mesh;
  mesh.positions = {{0, 0, 0},     {1, 0, 0}, {0, 0, -1},  // flat on y = 0, normal +y
                    {1, 0, 1e-8f}, {0, 0, 0}, {0, -std::sin(a), std::cos(a)}};
  mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
  return mesh;
}

TEST(Charts, AFoldJoinsBelowTheCreaseAngleAndSplitsAboveIt) {
  EXPECT_EQ(charts_of(folded_pair(0.0f)).charts.size(), 1u);   // flat: welded and joined
  EXPECT_EQ(charts_of(folded_pair(20.0f)).charts.size(), 1u);  // 20 < 30
  EXPECT_EQ(charts_of(folded_pair(45.0f)).charts.size(), 2u);  // 45 > 30
  EXPECT_EQ(charts_of(folded_pair(45.0f), 60.0f).charts.size(), 1u);
  // Apart (nothing shared within the tolerance): two charts however flat.
  pb::scene::Mesh apart = folded_pair(0.0f);
  for (int v = 3; v < 6; ++v) apart.positions[v].x += 0.01f;
  EXPECT_EQ(charts_of(apart).charts.size(), 2u);
}

TEST(Charts, BadInputIsRefusedWithTheKey) {
  const pb::scene::Mesh pair = folded_pair(0.0f);
  auto message = [&](float crease, std::vector<glm::uvec3> triangles) {
    try {
      segment_charts(pair.positions, triangles, crease);
    } catch (const pb::Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message(-1.0f, pair.triangles).find("crease_angle"), std::string::npos);
  EXPECT_NE(message(181.0f, pair.triangles).find("crease_angle"), std::string::npos);
  EXPECT_NE(message(30.0f, {{0, 1, 6}}).find("triangle 0 uses vertex 6"), std::string::npos);
  EXPECT_TRUE(segment_charts(pair.positions, {}, 30.0f).charts.empty());
}

}  // namespace toolkit_charts_test
