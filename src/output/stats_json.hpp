#pragma once
/// The JSON documents kfx writes (stats.json of `kfx run`, `kfx bench --json`) share one
/// versioned schema (docs/outputs.md): a top-level `schema_version`, flat snake_case keys with
/// units in their names (`ate_rmse_m`, `frames_per_second`).

#include <nlohmann/json.hpp>
#include <string>

#include "eval/report.hpp"
#include "localise/tracking_judge.hpp"

namespace kfx::output {

/// Version of the JSON schema; bump it when a key changes meaning or goes away.
constexpr int kJsonSchemaVersion = 2;

/// The ATE/RPE figures of an evaluation as flat keys (ate_rmse_m, ate_mean_m, ...,
/// rpe_translation_rmse_m, ...) added to `out`.
void add_flat_evaluation(nlohmann::json& out, const eval::EvalResult& result);

/// The run's tracking states as `tracking_states`: {"good", "poor", "lost": frame counts,
/// "stretches": [{"state", "first_frame", "last_frame", "frames"}] of poor and lost frames}.
void add_tracking_states(nlohmann::json& out, const TrackingTimeline& timeline);

/// Writes `document` with `schema_version` set to `path` (temporary name, renamed when
/// complete).
void write_json_document(const std::string& path, nlohmann::json document);

}  // namespace kfx::output
