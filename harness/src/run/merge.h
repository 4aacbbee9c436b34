// `photonbench merge OUT RUN_DIR...`: joins the run folders of a sharded run (run --shard I/N) into
// one, as if the config had been run in one place: every cell of the plan exactly once, the same
// cell folders and logs, summary.csv rebuilt from them, run.json recording each shard.
#pragma once

#include <filesystem>
#include <vector>

namespace pb::run {

// Checks every shard before writing anything: a folder that is not a shard run, shards of
// different configs (config hash) or shard counts, shards that planned different cells, a shard
// given twice, a cell missing from every shard (with the shard that should hold it) or complete in
// more than one are each named in one pb::InputError. Then writes OUT (which must not hold a run):
// cells/ and logs/ (hard links where the filesystem allows, else copies), invocation.json, run.json
// and summary.csv. Returns 0 when every cell is ok, 1 when some cell failed (as `run` does).
int merge_runs(const std::filesystem::path& out, const std::vector<std::filesystem::path>& shards);

}  // namespace pb::run
