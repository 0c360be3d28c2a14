/// `kfx sweep`: plan parsing (lists, grids, errors that name the entry, key, file and line),
/// sequence resolution, resume bookkeeping, CSV rows, and a tiny sweep through the real binary
/// that must resume without running anything again.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "core/platform.hpp"
#include "study/sweep_plan.hpp"
#include "support/cli_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx::sweep {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// The message of the kfx::Error that `f` throws ("" when it throws none).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::vector<std::string> names_of(const SweepPlan& plan) {
  std::vector<std::string> names;
  for (const auto& run : plan.runs) names.push_back(run.name);
  return names;
}

/// Splits one CSV line (RFC 4180 quoting) into fields.
std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        fields.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

const char* kListPlan = R"({
  "name": "list",
  "baseline": "exact",
  "sequences": [{"name": "synth", "input": "synthetic:frames=4"}],
  "runs": [
    {"name": "exact", "preset": "exact", "mark": true},
    {"name": "fewer_levels", "group": "tracking", "settings": {"pyramid_iterations": "5,3"}},
    {"group": "integration", "settings": {"integration_rate": 4, "volume_resolution": [128]}},
    {"name": "stepped", "group": "int", "step": 3, "settings": {"integration_rate": 3},
     "before": "fewer_levels"}
  ]
})";

TEST(SweepPlan, ParsesAnExplicitList) {
  const SweepPlan plan = parse_sweep_plan(kListPlan, "list.json");
  EXPECT_EQ(plan.name, "list");
  EXPECT_EQ(plan.baseline, "exact");
  ASSERT_EQ(plan.runs.size(), 4u);
  EXPECT_EQ(names_of(plan),
            (std::vector<std::string>{"exact", "fewer_levels",
                                      "integration_rate=4+volume_resolution=128", "stepped"}));
  const SweepRun& exact = plan.runs[0];
  EXPECT_TRUE(exact.baseline);
  EXPECT_TRUE(exact.mark);
  EXPECT_TRUE(exact.before.empty());
  EXPECT_FALSE(exact.table);  // the baseline is the "before" column, not a row
  const SweepRun& levels = plan.runs[1];
  EXPECT_EQ(levels.group, "tracking");
  EXPECT_EQ(levels.preset, "exact");
  EXPECT_EQ(levels.before, "exact");
  EXPECT_TRUE(levels.table);
  EXPECT_TRUE(levels.step.empty());
  // Numbers and lists become the text set_config_value() reads, in the file's order.
  EXPECT_EQ(plan.runs[2].settings,
            (Settings{{"integration_rate", "4"}, {"volume_resolution", "128"}}));
  const SweepRun& stepped = plan.runs[3];
  EXPECT_EQ(stepped.step, "3");
  EXPECT_EQ(stepped.step_key, "int");
  EXPECT_EQ(stepped.before, "fewer_levels");
  EXPECT_FALSE(stepped.table);  // a step-sweep point is plotted, not tabulated
  EXPECT_EQ(stepped.entry, "list.json: runs[3]");
}

TEST(SweepPlan, GridIsTheCartesianProductFirstKeySlowest) {
  const SweepPlan plan = parse_sweep_plan(R"({
    "sequences": [{"name": "s", "input": "synthetic"}],
    "runs": [
      {"name": "exact", "baseline": true},
      {"group": "g", "step_key": "integration_rate",
       "settings": {"volume_resolution": 64},
       "grid": {"integration_rate": [1, 2, 3], "pyramid_iterations": ["10,5,4", [2]]}},
      {"name": "ir{integration_rate}", "grid": {"integration_rate": [5, 6]}},
      {"name": "prefix", "grid": {"compute_size_ratio": [1]}}
    ]
  })");
  ASSERT_EQ(plan.runs.size(), 1u + 6u + 2u + 1u);
  EXPECT_EQ(
      names_of(plan),
      (std::vector<std::string>{
          "exact", "integration_rate=1+pyramid_iterations=10,5,4",
          "integration_rate=1+pyramid_iterations=2", "integration_rate=2+pyramid_iterations=10,5,4",
          "integration_rate=2+pyramid_iterations=2", "integration_rate=3+pyramid_iterations=10,5,4",
          "integration_rate=3+pyramid_iterations=2", "ir5", "ir6", "prefix/compute_size_ratio=1"}));
  const SweepRun& point = plan.runs[4];
  EXPECT_EQ(point.group, "g");
  EXPECT_EQ(point.step_key, "integration_rate");
  EXPECT_EQ(point.step, "2");
  EXPECT_EQ(point.settings, (Settings{{"volume_resolution", "64"},
                                      {"integration_rate", "2"},
                                      {"pyramid_iterations", "2"}}));
  EXPECT_EQ(point.before, "exact");  // the first run marked baseline
  // A single-key grid is a step sweep over that key, grouped under it by default.
  EXPECT_EQ(plan.runs[7].group, "integration_rate");
  EXPECT_EQ(plan.runs[7].step_key, "integration_rate");
  EXPECT_EQ(plan.runs[7].step, "5");
}

TEST(SweepPlan, BadSettingFailsUpFrontNamingEntryRunAndKey) {
  const SweepPlan plan = parse_sweep_plan(R"({
    "sequences": [{"name": "a", "input": "synthetic"}, {"name": "b", "input": "synthetic"}],
    "runs": [{"name": "exact"},
             {"name": "typo", "settings": {"integration_rat": 2}}]
  })",
                                          "p.json");
  const auto sequences = resolve_sequences(plan, {});
  const std::string message = error_of([&] { validate_sweep(select_runs(plan, {}), sequences); });
  EXPECT_NE(message.find("p.json: runs[1]"), std::string::npos) << message;
  EXPECT_NE(message.find("'typo'"), std::string::npos) << message;
  EXPECT_NE(message.find("unknown setting 'integration_rat'"), std::string::npos) << message;

  // A known key with a value validate() refuses is named too.
  const SweepPlan bad_value = parse_sweep_plan(R"({
    "sequences": [{"name": "a", "input": "synthetic"}],
    "runs": [{"grid": {"volume_resolution": [64, 3]}}]
  })",
                                               "v.json");
  const std::string value_message = error_of(
      [&] { validate_sweep(select_runs(bad_value, {}), resolve_sequences(bad_value, {})); });
  EXPECT_NE(value_message.find("v.json: runs[0]"), std::string::npos) << value_message;
  EXPECT_NE(value_message.find("volume_resolution=3"), std::string::npos) << value_message;
  EXPECT_NE(value_message.find("volume_resolution must be in 8..1024"), std::string::npos)
      << value_message;

  // A bad setting of a sequence fails for that sequence.
  const SweepPlan bad_sequence = parse_sweep_plan(R"({
    "sequences": [{"name": "seq1", "input": "synthetic", "settings": {"camera": "1,2"}}],
    "runs": [{"name": "exact"}]
  })");
  const std::string sequence_message = error_of(
      [&] { validate_sweep(select_runs(bad_sequence, {}), resolve_sequences(bad_sequence, {})); });
  EXPECT_NE(sequence_message.find("sequence 'seq1'"), std::string::npos) << sequence_message;
  EXPECT_NE(sequence_message.find("camera"), std::string::npos) << sequence_message;

  // Unknown presets, too.
  const SweepPlan bad_preset = parse_sweep_plan(R"({
    "sequences": [{"name": "a", "input": "synthetic"}],
    "runs": [{"name": "x", "preset": "fastest"}]
  })");
  EXPECT_NE(error_of([&] {
              validate_sweep(select_runs(bad_preset, {}), resolve_sequences(bad_preset, {}));
            }).find("unknown preset 'fastest'"),
            std::string::npos);
}

TEST(SweepPlan, MalformedJsonNamesFileLineAndColumn) {
  const std::string text = "{\n  \"sequences\": [],\n  \"runs\": [ {\"name\": \"a\",, } ]\n}\n";
  const std::string message = error_of([&] { parse_sweep_plan(text, "bench/x.json"); });
  EXPECT_NE(message.find("bench/x.json:3:"), std::string::npos) << message;
  EXPECT_NE(message.find("malformed JSON"), std::string::npos) << message;

  const std::string missing = error_of([] { read_sweep_plan("/nonexistent/plan.json"); });
  EXPECT_NE(missing.find("/nonexistent/plan.json"), std::string::npos) << missing;

  // read_sweep_plan names the file it read in the line-numbered message.
  const fs::path path = fs::temp_directory_path() / "kfx_sweep_bad_plan.json";
  std::ofstream(path) << "{\n\n  \"runs\": [\n}\n";
  const std::string from_file = error_of([&] { read_sweep_plan(path.string()); });
  EXPECT_NE(from_file.find(path.string() + ":4:"), std::string::npos) << from_file;
  fs::remove(path);
}

TEST(SweepPlan, StructuralMistakesNameTheEntry) {
  const struct {
    const char* runs;
    const char* expect;
  } cases[] = {
      {R"([{"name": "a", "settngs": {}}])", "runs[0]: unknown field 'settngs'"},
      {R"([{"name": "a"}, {"name": "a"}])", "run name 'a' is already used by p: runs[0]"},
      {R"([{"name": "a", "before": "nope"}])", "'nope' ('before'), which the plan lacks"},
      {R"([{"name": "a", "grid": {"integration_rate": []}}])", "non-empty list"},
      {R"([{"name": "a", "grid": {"integration_rate": [1]}, "step": 1}])", "'step' is taken"},
      {R"([{"name": "a", "grid": {"integration_rate": [1]}, "step_key": "x"}])",
       "'step_key' 'x' is not a key of the grid"},
      {R"([{"name": "n{x}", "grid": {"integration_rate": [1]}}])", "not a key of the grid"},
      {R"([{"name": "a", "settings": {"integration_rate": {"x": 1}}}])", "expected a string"},
      {R"([])", "'runs' must be a non-empty list"},
  };
  for (const auto& c : cases) {
    const std::string text = std::string(R"({"sequences": [{"name": "s", "input": "synthetic"}],
                                             "runs": )") +
                             c.runs + "}";
    const std::string message = error_of([&] { parse_sweep_plan(text, "p"); });
    EXPECT_NE(message.find(c.expect), std::string::npos) << c.runs << " -> " << message;
  }
  EXPECT_NE(error_of([] {
              parse_sweep_plan(R"({"sequences": [], "runs": [{"name": "a"}], "baseline": "b"})");
            }).find("'baseline' names run 'b'"),
            std::string::npos);
  EXPECT_NE(error_of([] {
              parse_sweep_plan(R"({"sequences": [{"name": "a b", "input": "x"}], "runs": [{}]})");
            }).find("'name' must be letters"),
            std::string::npos);
}

const char* kSequencePlan = R"({
  "data_root": "data",
  "settings": {"integration_rate": 1},
  "sequences": [
    {"name": "icl", "input": "icl_office_kt0", "settings": {"camera": [481.2, 480, 320, 240]},
     "variants": {"raw320": {"input": "icl_office_kt0.raw",
                             "settings": {"compute_size_ratio": 1,
                                          "camera": "240.6,240,160,120"}}}},
    {"name": "tum", "input": "/abs/tum", "settings": {"volume_size_m": 4}}
  ],
  "runs": [{"name": "exact"}]
})";

TEST(SweepPlan, SequencesResolveRootVariantsAndCommandLine) {
  const SweepPlan plan = parse_sweep_plan(kSequencePlan, "bench/sweeps/p.json", "bench/sweeps");
  EXPECT_EQ(plan.data_root, "bench/sweeps/data");

  auto all = resolve_sequences(plan, {});
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0].input, "bench/sweeps/data/icl_office_kt0");
  EXPECT_EQ(all[1].input, "/abs/tum");  // absolute paths stay as they are
  EXPECT_EQ(all[0].settings,
            (Settings{{"integration_rate", "1"}, {"camera", "481.2,480,320,240"}}));

  SequenceOptions options;
  options.data_root = "/tmp/kfx_data";
  options.variant = "raw320";
  options.sequences = {"icl"};
  options.sequence_settings = {"icl:max_weight=50,camera=1,2,3,4", "*:mu_m=0.05"};
  auto raw = resolve_sequences(plan, options);
  ASSERT_EQ(raw.size(), 1u);
  EXPECT_EQ(raw[0].input, "/tmp/kfx_data/icl_office_kt0.raw");
  EXPECT_EQ(raw[0].settings, (Settings{{"integration_rate", "1"},
                                       {"camera", "481.2,480,320,240"},
                                       {"compute_size_ratio", "1"},
                                       {"camera", "240.6,240,160,120"},
                                       {"max_weight", "50"},
                                       {"camera", "1,2,3,4"},
                                       {"mu_m", "0.05"}}));

  // name=path overrides the input and keeps the sequence's settings; order follows the list;
  // a new name with a path adds a sequence.
  SequenceOptions paths;
  paths.sequences = {"tum=/x/tum.raw", "extra=synthetic:frames=3"};
  auto chosen = resolve_sequences(plan, paths);
  ASSERT_EQ(chosen.size(), 2u);
  EXPECT_EQ(chosen[0].name, "tum");
  EXPECT_EQ(chosen[0].input, "/x/tum.raw");
  EXPECT_EQ(chosen[0].settings, (Settings{{"integration_rate", "1"}, {"volume_size_m", "4"}}));
  EXPECT_EQ(chosen[1].input, "synthetic:frames=3");

  // The variant must exist for every chosen plan sequence.
  SequenceOptions missing_variant;
  missing_variant.variant = "raw320";
  EXPECT_NE(error_of([&] {
              resolve_sequences(plan, missing_variant);
            }).find("sequence 'tum' has no input variant 'raw320'"),
            std::string::npos);
  SequenceOptions unknown;
  unknown.sequences = {"office"};
  EXPECT_NE(error_of([&] { resolve_sequences(plan, unknown); }).find("no sequence 'office'"),
            std::string::npos);
  SequenceOptions unknown_settings;
  unknown_settings.sequence_settings = {"office:mu_m=1"};
  EXPECT_NE(error_of([&] {
              resolve_sequences(plan, unknown_settings);
            }).find("--sequence-settings: no sequence 'office'"),
            std::string::npos);
}

TEST(SweepPlan, SequenceSettingsTextKeepsCommasInValues) {
  const auto [name, settings] =
      parse_sequence_settings("tum_fr1_xyz:camera=258.65,258.25,159.3,127.65,compute_size_ratio=1");
  EXPECT_EQ(name, "tum_fr1_xyz");
  EXPECT_EQ(settings,
            (Settings{{"camera", "258.65,258.25,159.3,127.65"}, {"compute_size_ratio", "1"}}));
  EXPECT_FALSE(error_of([] { parse_sequence_settings("camera=1,2"); }).empty());
  EXPECT_FALSE(error_of([] { parse_sequence_settings("a:1,2"); }).empty());
  EXPECT_FALSE(error_of([] { parse_sequence_settings("a:=1"); }).empty());
}

TEST(SweepPlan, OnlySelectsGroupsAndTheirBaselines) {
  const SweepPlan plan = parse_sweep_plan(kListPlan);
  const auto chosen = select_runs(plan, {"int"});
  ASSERT_EQ(chosen.size(), 3u);  // stepped, its before (fewer_levels) and that one's (exact)
  EXPECT_EQ(chosen[0]->name, "exact");
  EXPECT_EQ(chosen[1]->name, "fewer_levels");
  EXPECT_EQ(chosen[2]->name, "stepped");
  EXPECT_EQ(select_runs(plan, {"exact"}).size(), 1u);
  EXPECT_EQ(select_runs(plan, {}).size(), 4u);
  EXPECT_NE(error_of([&] { select_runs(plan, {"nope"}); }).find("no run or group named 'nope'"),
            std::string::npos);
}

TEST(SweepPlan, WarnsWhenASequenceOverridesAPresetChoice) {
  // Any preset other than exact that differs from it in some setting.
  for (const auto& preset : preset_names()) {
    if (preset == "exact") continue;
    const PipelineConfig exact = make_preset("exact");
    const PipelineConfig other = make_preset(preset);
    for (const auto& field : config_fields()) {
      if (field.format(other) == field.format(exact)) continue;
      SweepRun run;
      run.name = "p";
      run.preset = preset;
      ResolvedSequence sequence{"s", "synthetic", {{field.key, field.format(exact)}}};
      const auto warnings = validate_sweep({&run}, {sequence});
      ASSERT_EQ(warnings.size(), 1u);
      EXPECT_NE(warnings[0].find("overriding preset '" + preset + "'"), std::string::npos);
      // No warning when the sequence does not touch what the preset sets.
      ResolvedSequence plain{"s", "synthetic", {}};
      EXPECT_TRUE(validate_sweep({&run}, {plain}).empty());
      return;
    }
  }
  GTEST_SKIP() << "no preset other than exact changes a setting";
}

// ---------------------------------------------------------------------------------------------
// Resume bookkeeping and CSV.

json ok_record(const std::string& name, const std::vector<std::string>& assignments) {
  return {{"name", name},    {"sequence", "s"},           {"backend", "cpu"},
          {"status", "ok"},  {"preset", "exact"},         {"assignments", assignments},
          {"max_frames", 0}, {"frames_per_second", 10.5}, {"preset_settings", json::array()}};
}

TEST(SweepResults, ResumeSkipsOnlyCurrentSuccessfulRuns) {
  const fs::path path = fs::temp_directory_path() / "kfx_sweep_resume.jsonl";
  json failed = ok_record("b", {});
  failed["status"] = "failed";
  {
    std::ofstream log(path);
    log << ok_record("a", {"integration_rate=1"}).dump() << "\n";
    log << failed.dump() << "\n";
    log << ok_record("b", {}).dump().substr(0, 20);  // cut off by an interrupted write
  }
  int dropped = -1;
  const auto records = read_results_log(path.string(), &dropped);
  EXPECT_EQ(dropped, 1);
  ASSERT_EQ(records.size(), 2u);
  const auto latest = latest_results(records);
  ASSERT_EQ(latest.size(), 2u);
  EXPECT_EQ(result_key(latest[0]), "a|s|cpu");
  EXPECT_EQ(result_key(latest[0]), result_key("a", "s", "cpu"));
  EXPECT_TRUE(result_is_current(latest[0], "exact", {"integration_rate=1"}, 0));
  EXPECT_FALSE(result_is_current(latest[0], "exact", {"integration_rate=2"}, 0));
  EXPECT_FALSE(result_is_current(latest[0], "thesis", {"integration_rate=1"}, 0));
  EXPECT_FALSE(result_is_current(latest[0], "exact", {"integration_rate=1"}, 100));
  EXPECT_FALSE(result_is_current(latest[1], "exact", {}, 0));  // failed: run again

  // A preset defined differently when the record was written (same name) is run again, and so
  // is a record from before presets' settings were recorded.
  json fast = ok_record("c", {});
  fast["preset"] = "fast";
  fast["preset_settings"] = preset_settings("fast");
  EXPECT_TRUE(result_is_current(fast, "fast", {}, 0));
  fast["preset_settings"].push_back("icp_robust=huber");
  EXPECT_FALSE(result_is_current(fast, "fast", {}, 0));
  fast.erase("preset_settings");
  EXPECT_FALSE(result_is_current(fast, "fast", {}, 0));

  // A later record of the same key wins.
  auto again = records;
  again.push_back(ok_record("b", {}));
  const auto newer = latest_results(again);
  ASSERT_EQ(newer.size(), 2u);
  EXPECT_TRUE(result_is_current(newer[1], "exact", {}, 0));

  // A malformed line that is not the last one is an error naming the file and line.
  {
    std::ofstream log(path);
    log << "{not json\n" << ok_record("a", {}).dump() << "\n";
  }
  const std::string message = error_of([&] { read_results_log(path.string()); });
  EXPECT_NE(message.find(path.string() + "' line 1"), std::string::npos) << message;
  fs::remove(path);
  EXPECT_TRUE(read_results_log(path.string()).empty());  // no log yet: nothing done
}

TEST(SweepResults, CsvRowsQuoteAndFollowTheHeader) {
  EXPECT_EQ(csv_escape("plain"), "plain");
  EXPECT_EQ(csv_escape("a,b"), "\"a,b\"");
  EXPECT_EQ(csv_escape("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(csv_escape("two\nlines"), "\"two\nlines\"");

  json record = ok_record("pyramid_iterations=10,5,4", {});
  record["group"] = "tracking";
  record["frames"] = 500;
  record["ate_rmse_m"] = 0.0123456789;
  record["diverged_frames"] = 7;
  record["first_diverged_frame"] = 412;
  record["departure_frame"] = 430;
  record["computation_ms"] = {{"mean", 2.5}, {"median", 2.25}};
  record["stages_ms"]["track"] = {{"mean", 1.5}, {"median", 1.25}};
  record["settings"] = {"pyramid_iterations=10,5,4", "icp_stride_px=2"};
  record["error"] = "bad \"thing\"";
  const auto columns = csv_columns();
  const auto fields = split_csv(csv_row(record));
  ASSERT_EQ(fields.size(), columns.size());
  auto field = [&](const std::string& column) {
    const auto at = std::find(columns.begin(), columns.end(), column);
    EXPECT_NE(at, columns.end()) << column;
    return at == columns.end() ? std::string("?") : fields[at - columns.begin()];
  };
  EXPECT_EQ(field("name"), "pyramid_iterations=10,5,4");
  EXPECT_EQ(field("group"), "tracking");
  EXPECT_EQ(field("frames"), "500");
  EXPECT_EQ(field("ate_rmse_m"), "0.0123457");
  EXPECT_EQ(field("diverged_frames"), "7");
  EXPECT_EQ(field("first_diverged_frame"), "412");
  EXPECT_EQ(field("departure_frame"), "430");
  EXPECT_EQ(field("divergence_bound_m"), "");  // absent: empty
  EXPECT_EQ(field("frames_per_second"), "10.5");
  EXPECT_EQ(field("computation_ms_median"), "2.25");
  EXPECT_EQ(field("track_ms_mean"), "1.5");
  EXPECT_EQ(field("integrate_ms_mean"), "");  // absent: empty
  EXPECT_EQ(field("settings"), "pyramid_iterations=10,5,4 icp_stride_px=2");
  EXPECT_EQ(field("error"), "bad \"thing\"");

  const std::string csv = results_csv({record, record});
  std::istringstream lines(csv);
  std::string header;
  std::getline(lines, header);
  EXPECT_EQ(split_csv(header), columns);
  int rows = 0;
  for (std::string line; std::getline(lines, line);) rows += !line.empty();
  EXPECT_EQ(rows, 2);
}

// ---------------------------------------------------------------------------------------------
// End to end through the kfx binary.

using test::CommandResult;
using test::run_kfx;

int count_lines(const fs::path& path) {
  std::ifstream in(path);
  int lines = 0;
  for (std::string line; std::getline(in, line);) lines += !line.empty();
  return lines;
}

class SweepCli : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = kfx::test::fresh_test_dir("kfx_sweep_"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path write_plan(const std::string& text) {
    const fs::path path = dir_ / "plan.json";
    std::ofstream(path) << text;
    return path;
  }
  fs::path dir_;
};

TEST_F(SweepCli, TinySweepWritesResultsAndResumes) {
  const fs::path plan = write_plan(R"({
    "name": "tiny",
    "sequences": [{"name": "synth", "input": "synthetic:frames=12,width=160,height=120"}],
    "runs": [{"name": "exact", "baseline": true},
             {"group": "integration", "grid": {"integration_rate": [1]}}]
  })");
  const fs::path out = dir_ / "out";
  const std::string args = "sweep " + plan.string() + " --out " + out.string() +
                           " --backend cpu --warmup 2 --commit abc123";
  const auto first = run_kfx(args);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  EXPECT_NE(first.output.find("[1/2] exact on synth:"), std::string::npos) << first.output;
  EXPECT_NE(first.output.find("[2/2] integration_rate=1 on synth:"), std::string::npos);
  EXPECT_NE(first.output.find("ETA"), std::string::npos);

  std::ifstream json_file(out / "results.json");
  const json results = json::parse(json_file);
  EXPECT_EQ(results["plan"]["name"], "tiny");
  EXPECT_EQ(results["commit"], "abc123");
  ASSERT_EQ(results["runs"].size(), 2u);
  const json& exact = results["runs"][0];
  const json& rate = results["runs"][1];
  EXPECT_EQ(exact["name"], "exact");
  EXPECT_EQ(rate["name"], "integration_rate=1");
  for (const json& r : results["runs"]) {
    EXPECT_EQ(r["status"], "ok") << r.dump();
    EXPECT_EQ(r["sequence"], "synth");
    EXPECT_EQ(r["backend"], "cpu");
    EXPECT_EQ(r["frames"], 12);
    EXPECT_GT(r["tracked"].get<int>(), 0);
    EXPECT_GT(r["frames_per_second"].get<double>(), 0.0);
    EXPECT_GT(r["end_to_end_frames_per_second"].get<double>(), 0.0);
    EXPECT_TRUE(r["stages_ms"].contains("track"));
    EXPECT_FALSE(r["device"].get<std::string>().empty());
    EXPECT_EQ(r["commit"], "abc123");
    EXPECT_FALSE(r["date"].get<std::string>().empty());
    // The synthetic scene's exact ground truth: a tracked run stays within centimetres.
    ASSERT_TRUE(r.contains("ate_rmse_m")) << r.dump();
    EXPECT_GT(r["ate_rmse_m"].get<double>(), 0.0);
    EXPECT_LT(r["ate_rmse_m"].get<double>(), 0.05);
    // Such a run does not leave the ground truth: no frame beyond the divergence bound.
    EXPECT_EQ(r["diverged_frames"], 0) << r.dump();
    EXPECT_TRUE(r["first_diverged_frame"].is_null()) << r.dump();
    EXPECT_TRUE(r["departure_frame"].is_null()) << r.dump();
    EXPECT_DOUBLE_EQ(r["divergence_bound_m"].get<double>(), 0.10);
  }
  // The full configuration is recorded and reflects the run's settings.
  EXPECT_EQ(rate["config"]["integration_rate"], "1");
  EXPECT_EQ(rate["step"], "1");
  EXPECT_EQ(rate["before"], "exact");
  EXPECT_EQ(exact["config"]["integration_rate"], "2");

  EXPECT_EQ(count_lines(out / "results.jsonl"), 2);
  std::ifstream csv(out / "results.csv");
  std::string header, row1;
  std::getline(csv, header);
  std::getline(csv, row1);
  EXPECT_EQ(header.rfind("name,group,", 0), 0u) << header;
  EXPECT_EQ(row1.rfind("exact,", 0), 0u) << row1;
  EXPECT_EQ(count_lines(out / "results.csv"), 3);
  EXPECT_TRUE(fs::exists(out / "plan.json"));

  // Again: everything is done, nothing runs, the log does not grow.
  const auto second = run_kfx(args);
  ASSERT_EQ(second.exit_code, 0) << second.output;
  EXPECT_NE(second.output.find("2 already done, 0 to run"), std::string::npos) << second.output;
  EXPECT_EQ(second.output.find("[1/"), std::string::npos) << second.output;
  EXPECT_EQ(count_lines(out / "results.jsonl"), 2);

  // An interrupted sweep (its last record cut short) resumes with just the missing run.
  std::string log;
  {
    std::ifstream in(out / "results.jsonl");
    std::stringstream text;
    text << in.rdbuf();
    log = text.str();
  }
  const size_t last_start = log.rfind('\n', log.size() - 2) + 1;
  std::ofstream(out / "results.jsonl", std::ios::trunc) << log.substr(0, last_start + 30);
  const auto third = run_kfx(args);
  ASSERT_EQ(third.exit_code, 0) << third.output;
  EXPECT_NE(third.output.find("1 already done, 1 to run"), std::string::npos) << third.output;
  EXPECT_NE(third.output.find("[1/1] integration_rate=1 on synth"), std::string::npos);
  EXPECT_EQ(count_lines(out / "results.jsonl"), 2);

  // Changed settings under the same name are run again, not reused.
  const auto changed = run_kfx(args + " --set max_weight=50 --only exact");
  ASSERT_EQ(changed.exit_code, 0) << changed.output;
  EXPECT_NE(changed.output.find("0 already done, 1 to run"), std::string::npos) << changed.output;
}

TEST_F(SweepCli, FailedRunIsRecordedAndTheSweepContinues) {
  const fs::path plan = write_plan(R"({
    "sequences": [{"name": "missing", "input": "/nonexistent/kfx_sequence"},
                  {"name": "synth", "input": "synthetic:frames=4,width=160,height=120"}],
    "runs": [{"name": "exact"}]
  })");
  const fs::path out = dir_ / "out";
  const auto r =
      run_kfx("sweep " + plan.string() + " --out " + out.string() + " --backend cpu --warmup 0");
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("1 of 2 runs failed"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("/nonexistent/kfx_sequence"), std::string::npos) << r.output;
  std::ifstream json_file(out / "results.json");
  const json results = json::parse(json_file);
  ASSERT_EQ(results["runs"].size(), 2u);
  EXPECT_EQ(results["runs"][0]["status"], "failed");
  EXPECT_NE(results["runs"][0]["error"].get<std::string>().find("/nonexistent"), std::string::npos);
  EXPECT_EQ(results["runs"][1]["status"], "ok");  // the sweep went on
}

TEST_F(SweepCli, BadPlanFailsBeforeRunningAnything) {
  const fs::path plan = write_plan(R"({
    "sequences": [{"name": "synth", "input": "synthetic:frames=4"}],
    "runs": [{"name": "exact"}, {"name": "bad", "settings": {"icp_stride": 2}}]
  })");
  const fs::path out = dir_ / "out";
  const auto r = run_kfx("sweep " + plan.string() + " --out " + out.string() + " --backend cpu");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("runs[1]: run 'bad'"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("unknown setting 'icp_stride'"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out / "results.jsonl"));
}

}  // namespace
}  // namespace kfx::sweep
