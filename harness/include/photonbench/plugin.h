// The technique plugin contract. A technique is a shared module in build/plugins/ exporting one C entry
// point, `photonbench_technique`, that takes the host's API version and returns a static descriptor
// table of C types only: name, API version, path class, parameter schema and a factory. The loader
// checks the version before calling anything else.
//
//   static const pb_param_spec kParams[] = {
//       {"photons", PB_PARAM_INT, 200000, 1000, 5e7, nullptr, "photons", "photons traced per frame"},
//   };
//   PB_EXPORT_TECHNIQUE(MyTechnique, "mine", "C D S+ L", "one-line summary", kParams)
#pragma once

#include <cstdint>

#define PB_PLUGIN_API_VERSION 1u
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

typedef struct pb_technique_descriptor {
  uint32_t api_version;  // PB_PLUGIN_API_VERSION the module was built against
  const char* name;
  const char* path_class;  // light transport estimated, as a light path expression: "C D S+ L"
  const char* summary;
  const pb_param_spec* params;
  uint32_t param_count;
  void* (*create)(void);  // a new pb::Technique
  void (*destroy)(void*);
} pb_technique_descriptor;

typedef const pb_technique_descriptor* (*pb_technique_entry)(uint32_t host_api_version);

}  // extern "C"

#ifdef __cplusplus
#include <map>
#include <string>

namespace pb {

class Context;

// Resolved parameter values of one cell, already checked against the schema (type and range) by the
// harness. Cross-parameter constraints are the technique's to check in setup (throw pb::InputError).
class Params {
 public:
  explicit Params(std::map<std::string, std::string> values) : values_(std::move(values)) {}
  double number(const std::string& name) const;
  int64_t integer(const std::string& name) const;
  bool flag(const std::string& name) const;
  const std::string& choice(const std::string& name) const;
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

}  // namespace pb

#define PB_EXPORT_TECHNIQUE(Class, name, path_class, summary, params)                              \
  extern "C" __attribute__((visibility("default"))) const pb_technique_descriptor*                 \
  photonbench_technique(uint32_t /*host_api_version*/) {                                            \
    static const pb_technique_descriptor descriptor = {                                            \
        PB_PLUGIN_API_VERSION, name, path_class, summary, params,                                  \
        uint32_t(sizeof(params) / sizeof(params[0])),                                              \
        []() -> void* { return static_cast<pb::Technique*>(new Class()); },                        \
        [](void* t) { delete static_cast<pb::Technique*>(t); }};                                   \
    return &descriptor;                                                                            \
  }
#endif
