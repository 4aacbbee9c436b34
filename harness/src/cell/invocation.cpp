#include "cell/invocation.h"

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "io/results.h"
#include "photonbench/error.h"

namespace pb::run {

void write_invocation(const std::filesystem::path& run_dir, const Invocation& invocation) {
  nlohmann::json j = {{"config_file", std::filesystem::absolute(invocation.config_file).string()},
                      {"overrides", invocation.overrides},
                      {"config_hash", invocation.config_hash}};
  io::write_text_atomic(run_dir / "invocation.json", j.dump(2) + "\n");
}

Invocation read_invocation(const std::filesystem::path& run_dir) {
  std::filesystem::path file = run_dir / "invocation.json";
  if (!std::filesystem::exists(file))
    throw InputError(
        fmt::format("{}: not a photonbench run folder (no invocation.json)", run_dir.string()));
  auto j = nlohmann::json::parse(io::read_text(file));
  return {j.at("config_file").get<std::string>(), j.at("overrides").get<std::vector<std::string>>(),
          j.at("config_hash").get<std::string>()};
}

}  // namespace pb::run
