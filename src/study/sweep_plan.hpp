#pragma once
/// Sweep plans for `kfx sweep` (docs/sweep.md): a JSON file naming sequences and a list or grid
/// of configurations; parsing, up-front validation of every configuration × sequence, and the
/// results bookkeeping a resumable sweep needs (run keys, the JSON-lines log, CSV rows).
///
/// Generic over settings: a configuration is a preset plus `key=value` assignments, applied
/// through set_config_value(), so any key of the config table can be swept.

#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "pipeline/config.hpp"

namespace kfx::sweep {

/// Ordered `key → value` settings, applied first to last.
using Settings = std::vector<std::pair<std::string, std::string>>;

/// One named configuration of a sweep.
struct SweepRun {
  std::string name;       ///< unique within the plan; names the run in results and plots
  std::string group;      ///< technique or sweep it belongs to ("integrate", "presets", ...)
  std::string preset;     ///< preset it starts from
  Settings settings;      ///< applied over the preset, the plan's and the sequence's settings
  std::string step_key;   ///< the setting a step sweep varies ("" = not part of a step sweep)
  std::string step;       ///< that setting's value in this run ("" = not part of a step sweep)
  std::string before;     ///< run this one is compared against in before/after tables ("")
  bool baseline = false;  ///< a reference run (the plan's default `before`)
  bool table = false;     ///< a row of the per-technique before/after tables
  bool mark = false;      ///< marked and labelled in the Pareto plot (presets)
  std::string entry;      ///< where in the plan it came from, for messages: "runs[3]"
};

/// Where a sequence's frames come from, and the settings that go with that form of the data.
struct SweepInput {
  std::string input;  ///< path (relative paths resolve against the data root) or synthetic:...
  Settings settings;  ///< applied after the sequence's own settings
};

/// A sequence of a plan.
struct SweepSequence {
  std::string name;   ///< unique, [A-Za-z0-9_.-]+
  std::string input;  ///< default input (see SweepInput::input)
  Settings settings;  ///< settings every run on this sequence gets (intrinsics, volume, ...)
  std::map<std::string, SweepInput> variants;  ///< other forms of the data, by variant name
};

/// A parsed sweep plan.
struct SweepPlan {
  std::string path;         ///< file it was read from ("" when parsed from text)
  std::string name;         ///< plan name (default: the file name without extension)
  std::string description;  ///< free text
  std::string data_root;    ///< root for relative inputs, resolved against the plan's folder
  std::string baseline;     ///< default `before` run ("" = none)
  std::string preset;       ///< default preset of runs
  Settings settings;        ///< settings every run gets, before the sequence's
  int repeat = 1;           ///< timed passes per run
  int warmup_frames = 10;   ///< untimed frames before the timed passes
  /// Energy budget: runs using more device millijoules per frame are marked "over" (0 = none).
  double max_mj_per_frame = 0;
  std::vector<SweepSequence> sequences;
  std::vector<SweepRun> runs;  ///< in plan order, grids expanded
};

/// Parses a plan from JSON text. `origin` names the text in messages (a file path); relative
/// `data_root` resolves against `base_dir`. Throws kfx::Error naming the origin and line for
/// malformed JSON, and the entry and field for anything else wrong (unknown field, duplicate
/// name, unknown `before`, grid without values, ...). Settings are NOT checked here: see
/// validate_sweep().
SweepPlan parse_sweep_plan(const std::string& text, const std::string& origin = "plan",
                           const std::string& base_dir = "");

/// Reads and parses a plan file; throws kfx::Error naming the file when it cannot be read.
SweepPlan read_sweep_plan(const std::string& path);

/// The command line's choice of sequences (all optional).
struct SequenceOptions {
  std::string data_root;  ///< overrides the plan's data root ("" = keep)
  std::string variant;    ///< use each sequence's input variant of this name ("" = default)
  /// Which sequences run, in order: "name" or "name=path" (path overrides the input; a name
  /// the plan lacks with a path adds a sequence with no settings). Empty = all, plan order.
  std::vector<std::string> sequences;
  /// Extra settings per sequence: "name:key=value,key=value" ("*:..." = every sequence).
  std::vector<std::string> sequence_settings;
  Settings overrides;  ///< `--set`: applied last, to every run
};

/// A sequence ready to run: its resolved input and all settings that come with it.
struct ResolvedSequence {
  std::string name;
  std::string input;  ///< path resolved against the data root, or synthetic:...
  Settings settings;  ///< plan settings, sequence settings, variant settings, command line
};

/// Resolves the sequences to run; throws kfx::Error on an unknown name or variant.
std::vector<ResolvedSequence> resolve_sequences(const SweepPlan& plan,
                                                const SequenceOptions& options);

/// Parses "name:key=value,key=value": values may hold commas ("camera=1,2,3,4"), since a part
/// without '=' continues the previous value. Throws kfx::Error on malformed text.
std::pair<std::string, Settings> parse_sequence_settings(const std::string& text);

/// Parses "key=value,key=value" with the same comma rule; throws on malformed text.
Settings parse_settings_list(const std::string& text, const std::string& what);

/// The `key=value` assignments of `run` on `sequence`, in the order they apply: the sequence's
/// (which include the plan's), then the run's, then `overrides`.
std::vector<std::string> run_assignments(const SweepRun& run, const ResolvedSequence& sequence,
                                         const Settings& overrides = {});

/// The configuration of `run` on `sequence` (reader recommendations aside): preset, then
/// run_assignments(); validated. Throws kfx::Error naming the run, its plan entry, the sequence
/// and the failing setting.
PipelineConfig build_config(const SweepRun& run, const ResolvedSequence& sequence,
                            const Settings& overrides = {});

/// Checks every run × sequence with build_config() before anything runs, so a typo fails in a
/// second, not hours into a sweep. Returns warnings (e.g. a sequence setting overriding a
/// value the run's preset chose).
std::vector<std::string> validate_sweep(const std::vector<const SweepRun*>& runs,
                                        const std::vector<ResolvedSequence>& sequences,
                                        const Settings& overrides = {});

/// The runs whose name or group is in `only` (all when empty), plus the runs they are
/// compared against (`before`, transitively), in plan order. Throws when an `only` entry
/// matches nothing.
std::vector<const SweepRun*> select_runs(const SweepPlan& plan,
                                         const std::vector<std::string>& only);

// ---------------------------------------------------------------------------------------------
// Results.

/// The identity of one result: "run|sequence|backend".
std::string result_key(const std::string& run, const std::string& sequence,
                       const std::string& backend);

/// The key of a result record (its "name", "sequence" and "backend").
std::string result_key(const nlohmann::json& record);

/// Records of a JSON-lines results log, in file order; a missing file gives none. A malformed
/// LAST line (an interrupted write) is dropped and counted in `dropped_lines`; a malformed
/// line elsewhere throws kfx::Error naming the file and line.
std::vector<nlohmann::json> read_results_log(const std::string& path, int* dropped_lines = nullptr);

/// The latest record of each key, in the order keys first appear.
std::vector<nlohmann::json> latest_results(const std::vector<nlohmann::json>& records);

/// Whether `record` already answers a run with these settings: it succeeded, and its preset
/// (name and what it sets today, preset_settings()), assignments and frame limit equal the
/// given ones. Changed settings, a preset defined differently since, or a failure mean the run
/// must be done again.
bool result_is_current(const nlohmann::json& record, const std::string& preset,
                       const std::vector<std::string>& assignments, int max_frames);

/// The CSV columns, in order: identity, status, accuracy, speed, per-stage times, settings.
std::vector<std::string> csv_columns();

/// One CSV field, quoted (RFC 4180) when it holds a comma, quote, or line break.
std::string csv_escape(const std::string& field);

/// One CSV line (no line break) of a result record, in csv_columns() order; absent values
/// are empty fields.
std::string csv_row(const nlohmann::json& record);

/// A whole CSV file: header line, then one line per record.
std::string results_csv(const std::vector<nlohmann::json>& records);

}  // namespace kfx::sweep
