// One declaration per parameter (photonbench/param_table.h): a declaration gives the descriptor's
// C row (its type from the field's C++ type, its default, range, unit and doc) and reads a cell's
// values into the struct field it is bound to; an enum reads its name into the enumerator and
// refuses a name it cannot map, naming the parameter, the value and the choices; the
// struct's defaults are the declaration's; tables join into one schema; a counter table is the
// descriptor's array. What fails to compile in a constant expression (a default outside its range,
// two rows of one name) throws when run.
#include "photonbench/param_table.h"

#include <gtest/gtest.h>

#include <map>
#include <stdexcept>
#include <string>
#include <string_view>

#include "photonbench/error.h"
#include "photonbench/toolkit/technique.h"

namespace param_table_test {

enum class Mode : uint32_t { kPlain, kCone, kTrivial };

struct Filter {
  float alpha;
  uint32_t iterations;
  int32_t offset;
  bool spatial;
  Mode mode;
};

// clang-format off
constexpr auto kFilterParams = pb::params(
    pb::param("temporal_alpha", &Filter::alpha, 0.95, {0, 1}, "", "blend weight"),
    pb::param("iterations", &Filter::iterations, 4, {1, 8}, "passes", "a-trous passes"),
    pb::param("offset", &Filter::offset, -1, {-1, 64}, "pixels", "-1: automatic"),
    pb::param("spatial", &Filter::spatial, true, "the spatial filter"),
    pb::param("mode", &Filter::mode, Mode::kCone, "plain|cone|trivial", "which variant"));
// clang-format on

// A struct whose member initialisers must be its declaration's.
struct Initialised {
  uint32_t count = 7;
  float scale = 0.5f;
};
constexpr auto kInitialisedParams =
    pb::params(pb::param("count", &Initialised::count, 7, {1, 10}, "", "count"),
               pb::param("scale", &Initialised::scale, 0.5, {0, 1}, "", "scale"));
constexpr auto kOtherDefaultParams =
    pb::params(pb::param("count", &Initialised::count, 8, {1, 10}, "", "count"),
               pb::param("scale", &Initialised::scale, 0.5, {0, 1}, "", "scale"));
static_assert(kInitialisedParams.member_defaults_match());
static_assert(!kOtherDefaultParams.member_defaults_match());

pb::Params values(std::map<std::string, std::string> map) { return pb::Params(std::move(map)); }

const std::map<std::string, std::string> kAllSet = {{"temporal_alpha", "0.25"},
                                                    {"iterations", "6"},
                                                    {"offset", "-1"},
                                                    {"spatial", "false"},
                                                    {"mode", "trivial"}};

TEST(ParamTable, RowsCarryTheDeclarationWithTheTypeOfTheField) {
  ASSERT_EQ(kFilterParams.size(), 5u);
  const pb_param_spec& alpha = kFilterParams.row("temporal_alpha");
  EXPECT_EQ(alpha.type, PB_PARAM_FLOAT);
  EXPECT_EQ(alpha.default_value, 0.95);  // the declaration's double, not float(0.95)
  EXPECT_EQ(alpha.min_value, 0);
  EXPECT_EQ(alpha.max_value, 1);
  EXPECT_STREQ(alpha.doc, "blend weight");
  EXPECT_EQ(alpha.choices, nullptr);
  const pb_param_spec& iterations = kFilterParams.rows[1];
  EXPECT_STREQ(iterations.name, "iterations");
  EXPECT_EQ(iterations.type, PB_PARAM_INT);
  EXPECT_STREQ(iterations.unit, "passes");
  const pb_param_spec& spatial = kFilterParams.row("spatial");
  EXPECT_EQ(spatial.type, PB_PARAM_BOOL);
  EXPECT_EQ(spatial.default_value, 1);
  const pb_param_spec& mode = kFilterParams.row("mode");
  EXPECT_EQ(mode.type, PB_PARAM_ENUM);
  EXPECT_EQ(mode.default_value, 1);  // the index of "cone"
  EXPECT_EQ(mode.min_value, 0);
  EXPECT_EQ(mode.max_value, 2);
  EXPECT_STREQ(mode.choices, "plain|cone|trivial");
}

TEST(ParamTable, ReadFillsEveryBoundField) {
  const Filter filter = kFilterParams.read(values(kAllSet));
  EXPECT_EQ(filter.alpha, 0.25f);
  EXPECT_EQ(filter.iterations, 6u);
  EXPECT_EQ(filter.offset, -1);
  EXPECT_FALSE(filter.spatial);
  EXPECT_EQ(filter.mode, Mode::kTrivial);
}

TEST(ParamTable, DefaultsAreTheDeclarations) {
  constexpr Filter filter = kFilterParams.defaults();
  EXPECT_EQ(filter.alpha, 0.95f);
  EXPECT_EQ(filter.iterations, 4u);
  EXPECT_EQ(filter.offset, -1);
  EXPECT_TRUE(filter.spatial);
  EXPECT_EQ(filter.mode, Mode::kCone);
}

TEST(ParamTable, EveryChoiceMapsToItsEnumerator) {
  const char* names[] = {"plain", "cone", "trivial"};
  for (uint32_t i = 0; i < 3; ++i) {
    auto map = kAllSet;
    map["mode"] = names[i];
    EXPECT_EQ(kFilterParams.read(values(map)).mode, Mode(i)) << names[i];
  }
}

TEST(ParamTable, AnUnknownChoiceIsRefusedWithTheKeyAndTheChoices) {
  auto map = kAllSet;
  map["mode"] = "conee";
  try {
    kFilterParams.read(values(map));
    FAIL() << "an unknown choice was read";
  } catch (const pb::Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("'mode'"), std::string::npos) << message;
    EXPECT_NE(message.find("'conee'"), std::string::npos) << message;
    EXPECT_NE(message.find("plain, cone, trivial"), std::string::npos) << message;
  }
}

TEST(ParamTable, AMissingRowIsRefused) {
  auto map = kAllSet;
  map.erase("iterations");
  EXPECT_THROW(kFilterParams.read(values(map)), pb::Error);
}

TEST(ParamTable, ABadDeclarationIsRefused) {
  // Each of these fails to compile as a constexpr declaration; run, it throws.
  EXPECT_THROW(pb::row<uint32_t>("n", 9, {0, 8}, "", "default above the range"), std::logic_error);
  EXPECT_THROW(pb::row<uint32_t>("n", 1, {-1, 8}, "", "range below zero"), std::logic_error);
  EXPECT_THROW(pb::row<int32_t>("n", 0.5, {0, 8}, "", "default not whole"), std::logic_error);
  EXPECT_THROW(pb::bind(pb::row<float>("x", 0, {0, 1}, "", "a float"), &Filter::iterations),
               std::logic_error);
  EXPECT_THROW(pb::row<Mode>("m", Mode::kTrivial, "plain|cone", "default has no name"),
               std::logic_error);
  EXPECT_THROW(pb::params(pb::param("a", &Filter::iterations, 1, {0, 8}, "", "one"),
                          pb::param("a", &Filter::offset, 1, {0, 8}, "", "the same name")),
               std::logic_error);
}

TEST(ParamTable, TablesJoinIntoOneSchema) {
  constexpr auto joined = pb::join_rows(kFilterParams, kInitialisedParams);
  static_assert(joined.size() == 7);
  EXPECT_STREQ(joined.rows[0].name, "temporal_alpha");
  EXPECT_STREQ(joined.rows[5].name, "count");
  EXPECT_THROW(pb::join_rows(kInitialisedParams, kOtherDefaultParams), std::logic_error);
}

// Two structs binding one declaration: the merged schema lists it once.
struct Other {
  uint32_t count;
};
constexpr auto kOtherParams = pb::params(pb::bind(kInitialisedParams.row("count"), &Other::count),
                                         pb::param("extra", &Other::count, 1, {0, 2}, "", "extra"));

TEST(ParamTable, MergedTablesListASharedRowOnce) {
  constexpr auto merged = pb::merge_rows<kInitialisedParams, kOtherParams>();
  static_assert(merged.size() == 3);
  EXPECT_STREQ(merged.rows[0].name, "count");
  EXPECT_STREQ(merged.rows[1].name, "scale");
  EXPECT_STREQ(merged.rows[2].name, "extra");
}

TEST(ParamTable, WithRowReplacesADefaultForReadAndSchema) {
  constexpr auto changed = kInitialisedParams.with_row(
      pb::toolkit::with_range(kInitialisedParams.row("count"), 3, 1, 5, "count, at most 5"));
  EXPECT_EQ(changed.row("count").max_value, 5);
  EXPECT_EQ(changed.defaults().count, 3u);
  EXPECT_EQ(changed.read(values({{"count", "4"}, {"scale", "1"}})).count, 4u);
  EXPECT_THROW(kInitialisedParams.with_row(pb::row<uint32_t>("absent", 1, {0, 2}, "", "none")),
               std::logic_error);
}

// The toolkit's shared rows come from their declarations, as the schema had them.
TEST(ParamTable, ToolkitPhotonRowsKeepTheirSchema) {
  using namespace pb::toolkit;
  EXPECT_EQ(kPhotonsParam.type, PB_PARAM_INT);
  EXPECT_EQ(kPhotonsParam.default_value, 100000);
  EXPECT_EQ(kPhotonsParam.max_value, 5e7);
  EXPECT_EQ(kRadiusParam.default_value, 0.05);
  EXPECT_EQ(kMaxBouncesParam.min_value, 2);
  EXPECT_EQ(kShadowMapSizeParam.default_value, 512);
  EXPECT_EQ(kStoreFirstHitParam.type, PB_PARAM_BOOL);
  const PhotonParams read = PhotonParams::read(values({{"photons", "1000"},
                                                       {"radius", "0.5"},
                                                       {"max_bounces", "6"},
                                                       {"shadow_map_size", "256"},
                                                       {"store_first_hit", "true"}}));
  EXPECT_EQ(read.paths, 1000u);
  EXPECT_EQ(read.radius, 0.5f);
  EXPECT_EQ(read.max_bounces, 6u);
  EXPECT_EQ(read.shadow_map_size, 256u);
  EXPECT_TRUE(read.store_first_hit);
}

// A params struct built from parts (a core struct, the toolkit's shared rows) binds the fields it
// inherits through pb::base_field: read fills them in the struct's own parts, and each part's
// initialisers stay checkable against the declaration.
struct Core {
  float scale = 0.5f;
  uint32_t passes = 3;
};
struct Composed : Core, pb::toolkit::PhotonParams {
  bool extra;
};
// clang-format off
constexpr auto kComposedParams = pb::params(
    pb::param("scale", pb::base_field<Composed>(&Core::scale), 0.5, {0, 1}, "", "scale"),
    pb::bind(pb::toolkit::kMaxBouncesParam,
             pb::base_field<Composed>(&pb::toolkit::PhotonParams::max_bounces)),
    pb::param("passes", pb::base_field<Composed>(&Core::passes), 3, {1, 9}, "", "passes"),
    pb::param("extra", &Composed::extra, true, "extra"));
// clang-format on
static_assert(static_cast<const Core&>(kComposedParams.defaults()).passes == Core{}.passes);

TEST(ParamTable, BaseFieldFillsTheFieldOfAPart) {
  const Composed read = kComposedParams.read(
      values({{"scale", "0.25"}, {"max_bounces", "7"}, {"passes", "5"}, {"extra", "false"}}));
  const Core& core = read;
  const pb::toolkit::PhotonParams& photon = read;
  EXPECT_EQ(core.scale, 0.25f);
  EXPECT_EQ(core.passes, 5u);
  EXPECT_EQ(photon.max_bounces, 7u);
  EXPECT_EQ(photon.paths, pb::toolkit::PhotonParams{}.paths);  // no row: its initialiser
  EXPECT_FALSE(read.extra);
  EXPECT_STREQ(kComposedParams.rows[1].name, "max_bounces");
  EXPECT_EQ(kComposedParams.rows[1].type, PB_PARAM_INT);
  EXPECT_EQ(kComposedParams.defaults().max_bounces, 4u);
}

// A counter table is the descriptor's array and the counters' names, checked where they are used.
constexpr auto kCounters = pb::counters({
    {"paths_kept", PB_COUNTER_WORK, "paths", "kept"},
    {"bytes_map", PB_COUNTER_SIZE, "bytes", "the map"},
});

TEST(CounterTable, IsTheArrayAndIsCountedByName) {
  static_assert(kCounters.size() == 2);
  EXPECT_EQ(&kCounters["bytes_map"], &kCounters.specs[1]);
  EXPECT_EQ(kCounters["paths_kept"].kind, PB_COUNTER_WORK);
  EXPECT_STREQ(kCounters["bytes_map"].unit, "bytes");
  const pb_counter_spec twice[] = {{"a", PB_COUNTER_WORK, "", "one"},
                                   {"a", PB_COUNTER_SIZE, "", "the same name"}};
  EXPECT_THROW(pb::counters(twice), std::logic_error);
}

}  // namespace param_table_test
