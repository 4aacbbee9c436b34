// The technique plugin contract. A technique is a shared module exporting one C entry point,
// `photonbench_technique`, that takes the host's API version and returns a static descriptor table
// of C types only: API version, build record, name, path class, parameter schema, a factory, the
// counters it emits and, optionally, a check of its parameters taken together and the budget knobs
// a match run may turn (the parameters that trade cost for quality).
//
// Plugins are built by other compilers on other days (out of tree, against the installed package),
// so the boundary is checked before anything else is called: the descriptor opens with the module's
// API version and its build record (compiler, standard library, Vulkan-Hpp version, sizeof of each
// public class), a layout kept from version 2 on. Only a module of this version is loaded: one of
// another version is refused at its version, the message naming both versions and what each later
// version changed (version 3 added the counters and the check, version 4 the budget knobs, version
// 5 turned the photon tracer's modes into tracer policies: photonbench/photons.h). The entry
// point honours the host's version: given another version than its own it returns only that
// opening, never a factory the host cannot use.
// A mismatch fails only that plugin's cells, with a message naming both sides (plan/plugins.cpp).
//
//   static const pb_param_spec kParams[] = {
// {"photons", PB_PARAM_INT, 200000, 1000, 5e7, nullptr, "photons", "photons traced per frame"},
//   };
//   constexpr pb_counter_spec kRead{"photons_read", PB_COUNTER_WORK, "photons", "entries read"};
//   const pb_counter_spec kCounters[] = {kRead};  // pb::count(ctx, kRead, n) in render
//   const pb_budget_knob kBudget[] = {{"photons", PB_COST_GROWS, PB_ERROR_FALLS, PB_SCALE_LOG}};
//   PB_EXPORT_TECHNIQUE(MyTechnique, "mine", "C D S+ L", "one-line summary", kParams,
//                       .counters = kCounters, .check = &MyTechnique::check, .budget = kBudget)
// where `static std::string check(const pb::Params&)` returns "" or "<parameter>: what is wrong".
// Every extra is optional, and a technique that declares none compiles unchanged.
#pragma once

#include <cstdint>

#ifndef PB_PLUGIN_API_VERSION  // a test plugin defines another to play a module of another day
#define PB_PLUGIN_API_VERSION 6u
#endif
// The oldest module version a host loads: version 6 made the tracer's footprints a request
// (TraceSettings::footprints), which a version-5 module that reads them never makes, and its
// TraceSettings keeps its size, so the build record's sizes cannot tell.
#define PB_PLUGIN_API_OLDEST_LOADED 6u
#define PB_TECHNIQUE_ENTRY_SYMBOL "photonbench_technique"

extern "C" {

typedef enum pb_param_type {
  PB_PARAM_INT = 0,    // whole number in [min, max]
  PB_PARAM_FLOAT = 1,  // real number in [min, max]
  PB_PARAM_BOOL = 2,   // true / false; default 0 or 1
  PB_PARAM_ENUM = 3,   // one of `choices` ("a|b|c"); default is the index of the default choice
} pb_param_type;

typedef struct pb_param_spec {
  const char* name;  // snake_case, with the unit in the name or in `unit`
  pb_param_type type;
  double default_value;
  double min_value;
  double max_value;
  const char* choices;  // PB_PARAM_ENUM only: "plain|cone|trivial"
  const char* unit;     // "m", "photons", "deg", "" ...
  const char* doc;      // one line
} pb_param_spec;

// One parameter of a cell as the harness resolved it (its default filled in, its type and range
// checked against the row): the text pb::Params holds ("8", "0.05", "true", "cone").
typedef struct pb_param_value {
  const char* name;
  const char* value;
} pb_param_value;

// How a counter's values combine over frames (pb::CounterKind, photonbench/context.h).
typedef enum pb_counter_kind {
  PB_COUNTER_WORK = 0,   // done this frame: adds up over frames
  PB_COUNTER_SIZE = 1,   // held this frame: a level
  PB_COUNTER_RATIO = 2,  // a fraction of this frame's work: averaged, never added
} pb_counter_kind;

// A counter the technique emits (ctx.count): the harness fails a cell whose technique counts a
// name its descriptor does not declare, or declares with another kind or unit.
typedef struct pb_counter_spec {
  const char* name;  // snake_case, unique within a technique
  pb_counter_kind kind;
  const char* unit;  // "photons", "bytes", "nodes", ...
  const char* doc;   // one line
} pb_counter_spec;

// How a budget knob moves a technique's cost (frame time) or its error as the knob grows.
typedef enum pb_budget_direction {
  PB_BUDGET_FALLS = -1,
  PB_BUDGET_MIXED = 0,  // error only: not monotone (a splat radius trades variance for bias)
  PB_BUDGET_GROWS = 1,
} pb_budget_direction;
#define PB_COST_GROWS PB_BUDGET_GROWS
#define PB_COST_FALLS PB_BUDGET_FALLS
#define PB_ERROR_GROWS PB_BUDGET_GROWS
#define PB_ERROR_FALLS PB_BUDGET_FALLS
#define PB_ERROR_MIXED PB_BUDGET_MIXED

// How cost and error follow the knob, roughly: in proportion to it, or to its logarithm (a photon
// count: a match run brackets such a knob by factors of 2 and bisects it geometrically).
typedef enum pb_budget_scale {
  PB_SCALE_LINEAR = 0,
  PB_SCALE_LOG = 1,
} pb_budget_scale;

// A parameter that trades cost for quality: what `match:` turns to reach an equal frame time or an
// equal error (plan/match_plan.h). It names an int or float parameter of the schema.
typedef struct pb_budget_knob {
  const char* param;          // the parameter's name
  pb_budget_direction cost;   // GROWS or FALLS: frame time as the knob grows
  pb_budget_direction error;  // GROWS, FALLS or MIXED: the error as the knob grows
  pb_budget_scale scale;
} pb_budget_knob;

typedef struct pb_class_size {
  const char* name;  // "pb::gpu::Device"
  uint32_t bytes;
} pb_class_size;

// What a module was built with. The host requires the same standard library ABI, the same
// Vulkan-Hpp headers (the vk::raii types of the public classes are inline), the same NDEBUG and the
// same size of every public class and of Vulkan-Hpp's dispatchers; the compiler and the library's
// release are reported, not compared (GCC and Clang share the Itanium C++ ABI, and a newer library
// than the host's fails in dlopen with the loader's message). NDEBUG is part of the ABI: without
// it Vulkan-Hpp's dispatchers (vk::DispatchLoaderBase) hold a header version and a flag before
// their function pointers, so a module and a host that differ read each other's dispatchers at
// other offsets (CMake's build type sets NDEBUG: Release and RelWithDebInfo do, Debug and none do
// not).
typedef struct pb_build_record {
  const char* compiler;              // "GCC 12.2.0"
  const char* standard_library;      // "libstdc++ 12 (20230210)"
  const char* standard_library_abi;  // "libstdc++ cxx11": must equal the host's
  uint32_t vulkan_hpp_version;       // VK_HEADER_VERSION: must equal the host's
  uint32_t class_size_count;
  const pb_class_size* class_sizes;  // each must equal the host's
  uint32_t assertions;               // 1: built without NDEBUG; must equal the host's
} pb_build_record;

typedef struct pb_technique_descriptor {
  // The opening every API version from 2 on keeps: read before anything else.
  uint32_t api_version;  // PB_PLUGIN_API_VERSION the module was built against
  const pb_build_record* build;
  // The rest: null unless the host's API version is the module's.
  const char* name;
  // Light transport estimated: a reference class name ("caustics") or its light path expression
  // ("C D S+ L"); anything else fails the plugin at load.
  const char* path_class;
  const char* summary;
  const pb_param_spec* params;
  uint32_t param_count;
  void* (*create)(void);  // a new pb::Technique
  void (*destroy)(void*);
  // From version 3: every counter the technique may emit (photonbench list techniques prints them).
  const pb_counter_spec* counters;
  uint32_t counter_count;
  // From version 3, optional (null: none): the cross-parameter check. The plan calls it for every
  // cell, before any work (`validate` too), with every parameter resolved; null or "" when the
  // values go together, else a message opening with the parameter at fault and ": " (e.g.
  // "density_max: 2 is below density_min = 4"), which the harness reports at that key's file, line
  // and column. The text stays valid until the next call on the same thread.
  const char* (*check)(const pb_param_value* values, uint32_t count);
  // From version 4, optional (none: the technique cannot be matched): its budget knobs, the first
  // the default knob of a match (photonbench list techniques prints them).
  const pb_budget_knob* budget;
  uint32_t budget_count;
} pb_technique_descriptor;

typedef const pb_technique_descriptor* (*pb_technique_entry)(uint32_t host_api_version);

}  // extern "C"

#ifdef __cplusplus
#include <exception>
#include <map>
#include <span>
#include <string>
#include <string_view>

#include "photonbench/context.h"

namespace pb {

// Resolved parameter values of one cell, already checked against the schema (type and range) by the
// harness, and against each other by the descriptor's check, if it has one. setup throws
// pb::InputError only for what needs the device (a buffer over maxStorageBufferRange).
class Params {
 public:
  explicit Params(std::map<std::string, std::string> values) : values_(std::move(values)) {}
  double number(const std::string& name) const;
  int64_t integer(const std::string& name) const;
  bool flag(const std::string& name) const;
  const std::string& choice(const std::string& name) const;
  // An enum parameter's value as the index of its name among `choices` ("a|b|c"), or as the
  // enumerator of that index; a name that is none of them throws pb::Error naming the parameter,
  // the value and the choices (never a fallback).
  uint32_t choice_index(const std::string& name, std::string_view choices) const;
  template <class E>
  E choice(const std::string& name, std::string_view choices) const {
    return E(choice_index(name, choices));
  }
  const std::map<std::string, std::string>& all() const { return values_; }

 private:
  const std::string& raw(const std::string& name) const;
  std::map<std::string, std::string> values_;
};

// One technique instance lives for one cell: setup once, then render once per frame (warm-up frames
// included). Both record GPU work through the context; the harness submits and times it.
class Technique {
 public:
  virtual ~Technique() = default;
  virtual void setup(Context& ctx, const Params& params) = 0;
  virtual void render(Context& ctx) = 0;
};

// Counts `value` for a counter the descriptor declares (pb_counter_spec), as ctx.count does.
inline void count(Context& ctx, const pb_counter_spec& counter, double value) {
  ctx.count({counter.name, CounterKind(counter.kind), counter.unit ? counter.unit : ""}, value);
}

// The cross-parameter check of a technique: "" when the values go together, else "<parameter>:
// what is wrong" (pb_technique_descriptor::check).
using ParamCheck = std::string (*)(const Params&);

// What PB_EXPORT_TECHNIQUE's optional arguments set, each optional, in this order: .counters (an
// array of pb_counter_spec), .check and .budget (an array of pb_budget_knob).
struct TechniqueExtras {
  std::span<const pb_counter_spec> counters;
  ParamCheck check = nullptr;
  std::span<const pb_budget_knob> budget;
};

namespace detail {

// The C entry of a C++ check: the values as pb::Params, the answer kept in a thread's own text.
// (PB_EXPORT_TECHNIQUE instantiates it for a null check too; the test is at run time because GCC
// does not take a pointer template argument's comparison with null as a constant under
// -fsanitize=undefined.)
template <ParamCheck check>
const char* check_entry(const pb_param_value* values, uint32_t count) {
  const ParamCheck entry = check;
  if (entry == nullptr) return nullptr;
  thread_local std::string message;
  try {
    std::map<std::string, std::string> map;
    for (uint32_t i = 0; i < count; ++i) map[values[i].name] = values[i].value;
    message = entry(Params(std::move(map)));
  } catch (const std::exception& e) {
    message = e.what();
  } catch (...) {
    message = "the parameter check threw";
  }
  return message.empty() ? nullptr : message.c_str();
}

#define PB_STRINGIFY_(x) #x
#define PB_STRINGIFY(x) PB_STRINGIFY_(x)

// The build record of the module that expands this (internal linkage: never bound to the host's
// copy by the dynamic linker, so each side reports its own build).
[[maybe_unused]] static const pb_build_record* this_build() {
  static const pb_class_size sizes[] = {
      {"std::string", sizeof(std::string)},
      {"pb::Params", sizeof(Params)},
      {"pb::Technique", sizeof(Technique)},
      {"pb::Context", sizeof(Context)},
      {"pb::FrameInfo", sizeof(FrameInfo)},
      {"pb::GBuffer", sizeof(GBuffer)},
      {"pb::SceneTriangles", sizeof(SceneTriangles)},
      {"pb::SceneTarget", sizeof(SceneTarget)},
      {"pb::Counter", sizeof(Counter)},
      {"pb::PassScope", sizeof(PassScope)},
      {"pb::gpu::Device", sizeof(gpu::Device)},
      {"pb::gpu::Device::Limits", sizeof(gpu::Device::Limits)},
      {"pb::gpu::Buffer", sizeof(gpu::Buffer)},
      {"pb::gpu::Image", sizeof(gpu::Image)},
      {"pb::gpu::Pipeline", sizeof(gpu::Pipeline)},
      {"pb::gpu::GraphicsPipelineDesc", sizeof(gpu::GraphicsPipelineDesc)},
      {"pb::trace::TraceSettings", sizeof(trace::TraceSettings)},
      {"pb::trace::PhotonBatch", sizeof(trace::PhotonBatch)},
      {"pb::trace::CameraPathSettings", sizeof(trace::CameraPathSettings)},
      {"pb::trace::CameraPathBatch", sizeof(trace::CameraPathBatch)},
      {"vk::raii::ContextDispatcher", sizeof(*std::declval<vk::raii::Context&>().getDispatcher())},
      {"vk::raii::InstanceDispatcher",
       sizeof(*std::declval<vk::raii::Instance&>().getDispatcher())},
      {"vk::raii::DeviceDispatcher", sizeof(*std::declval<vk::raii::Device&>().getDispatcher())},
  };
  static const pb_build_record record = {
#if defined(__clang__)
    "clang " __clang_version__,
#elif defined(__GNUC__)
    "GCC " __VERSION__,
#else
    "unknown compiler",
#endif
#if defined(_LIBCPP_VERSION)
    "libc++ " PB_STRINGIFY(_LIBCPP_VERSION),
    "libc++ " PB_STRINGIFY(_LIBCPP_ABI_VERSION),
#elif defined(__GLIBCXX__)
    "libstdc++ " PB_STRINGIFY(_GLIBCXX_RELEASE) " (" PB_STRINGIFY(__GLIBCXX__) ")",
#if _GLIBCXX_USE_CXX11_ABI
    "libstdc++ cxx11",
#else
    "libstdc++ pre-cxx11",
#endif
#else
    "unknown standard library",
    "unknown standard library",
#endif
    VK_HEADER_VERSION,
    uint32_t(sizeof(sizes) / sizeof(sizes[0])),
    sizes,
#ifdef NDEBUG
    0u
#else
    1u
#endif
  };
  return &record;
}

}  // namespace detail
}  // namespace pb

// The entry point: the whole descriptor for a host of the module's API version, only the opening
// (version and build record) for any other host. After `params`, optionally, designated
// initializers of pb::TechniqueExtras: `.counters = kCounters, .check = &MyTechnique::check,
// .budget = kBudget`.
#define PB_EXPORT_TECHNIQUE(Class, name, path_class, summary, params, ...)         \
  extern "C" __attribute__((visibility("default"))) const pb_technique_descriptor* \
  photonbench_technique(uint32_t host_api_version) {                               \
    static constexpr pb::TechniqueExtras extras{__VA_ARGS__};                      \
    static const pb_technique_descriptor descriptor = {                            \
        PB_PLUGIN_API_VERSION,                                                     \
        pb::detail::this_build(),                                                  \
        name,                                                                      \
        path_class,                                                                \
        summary,                                                                   \
        params,                                                                    \
        uint32_t(sizeof(params) / sizeof(params[0])),                              \
        []() -> void* { return static_cast<pb::Technique*>(new Class()); },        \
        [](void* t) { delete static_cast<pb::Technique*>(t); },                    \
        extras.counters.data(),                                                    \
        uint32_t(extras.counters.size()),                                          \
        extras.check ? &pb::detail::check_entry<extras.check> : nullptr,           \
        extras.budget.data(),                                                      \
        uint32_t(extras.budget.size())};                                           \
    static const pb_technique_descriptor opening = {PB_PLUGIN_API_VERSION,         \
                                                    pb::detail::this_build(),      \
                                                    nullptr,                       \
                                                    nullptr,                       \
                                                    nullptr,                       \
                                                    nullptr,                       \
                                                    0,                             \
                                                    nullptr,                       \
                                                    nullptr,                       \
                                                    nullptr,                       \
                                                    0,                             \
                                                    nullptr,                       \
                                                    nullptr,                       \
                                                    0};                            \
    return host_api_version == PB_PLUGIN_API_VERSION ? &descriptor : &opening;     \
  }
#endif
