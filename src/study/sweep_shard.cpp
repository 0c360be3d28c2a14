#include "study/sweep_shard.hpp"

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "core/platform.hpp"
#include "study/sweep_plan.hpp"

namespace kfx::sweep {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  KFX_CHECK(in.good(), "cannot read '" << path.string() << "'");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// "run NAME on SEQUENCE" from a "run|sequence|backend" key.
std::string describe_key(const std::string& key) {
  const auto first = key.find('|');
  const auto second = key.find('|', first + 1);
  if (first == std::string::npos || second == std::string::npos) return key;
  return "run " + key.substr(0, first) + " on " + key.substr(first + 1, second - first - 1) + " (" +
         key.substr(second + 1) + ")";
}

}  // namespace

Shard parse_shard(const std::string& text) {
  Shard shard;
  char slash = 0;
  std::istringstream in(text);
  const bool parsed = static_cast<bool>(in >> shard.index >> slash >> shard.count) &&
                      slash == '/' && in.peek() == std::char_traits<char>::eof();
  KFX_CHECK(parsed && shard.count >= 1 && shard.index >= 0 && shard.index < shard.count,
            "--shard '" << text << "' is not i/n with 0 <= i < n (e.g. 0/4 ... 3/4)");
  return shard;
}

ShardFolder read_shard_folder(const std::string& folder) {
  ShardFolder shard;
  shard.folder = folder;
  const fs::path dir = folder;
  KFX_CHECK(fs::is_directory(dir), "shard folder '" << folder << "' does not exist");
  shard.plan_text = read_text(dir / "plan.json");
  const std::string results_path = (dir / "results.json").string();
  const json results = json::parse(read_text(results_path), nullptr, false);
  KFX_CHECK(results.is_object(), "'" << results_path << "' is not a JSON object");
  shard.meta = results;
  shard.meta.erase("runs");
  shard.meta.erase("updated");
  shard.records = read_results_log((dir / "results.jsonl").string());
  return shard;
}

MergedSweep merge_shards(const std::vector<ShardFolder>& shards) {
  KFX_CHECK(!shards.empty(), "no shard folders to merge");
  const ShardFolder& first = shards.front();
  auto shard_of = [](const ShardFolder& s) {
    KFX_CHECK(
        s.meta.contains("shard") && s.meta["shard"].is_object() && s.meta.contains("run_keys"),
        "'" << s.folder << "' is not a shard of a sweep (its results.json has no \"shard\"; "
            << "shards are written by kfx sweep --shard i/n)");
    return Shard{s.meta["shard"].value("index", -1), s.meta["shard"].value("count", 0)};
  };
  const int count = shard_of(first).count;
  std::vector<const ShardFolder*> by_index(static_cast<size_t>(std::max(count, 0)), nullptr);
  for (const ShardFolder& s : shards) {
    const Shard shard = shard_of(s);
    KFX_CHECK(s.plan_text == first.plan_text,
              "'" << s.folder << "' ran a different plan than '" << first.folder
                  << "' (their plan.json differ): shards of different sweeps cannot be merged");
    KFX_CHECK(s.meta["run_keys"] == first.meta["run_keys"] &&
                  s.meta.value("run_options", json()) == first.meta.value("run_options", json()),
              "'" << s.folder << "' expanded the plan into other runs or options than '"
                  << first.folder << "' (different --only, --sequences, --variant, --set, "
                  << "--frames, --repeat, --warmup or backend): shards of different sweeps "
                  << "cannot be merged");
    KFX_CHECK(shard.count == count, "'" << s.folder << "' is shard " << shard.index << "/"
                                        << shard.count << " but '" << first.folder << "' is one of "
                                        << count << " shards");
    KFX_CHECK(shard.index >= 0 && shard.index < count,
              "'" << s.folder << "' has a bad shard index " << shard.index);
    KFX_CHECK(!by_index[shard.index], "shard " << shard.index << "/" << count << " given twice: '"
                                               << by_index[shard.index]->folder << "' and '"
                                               << s.folder << "'");
    by_index[shard.index] = &s;
  }
  for (int i = 0; i < count; ++i) {
    KFX_CHECK(by_index[i], "shard " << i << "/" << count << " is missing: " << count
                                    << " shard folders are needed, " << shards.size()
                                    << " were given");
  }

  MergedSweep merged;
  merged.plan_text = first.plan_text;
  merged.meta = first.meta;
  merged.meta.erase("shard");
  merged.meta["merged_from"] = json::array();
  for (int i = 0; i < count; ++i) merged.meta["merged_from"].push_back(by_index[i]->folder);
  merged.run_keys = first.meta["run_keys"].get<std::vector<std::string>>();

  // The latest record of every key in every shard; a run of the plan must be answered by the
  // shard it belongs to, and by no other.
  std::vector<std::map<std::string, json>> latest(count);
  for (int i = 0; i < count; ++i) {
    for (const json& record : latest_results(by_index[i]->records)) {
      latest[i][result_key(record)] = record;
    }
  }
  for (size_t j = 0; j < merged.run_keys.size(); ++j) {
    const std::string& key = merged.run_keys[j];
    const int owner = static_cast<int>(j % static_cast<size_t>(count));
    for (int i = 0; i < count; ++i) {
      KFX_CHECK(i == owner || !latest[i].count(key),
                describe_key(key) << " belongs to shard " << owner << "/" << count << " ('"
                                  << by_index[owner]->folder << "') but '" << by_index[i]->folder
                                  << "' (shard " << i << "/" << count
                                  << ") also has a result for it: overlapping shards");
    }
    const auto it = latest[owner].find(key);
    KFX_CHECK(it != latest[owner].end(),
              describe_key(key) << " has no result in shard " << owner << "/" << count << " ('"
                                << by_index[owner]->folder
                                << "'): that shard did not finish; run its command again to "
                                   "resume it");
    merged.records.push_back(it->second);
  }
  return merged;
}

}  // namespace kfx::sweep
