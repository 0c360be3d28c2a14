/// Sweep plan parsing, validation and results bookkeeping (see sweep_plan.hpp).

#include "study/sweep_plan.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "backend/backend.hpp"
#include "core/platform.hpp"

namespace kfx::sweep {
namespace {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

/// Fields every object may carry and that mean nothing: "comment" and "_anything".
bool is_comment_field(const std::string& key) {
  return key == "comment" || (!key.empty() && key[0] == '_');
}

/// Throws when `object` has a field outside `allowed` (typos must not be ignored silently).
void check_fields(const ojson& object, const std::string& where,
                  const std::vector<std::string>& allowed) {
  KFX_CHECK(object.is_object(), where << ": expected a JSON object, got " << object.type_name());
  for (const auto& item : object.items()) {
    const std::string& key = item.key();
    if (is_comment_field(key)) continue;
    if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
    std::string known;
    for (const auto& a : allowed) known += (known.empty() ? "" : ", ") + a;
    KFX_FAIL(where << ": unknown field '" << key << "' (known fields: " << known << ")");
  }
}

/// A setting's value as text: strings as they are, numbers in their shortest exact form,
/// booleans as on/off, arrays of those joined by commas ([481.2, 480, 320, 240]).
std::string value_text(const ojson& value, const std::string& where) {
  switch (value.type()) {
    case ojson::value_t::string:
      return value.get<std::string>();
    case ojson::value_t::number_integer:
    case ojson::value_t::number_unsigned:
    case ojson::value_t::number_float:
      return value.dump();
    case ojson::value_t::boolean:
      return value.get<bool>() ? "on" : "off";
    case ojson::value_t::array: {
      std::string out;
      for (const auto& element : value) {
        KFX_CHECK(!element.is_array() && !element.is_object(),
                  where << ": a list value may hold only numbers and strings");
        out += (out.empty() ? "" : ",") + value_text(element, where);
      }
      return out;
    }
    default:
      KFX_FAIL(where << ": expected a string, number, boolean or list, got " << value.type_name());
  }
}

std::string string_field(const ojson& object, const char* key, const std::string& where,
                         const std::string& fallback = "") {
  if (!object.contains(key)) return fallback;
  KFX_CHECK(object[key].is_string(), where << ": '" << key << "' must be a string");
  return object[key].get<std::string>();
}

bool bool_field(const ojson& object, const char* key, const std::string& where, bool fallback) {
  if (!object.contains(key)) return fallback;
  KFX_CHECK(object[key].is_boolean(), where << ": '" << key << "' must be true or false");
  return object[key].get<bool>();
}

int int_field(const ojson& object, const char* key, const std::string& where, int fallback,
              int min_value) {
  if (!object.contains(key)) return fallback;
  KFX_CHECK(object[key].is_number_integer() && object[key].get<int>() >= min_value,
            where << ": '" << key << "' must be an integer >= " << min_value);
  return object[key].get<int>();
}

Settings settings_field(const ojson& object, const std::string& where) {
  Settings settings;
  if (!object.contains("settings")) return settings;
  const ojson& s = object["settings"];
  KFX_CHECK(s.is_object(), where << ": 'settings' must be an object of key: value");
  for (const auto& item : s.items()) {
    KFX_CHECK(!item.key().empty(), where << ": empty setting name");
    settings.emplace_back(item.key(),
                          value_text(item.value(), where + ": setting '" + item.key() + "'"));
  }
  return settings;
}

/// "k=v+k=v": the default name of a grid point.
std::string label_of(const Settings& settings) {
  std::string out;
  for (const auto& [key, value] : settings) out += (out.empty() ? "" : "+") + key + "=" + value;
  return out;
}

/// Replaces "{key}" in `name` by the grid point's value; throws on an unknown key.
std::string substitute_name(std::string name, const Settings& point, const std::string& where) {
  for (const auto& [key, value] : point) {
    const std::string token = "{" + key + "}";
    for (size_t at = name.find(token); at != std::string::npos; at = name.find(token, at)) {
      name.replace(at, token.size(), value);
      at += value.size();
    }
  }
  const auto open = name.find('{');
  KFX_CHECK(open == std::string::npos, where << ": name '" << name << "' refers to "
                                             << name.substr(open)
                                             << ", which is not a key of the grid");
  return name;
}

std::vector<SweepRun> parse_run_entry(const ojson& entry, const std::string& where,
                                      const std::string& default_preset) {
  check_fields(entry, where,
               {"name", "group", "preset", "settings", "grid", "step_key", "step", "before",
                "baseline", "table", "mark"});
  SweepRun base;
  base.entry = where;
  base.preset = string_field(entry, "preset", where, default_preset);
  base.settings = settings_field(entry, where);
  base.baseline = bool_field(entry, "baseline", where, false);
  base.mark = bool_field(entry, "mark", where, false);
  base.before = string_field(entry, "before", where);
  base.step_key = string_field(entry, "step_key", where);
  const std::string name = string_field(entry, "name", where);
  const std::string group = string_field(entry, "group", where);

  std::vector<SweepRun> runs;
  if (!entry.contains("grid")) {
    SweepRun run = base;
    if (entry.contains("step")) run.step = value_text(entry["step"], where + ": 'step'");
    KFX_CHECK(run.step_key.empty() || !run.step.empty(),
              where << ": 'step_key' needs a 'step' value (or a 'grid')");
    if (!run.step.empty() && run.step_key.empty()) run.step_key = group.empty() ? "step" : group;
    run.name = !name.empty() ? name : !run.settings.empty() ? label_of(run.settings) : run.preset;
    run.group = group.empty() ? run.name : group;
    runs.push_back(run);
  } else {
    KFX_CHECK(!entry.contains("step"),
              where << ": 'step' is taken from the grid (name the grid key with 'step_key')");
    const ojson& grid = entry["grid"];
    KFX_CHECK(grid.is_object() && !grid.empty(),
              where << ": 'grid' must be a non-empty object of key: [values]");
    std::vector<std::string> keys;
    std::vector<std::vector<std::string>> values;
    for (const auto& item : grid.items()) {
      const std::string key_where = where + ": grid '" + item.key() + "'";
      KFX_CHECK(item.value().is_array() && !item.value().empty(),
                key_where << ": expected a non-empty list of values");
      keys.push_back(item.key());
      values.emplace_back();
      for (const auto& v : item.value()) values.back().push_back(value_text(v, key_where));
    }
    if (base.step_key.empty() && keys.size() == 1) base.step_key = keys[0];
    const auto step_index = std::find(keys.begin(), keys.end(), base.step_key) - keys.begin();
    KFX_CHECK(base.step_key.empty() || step_index < static_cast<long>(keys.size()),
              where << ": 'step_key' '" << base.step_key << "' is not a key of the grid");
    // Cartesian product, the first key varying slowest (nested loops in file order).
    std::vector<size_t> index(keys.size(), 0);
    while (true) {
      SweepRun run = base;
      Settings point;
      for (size_t k = 0; k < keys.size(); ++k) point.emplace_back(keys[k], values[k][index[k]]);
      for (const auto& s : point) run.settings.push_back(s);
      if (!base.step_key.empty()) run.step = point[step_index].second;
      if (name.empty()) {
        run.name = label_of(point);
      } else if (name.find('{') != std::string::npos) {
        run.name = substitute_name(name, point, where);
      } else {
        run.name = name + "/" + label_of(point);
      }
      run.group = !group.empty() ? group : keys.size() == 1 ? keys[0] : "grid";
      runs.push_back(run);
      size_t k = keys.size();
      while (k > 0 && ++index[k - 1] == values[k - 1].size()) index[--k] = 0;
      if (k == 0) break;
    }
  }
  for (auto& run : runs) {
    run.table = bool_field(entry, "table", where, !run.baseline && run.step.empty());
  }
  return runs;
}

bool valid_sequence_name(const std::string& name) {
  if (name.empty()) return false;
  for (char c : name) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) {
      return false;
    }
  }
  return true;
}

SweepSequence parse_sequence(const ojson& entry, const std::string& where) {
  check_fields(entry, where, {"name", "input", "settings", "variants"});
  SweepSequence sequence;
  sequence.name = string_field(entry, "name", where);
  KFX_CHECK(
      valid_sequence_name(sequence.name),
      where << ": 'name' must be letters, digits, '_', '-' or '.', got '" << sequence.name << "'");
  const std::string named = where + " (" + sequence.name + ")";
  sequence.input = string_field(entry, "input", named);
  KFX_CHECK(!sequence.input.empty(), named << ": 'input' is missing");
  sequence.settings = settings_field(entry, named);
  if (entry.contains("variants")) {
    const ojson& variants = entry["variants"];
    KFX_CHECK(variants.is_object(), named << ": 'variants' must be an object of name: {...}");
    for (const auto& item : variants.items()) {
      const std::string variant_where = named + ": variant '" + item.key() + "'";
      check_fields(item.value(), variant_where, {"input", "settings"});
      SweepInput variant;
      variant.input = string_field(item.value(), "input", variant_where, sequence.input);
      variant.settings = settings_field(item.value(), variant_where);
      sequence.variants[item.key()] = variant;
    }
  }
  return sequence;
}

/// Splits "key=value,key=value" where a part without '=' continues the previous value.
Settings split_assignments(const std::string& text, const std::string& what) {
  Settings out;
  std::stringstream stream(text);
  std::string part;
  while (std::getline(stream, part, ',')) {
    const auto eq = part.find('=');
    if (eq == std::string::npos) {
      KFX_CHECK(!out.empty(), what << ": '" << text << "' must be key=value,key=value");
      out.back().second += "," + part;
      continue;
    }
    KFX_CHECK(eq > 0, what << ": '" << part << "' has no setting name before '='");
    out.emplace_back(part.substr(0, eq), part.substr(eq + 1));
  }
  KFX_CHECK(!out.empty(), what << ": no key=value in '" << text << "'");
  return out;
}

std::string resolve_input(const std::string& root, const std::string& input) {
  if (input == "synthetic" || input.rfind("synthetic:", 0) == 0) return input;
  if (root.empty() || fs::path(input).is_absolute()) return input;
  return (fs::path(root) / input).lexically_normal().string();
}

/// A number for a CSV field: integers as integers, others with 6 significant digits.
std::string csv_value(const nlohmann::json& value) {
  if (value.is_null()) return "";
  if (value.is_string()) return value.get<std::string>();
  if (value.is_boolean()) return value.get<bool>() ? "true" : "false";
  if (value.is_number_integer() || value.is_number_unsigned()) return value.dump();
  if (value.is_number_float()) {
    char buffer[64];
    std::snprintf(buffer, sizeof(buffer), "%.6g", value.get<double>());
    return buffer;
  }
  return value.dump();
}

/// record[a][b]... or null.
nlohmann::json lookup(const nlohmann::json& record, const std::vector<std::string>& path) {
  const nlohmann::json* at = &record;
  for (const auto& key : path) {
    if (!at->is_object() || !at->contains(key)) return nullptr;
    at = &(*at)[key];
  }
  return *at;
}

/// Where each CSV column's value lives in a record.
std::vector<std::pair<std::string, std::vector<std::string>>> csv_layout() {
  std::vector<std::pair<std::string, std::vector<std::string>>> layout = {
      {"name", {"name"}},
      {"group", {"group"}},
      {"step_key", {"step_key"}},
      {"step", {"step"}},
      {"sequence", {"sequence"}},
      {"backend", {"backend"}},
      {"status", {"status"}},
      {"frames", {"frames"}},
      {"tracked", {"tracked"}},
      {"integrated", {"integrated"}},
      {"ate_rmse_m", {"ate_rmse_m"}},
      {"checkpos_mean_m", {"checkpos_mean_m"}},
      {"diverged_frames", {"diverged_frames"}},
      {"first_diverged_frame", {"first_diverged_frame"}},
      {"departure_frame", {"departure_frame"}},
      {"divergence_bound_m", {"divergence_bound_m"}},
      {"frames_per_second", {"frames_per_second"}},
      {"end_to_end_frames_per_second", {"end_to_end_frames_per_second"}},
      // Energy of the backend's device (see docs/sweep.md); empty where not measured.
      {"mj_per_frame", {"mj_per_frame"}},
      {"mj_per_frame_above_idle", {"mj_per_frame_above_idle"}},
      {"mean_watts", {"mean_watts"}},
      {"idle_watts", {"idle_watts"}},
      {"energy_method", {"energy_method"}},
      {"energy_budget", {"energy_budget"}},
      {"computation_ms_mean", {"computation_ms", "mean"}},
      {"computation_ms_median", {"computation_ms", "median"}},
  };
  for (int s = 0; s < static_cast<int>(Stage::kCount); ++s) {
    const std::string stage = stage_name(static_cast<Stage>(s));
    layout.push_back({stage + "_ms_mean", {"stages_ms", stage, "mean"}});
    layout.push_back({stage + "_ms_median", {"stages_ms", stage, "median"}});
  }
  for (const char* key : {"preset", "settings", "before", "baseline", "table", "mark", "input",
                          "device", "repeat", "commit", "date", "energy_note", "error"}) {
    layout.push_back({key, {key}});
  }
  return layout;
}

}  // namespace

SweepPlan parse_sweep_plan(const std::string& text, const std::string& origin,
                           const std::string& base_dir) {
  ojson root;
  try {
    root = ojson::parse(text);
  } catch (const ojson::parse_error& e) {
    // Line and column from the byte offset (nlohmann counts bytes from 1).
    const size_t end = std::min<size_t>(e.byte > 0 ? e.byte - 1 : 0, text.size());
    const size_t line = std::count(text.begin(), text.begin() + end, '\n') + 1;
    const size_t line_start = text.rfind('\n', end > 0 ? end - 1 : 0);
    const size_t column = line_start == std::string::npos || end == 0 ? end + 1 : end - line_start;
    KFX_FAIL(origin << ":" << line << ":" << column << ": malformed JSON: " << e.what());
  } catch (const ojson::exception& e) {  // e.g. a number beyond double's range (found by fuzzing)
    KFX_FAIL(origin << ": malformed JSON: " << e.what());
  }
  check_fields(root, origin,
               {"name", "description", "data_root", "baseline", "preset", "settings", "repeat",
                "warmup_frames", "max_mj_per_frame", "sequences", "runs"});
  SweepPlan plan;
  plan.path = origin;
  plan.name = string_field(root, "name", origin, fs::path(origin).stem().string());
  plan.description = string_field(root, "description", origin);
  plan.data_root = string_field(root, "data_root", origin);
  if (!plan.data_root.empty() && fs::path(plan.data_root).is_relative() && !base_dir.empty()) {
    plan.data_root = (fs::path(base_dir) / plan.data_root).lexically_normal().string();
  }
  plan.preset = string_field(root, "preset", origin, "exact");
  plan.settings = settings_field(root, origin);
  plan.repeat = int_field(root, "repeat", origin, 1, 1);
  plan.warmup_frames = int_field(root, "warmup_frames", origin, 10, 0);
  if (root.contains("max_mj_per_frame")) {
    KFX_CHECK(root["max_mj_per_frame"].is_number() && root["max_mj_per_frame"].get<double>() > 0,
              origin << ": 'max_mj_per_frame' must be a number > 0 (millijoules per frame)");
    plan.max_mj_per_frame = root["max_mj_per_frame"].get<double>();
  }

  KFX_CHECK(root.contains("sequences") && root["sequences"].is_array(),
            origin << ": 'sequences' must be a list of {name, input, settings, variants}");
  std::set<std::string> sequence_names;
  for (size_t i = 0; i < root["sequences"].size(); ++i) {
    const std::string where = origin + ": sequences[" + std::to_string(i) + "]";
    SweepSequence sequence = parse_sequence(root["sequences"][i], where);
    KFX_CHECK(sequence_names.insert(sequence.name).second,
              where << ": sequence '" << sequence.name << "' is named twice");
    plan.sequences.push_back(sequence);
  }

  KFX_CHECK(root.contains("runs") && root["runs"].is_array() && !root["runs"].empty(),
            origin << ": 'runs' must be a non-empty list of runs and grids");
  std::map<std::string, std::string> entry_of;  // run name → its entry, for duplicate messages
  for (size_t i = 0; i < root["runs"].size(); ++i) {
    const std::string where = origin + ": runs[" + std::to_string(i) + "]";
    const ojson& entry = root["runs"][i];
    // An entry of comments only is a heading between runs.
    bool comments_only = entry.is_object() && !entry.empty();
    for (const auto& item : entry.items()) comments_only &= is_comment_field(item.key());
    if (comments_only) continue;
    for (auto& run : parse_run_entry(root["runs"][i], where, plan.preset)) {
      KFX_CHECK(run.name.find('|') == std::string::npos && run.name.find('\n') == std::string::npos,
                where << ": run name '" << run.name << "' must not hold '|' or a line break");
      const auto [it, fresh] = entry_of.emplace(run.name, where);
      KFX_CHECK(fresh, where << ": run name '" << run.name << "' is already used by " << it->second
                             << "; give the entry a distinct 'name'");
      plan.runs.push_back(run);
    }
  }

  // The default 'before' run: the plan's 'baseline', else the first run marked baseline.
  plan.baseline = string_field(root, "baseline", origin);
  if (plan.baseline.empty()) {
    for (const auto& run : plan.runs) {
      if (run.baseline) {
        plan.baseline = run.name;
        break;
      }
    }
  }
  KFX_CHECK(plan.baseline.empty() || entry_of.count(plan.baseline),
            origin << ": 'baseline' names run '" << plan.baseline << "', which the plan lacks");
  for (size_t i = 0; i < plan.runs.size(); ++i) {
    auto& run = plan.runs[i];
    if (run.name == plan.baseline) run.baseline = true;
    if (run.before.empty() && !run.baseline) run.before = plan.baseline;
    KFX_CHECK(run.before.empty() || entry_of.count(run.before),
              run.entry << ": run '" << run.name << "' is compared against '" << run.before
                        << "' ('before'), which the plan lacks");
    KFX_CHECK(run.before != run.name,
              run.entry << ": run '" << run.name << "' cannot be its own 'before'");
    // A run without a comparison has no table row, whatever its entry said.
    if (run.before.empty()) run.table = false;
  }
  return plan;
}

SweepPlan read_sweep_plan(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  KFX_CHECK(in.good(), "cannot read sweep plan '" << path << "'");
  std::stringstream text;
  text << in.rdbuf();
  KFX_CHECK(!in.bad(), "error while reading sweep plan '" << path << "'");
  const std::string base_dir = fs::path(path).parent_path().string();
  return parse_sweep_plan(text.str(), path, base_dir.empty() ? "." : base_dir);
}

std::pair<std::string, Settings> parse_sequence_settings(const std::string& text) {
  const auto colon = text.find(':');
  KFX_CHECK(colon != std::string::npos && colon > 0,
            "--sequence-settings '" << text << "' must be name:key=value,key=value");
  const std::string name = text.substr(0, colon);
  return {name, split_assignments(text.substr(colon + 1), "--sequence-settings '" + name + "'")};
}

Settings parse_settings_list(const std::string& text, const std::string& what) {
  return split_assignments(text, what);
}

std::vector<ResolvedSequence> resolve_sequences(const SweepPlan& plan,
                                                const SequenceOptions& options) {
  const std::string root = !options.data_root.empty() ? options.data_root : plan.data_root;
  auto find = [&plan](const std::string& name) -> const SweepSequence* {
    for (const auto& s : plan.sequences) {
      if (s.name == name) return &s;
    }
    return nullptr;
  };
  std::string known;
  for (const auto& s : plan.sequences) known += (known.empty() ? "" : ", ") + s.name;

  // Which sequences, in which order, with which path overrides.
  std::vector<std::pair<std::string, std::string>> chosen;  // name, path override
  if (options.sequences.empty()) {
    for (const auto& s : plan.sequences) chosen.emplace_back(s.name, "");
  } else {
    for (const auto& item : options.sequences) {
      const auto eq = item.find('=');
      const std::string name = item.substr(0, eq);
      const std::string path = eq == std::string::npos ? "" : item.substr(eq + 1);
      KFX_CHECK(valid_sequence_name(name),
                "--sequences: '" << name << "' is not a sequence name (name or name=path)");
      KFX_CHECK(find(name) || !path.empty(), "--sequences: the plan has no sequence '"
                                                 << name << "' (it has: " << known
                                                 << "); give a path with " << name
                                                 << "=PATH to add one");
      for (const auto& c : chosen) {
        KFX_CHECK(c.first != name, "--sequences: '" << name << "' is listed twice");
      }
      KFX_CHECK(eq == std::string::npos || !path.empty(),
                "--sequences: '" << item << "' has an empty path");
      chosen.emplace_back(name, path);
    }
  }
  KFX_CHECK(!chosen.empty(), plan.path << ": the plan lists no sequences; add some or name them "
                                          "with --sequences name=path");

  // Per-sequence extra settings from the command line; every name must be known.
  std::vector<std::pair<std::string, Settings>> extra;
  for (const auto& text : options.sequence_settings) {
    auto parsed = parse_sequence_settings(text);
    const bool known_name = parsed.first == "*" || find(parsed.first) ||
                            std::any_of(chosen.begin(), chosen.end(), [&parsed](const auto& c) {
                              return c.first == parsed.first;
                            });
    KFX_CHECK(known_name, "--sequence-settings: no sequence '"
                              << parsed.first << "' (known: " << known << ", or * for all)");
    extra.push_back(std::move(parsed));
  }

  std::vector<ResolvedSequence> out;
  for (const auto& [name, path] : chosen) {
    ResolvedSequence resolved;
    resolved.name = name;
    resolved.settings = plan.settings;
    const SweepSequence* sequence = find(name);
    std::string input = path;
    if (sequence) {
      for (const auto& s : sequence->settings) resolved.settings.push_back(s);
      std::string plan_input = sequence->input;
      if (!options.variant.empty()) {
        const auto it = sequence->variants.find(options.variant);
        std::string variants;
        for (const auto& v : sequence->variants)
          variants += (variants.empty() ? "" : ", ") + v.first;
        KFX_CHECK(it != sequence->variants.end(),
                  "sequence '" << name << "' has no input variant '" << options.variant
                               << "' (it has: " << (variants.empty() ? "none" : variants) << ")");
        plan_input = it->second.input;
        for (const auto& s : it->second.settings) resolved.settings.push_back(s);
      }
      if (input.empty()) input = resolve_input(root, plan_input);
    }
    resolved.input = input;
    for (const auto& [target, settings] : extra) {
      if (target != "*" && target != name) continue;
      for (const auto& s : settings) resolved.settings.push_back(s);
    }
    out.push_back(resolved);
  }
  return out;
}

std::vector<std::string> run_assignments(const SweepRun& run, const ResolvedSequence& sequence,
                                         const Settings& overrides) {
  std::vector<std::string> out;
  for (const auto& [k, v] : sequence.settings) out.push_back(k + "=" + v);
  for (const auto& [k, v] : run.settings) out.push_back(k + "=" + v);
  for (const auto& [k, v] : overrides) out.push_back(k + "=" + v);
  return out;
}

PipelineConfig build_config(const SweepRun& run, const ResolvedSequence& sequence,
                            const Settings& overrides) {
  const std::string where =
      run.entry + ": run '" + run.name + "' on sequence '" + sequence.name + "'";
  PipelineConfig config;
  try {
    config = make_preset(run.preset);
  } catch (const Error& e) {
    KFX_FAIL(where << ": " << e.what());
  }
  for (const auto& assignment : run_assignments(run, sequence, overrides)) {
    try {
      set_config_assignment(config, assignment);
    } catch (const Error& e) {
      KFX_FAIL(where << ": " << e.what());
    }
  }
  try {
    config.validate();
  } catch (const Error& e) {
    KFX_FAIL(where << ": invalid configuration: " << e.what());
  }
  return config;
}

std::vector<std::string> validate_sweep(const std::vector<const SweepRun*>& runs,
                                        const std::vector<ResolvedSequence>& sequences,
                                        const Settings& overrides) {
  std::vector<std::string> warnings;
  std::set<std::string> warned;
  for (const SweepRun* run : runs) {
    // What the preset sets, by key (empty for exact).
    const auto values = kfx::preset_values(run->preset);
    const std::map<std::string, std::string> preset_values(values.begin(), values.end());
    for (const auto& sequence : sequences) {
      build_config(*run, sequence, overrides);
      // A sequence setting silently undoing a preset's choice would mislabel the result.
      for (const auto& [key, value] : sequence.settings) {
        const auto chosen = preset_values.find(key);
        if (chosen == preset_values.end()) continue;
        const std::string id = run->preset + "|" + sequence.name + "|" + key;
        if (!warned.insert(id).second) continue;
        warnings.push_back("sequence '" + sequence.name + "' sets " + key + "=" + value +
                           ", overriding preset '" + run->preset + "''s " + key + "=" +
                           chosen->second);
      }
    }
  }
  return warnings;
}

std::vector<const SweepRun*> select_runs(const SweepPlan& plan,
                                         const std::vector<std::string>& only) {
  std::set<std::string> wanted;
  for (const auto& item : only) {
    const bool matches = std::any_of(plan.runs.begin(), plan.runs.end(), [&item](const auto& r) {
      return r.name == item || r.group == item;
    });
    std::set<std::string> groups;
    for (const auto& r : plan.runs) groups.insert(r.group);
    std::string known;
    for (const auto& g : groups) known += (known.empty() ? "" : ", ") + g;
    KFX_CHECK(matches, "--only: no run or group named '" << item << "' (groups: " << known << ")");
  }
  for (const auto& run : plan.runs) {
    const bool chosen = only.empty() ||
                        std::find(only.begin(), only.end(), run.name) != only.end() ||
                        std::find(only.begin(), only.end(), run.group) != only.end();
    if (chosen) wanted.insert(run.name);
  }
  // Add what the chosen runs are compared against, transitively.
  for (bool grew = true; grew;) {
    grew = false;
    for (const auto& run : plan.runs) {
      if (wanted.count(run.name) && !run.before.empty() && wanted.insert(run.before).second) {
        grew = true;
      }
    }
  }
  std::vector<const SweepRun*> out;
  for (const auto& run : plan.runs) {
    if (wanted.count(run.name)) out.push_back(&run);
  }
  return out;
}

std::string result_key(const std::string& run, const std::string& sequence,
                       const std::string& backend) {
  return run + "|" + sequence + "|" + backend;
}

std::string result_key(const nlohmann::json& record) {
  auto text = [&record](const char* key) {
    return record.contains(key) && record[key].is_string() ? record[key].get<std::string>() : "";
  };
  return result_key(text("name"), text("sequence"), text("backend"));
}

std::vector<nlohmann::json> read_results_log(const std::string& path, int* dropped_lines) {
  if (dropped_lines) *dropped_lines = 0;
  std::vector<nlohmann::json> records;
  std::error_code error;
  if (!fs::exists(path, error)) return records;
  std::ifstream in(path);
  KFX_CHECK(in.good(), "cannot read results log '" << path << "'");
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  for (size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].find_first_not_of(" \t\r") == std::string::npos) continue;
    nlohmann::json record;
    try {
      record = nlohmann::json::parse(lines[i]);
      KFX_CHECK(record.is_object(), "not a JSON object");
    } catch (const std::exception& e) {
      // Only the last line can be cut short by an interrupted write.
      const bool last = i + 1 == lines.size();
      KFX_CHECK(last, "results log '" << path << "' line " << i + 1 << " is malformed (" << e.what()
                                      << "); fix or delete that line to resume");
      if (dropped_lines) ++*dropped_lines;
      continue;
    }
    records.push_back(std::move(record));
  }
  return records;
}

std::vector<nlohmann::json> latest_results(const std::vector<nlohmann::json>& records) {
  std::vector<nlohmann::json> out;
  std::map<std::string, size_t> position;
  for (const auto& record : records) {
    const std::string key = result_key(record);
    const auto it = position.find(key);
    if (it == position.end()) {
      position[key] = out.size();
      out.push_back(record);
    } else {
      out[it->second] = record;
    }
  }
  return out;
}

bool result_is_current(const nlohmann::json& record, const std::string& preset,
                       const std::vector<std::string>& assignments, int max_frames) {
  if (lookup(record, {"status"}) != "ok") return false;
  if (lookup(record, {"preset"}) != preset) return false;
  // A preset chosen again between kfx versions keeps its name: compare what it sets. Records
  // written before this field existed are run again once.
  if (lookup(record, {"preset_settings"}) != nlohmann::json(preset_settings(preset))) return false;
  if (lookup(record, {"assignments"}) != nlohmann::json(assignments)) return false;
  return lookup(record, {"max_frames"}) == max_frames;
}

std::vector<std::string> csv_columns() {
  std::vector<std::string> columns;
  for (const auto& [name, path] : csv_layout()) columns.push_back(name);
  return columns;
}

std::string csv_escape(const std::string& field) {
  if (field.find_first_of(",\"\r\n") == std::string::npos) return field;
  std::string out = "\"";
  for (char c : field) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

std::string csv_row(const nlohmann::json& record) {
  std::string line;
  bool first = true;
  for (const auto& [name, path] : csv_layout()) {
    nlohmann::json value = lookup(record, path);
    std::string text;
    if (value.is_array()) {
      // Lists ("settings": the run's own key=value, in order) as space-separated items.
      for (const auto& item : value) text += (text.empty() ? "" : " ") + csv_value(item);
    } else {
      text = csv_value(value);
    }
    line += (first ? "" : ",") + csv_escape(text);
    first = false;
  }
  return line;
}

std::string results_csv(const std::vector<nlohmann::json>& records) {
  std::string out;
  bool first = true;
  for (const auto& column : csv_columns()) {
    out += (first ? "" : ",") + csv_escape(column);
    first = false;
  }
  out += "\n";
  for (const auto& record : records) out += csv_row(record) + "\n";
  return out;
}

}  // namespace kfx::sweep
