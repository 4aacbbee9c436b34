// pb::Params: typed reads of a cell's resolved parameter values (already validated by the harness).
#include <fmt/format.h>

#include <cstdlib>
#include <vector>

#include "photonbench/error.h"
#include "photonbench/plugin.h"

namespace pb {

const std::string& Params::raw(const std::string& name) const {
  auto it = values_.find(name);
  if (it == values_.end())
    throw Error(fmt::format("technique read parameter '{}', which its schema lacks", name));
  return it->second;
}

double Params::number(const std::string& name) const {
  return std::strtod(raw(name).c_str(), nullptr);
}
int64_t Params::integer(const std::string& name) const {
  return std::strtoll(raw(name).c_str(), nullptr, 10);
}
bool Params::flag(const std::string& name) const { return raw(name) == "true"; }
const std::string& Params::choice(const std::string& name) const { return raw(name); }

uint32_t Params::choice_index(const std::string& name, std::string_view choices) const {
  const std::string& value = raw(name);
  std::vector<std::string_view> names;
  for (size_t start = 0;;) {
    const size_t bar = choices.find('|', start);
    names.push_back(choices.substr(start, bar - start));
    if (bar == std::string_view::npos) break;
    start = bar + 1;
  }
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == value) return uint32_t(i);
  // The plan refuses such a value at its config key (with the closest name), so this is a
  // technique whose enum and choices disagree.
  throw Error(
      fmt::format("parameter '{}': '{}' is not one of {}", name, value, fmt::join(names, ", ")));
}

}  // namespace pb
