// pb::Params: typed reads of a cell's resolved parameter values (already validated by the harness).
#include <fmt/format.h>

#include <cstdlib>

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

}  // namespace pb
