#pragma once
/// Sweeps split over machines (docs/sweep.md, "Shards"): `kfx sweep --shard i/n` runs the runs
/// at positions j with j mod n = i of the plan's expanded, ordered run list (sequence by
/// sequence, runs in plan order within each), and `kfx sweep merge` joins the n shard folders
/// into the results one unsharded sweep would have written, refusing shards of different plans
/// or options, missing or repeated shards, and runs answered twice or not at all.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace kfx::sweep {

/// One slice of n: index i in [0, n).
struct Shard {
  int index = 0;
  int count = 1;
};

/// Parses "i/n" (0 <= i < n, n >= 1); throws kfx::Error naming the text otherwise.
Shard parse_shard(const std::string& text);

/// Whether the run at `position` of the expanded run list belongs to `shard`.
inline bool in_shard(size_t position, const Shard& shard) {
  return static_cast<int>(position % static_cast<size_t>(shard.count)) == shard.index;
}

/// A finished shard's folder as read back: plan.json, results.json (its `shard`, `run_keys`
/// and `run_options`) and every record of results.jsonl.
struct ShardFolder {
  std::string folder;
  std::string plan_text;
  nlohmann::json meta;  ///< results.json without `runs`
  std::vector<nlohmann::json> records;
};

/// Reads a shard folder; a missing or unreadable file throws kfx::Error naming it.
ShardFolder read_shard_folder(const std::string& folder);

/// The joined sweep: the plan, the meta of results.json (no `shard`; `merged_from` lists the
/// folders) and the latest record of every run, in plan order.
struct MergedSweep {
  std::string plan_text;
  nlohmann::json meta;
  std::vector<std::string> run_keys;
  std::vector<nlohmann::json> records;
};

/// Joins shards; throws kfx::Error naming the folders and runs when they do not make one
/// whole sweep (different plan or options, a shard missing or given twice, a run without a
/// result or with results in two shards).
MergedSweep merge_shards(const std::vector<ShardFolder>& shards);

}  // namespace kfx::sweep
