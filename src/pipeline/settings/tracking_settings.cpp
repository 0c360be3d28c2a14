/// Settings section `tracking`: its rows and checks.

#include "pipeline/settings/sections.hpp"
#include "pipeline/settings/setting_rows.hpp"

namespace kfx::settings {
namespace {

void check_tracking(const PipelineConfig& config) {
  const TrackingSettings& tracking = config.tracking;
  KFX_CHECK(tracking.rate >= 1, "tracking_rate must be >= 1, got " << tracking.rate);
  const auto& levels = tracking.iterations_per_level;
  KFX_CHECK(!levels.empty() && levels.size() <= 4,
            "pyramid_iterations must list 1 to 4 levels, got " << levels.size());
  for (int it : levels) {
    KFX_CHECK(it >= 0 && it <= 1000, "pyramid_iterations entries must be in 0..1000, got " << it);
  }
  KFX_CHECK(tracking.icp_threshold >= 0, "icp_threshold must be >= 0");
  KFX_CHECK(tracking.dist_threshold_m > 0, "dist_threshold_m must be > 0");
  KFX_CHECK(tracking.normal_threshold >= -1 && tracking.normal_threshold <= 1,
            "normal_threshold must be in [-1, 1]");
  KFX_CHECK(tracking.max_rms_error_m > 0, "max_rms_error_m must be > 0");
  KFX_CHECK(tracking.min_inlier_fraction >= 0 && tracking.min_inlier_fraction <= 1,
            "min_inlier_fraction must be in [0, 1]");
  KFX_CHECK(tracking.half_sample_range_m > 0, "half_sample_range_m must be > 0");
  KFX_CHECK(tracking.relocalise_keyframes >= 1 && tracking.relocalise_keyframes <= 1000000,
            "relocalise_keyframes must be in 1..1000000, got " << tracking.relocalise_keyframes);
  KFX_CHECK(tracking.loop_min_gap_frames >= 1,
            "loop_min_gap_frames must be >= 1, got " << tracking.loop_min_gap_frames);
  KFX_CHECK(tracking.relocalise_ferns >= 1 && tracking.relocalise_ferns <= 10000,
            "relocalise_ferns must be in 1..10000, got " << tracking.relocalise_ferns);
  KFX_CHECK(tracking.relocalise_harvest > 0 && tracking.relocalise_harvest <= 1,
            "relocalise_harvest must be in (0, 1], got " << tracking.relocalise_harvest);
  KFX_CHECK(tracking.localise_candidates >= 1 && tracking.localise_candidates <= 100,
            "localise_candidates must be in 1..100, got " << tracking.localise_candidates);
  KFX_CHECK(tracking.localise_perturb >= 0 && tracking.localise_perturb <= 100,
            "localise_perturb must be in 0..100, got " << tracking.localise_perturb);
  KFX_CHECK(tracking.localise_confirm_passes >= 1 && tracking.localise_confirm_passes <= 10,
            "localise_confirm_passes must be in 1..10, got " << tracking.localise_confirm_passes);
  KFX_CHECK(tracking.localise_perturb_m >= 0 && tracking.localise_perturb_m <= 1,
            "localise_perturb_m must be in [0, 1] metres, got " << tracking.localise_perturb_m);
  KFX_CHECK(
      tracking.localise_perturb_deg >= 0 && tracking.localise_perturb_deg <= 90,
      "localise_perturb_deg must be in [0, 90] degrees, got " << tracking.localise_perturb_deg);
  KFX_CHECK(tracking.localise_max_misfit >= 0 && tracking.localise_max_misfit <= 1,
            "localise_max_misfit must be in [0, 1], got " << tracking.localise_max_misfit);
  KFX_CHECK(tracking.localise_min_inliers >= 0 && tracking.localise_min_inliers <= 1,
            "localise_min_inliers must be in [0, 1], got " << tracking.localise_min_inliers);
  KFX_CHECK(!tracking.relocalise_each_frame || tracking.relocalise,
            "relocalise_each_frame=on locates frames from the keyframe database: it needs "
            "relocalise=on");
}

}  // namespace

SettingsSection tracking_section() {
  const std::string s = "tracking";
  using C = PipelineConfig;
  SettingsSection section;
  section.check = check_tracking;
  auto& rows = section.fields;
  rows.push_back(integer_row("tracking_rate", s, "track every N-th frame (>= 1)",
                             [](C& c) -> int& { return c.tracking.rate; }, {"t", "tracking-rate"}));
  rows.push_back(custom_row(
      "pyramid_iterations", s,
      "ICP iteration caps per level, finest first; the count is the number of levels (1..4)",
      [](C& c, const std::string& text) {
        std::vector<int> levels;
        for (const auto& part : split_commas(text)) {
          levels.push_back(parse_integer("pyramid_iterations", part));
        }
        c.tracking.iterations_per_level = levels;
      },
      [](const C& c) { return format_list(c.tracking.iterations_per_level); },
      {"y", "pyramid-levels"}));
  rows.push_back(number_row("icp_threshold", s, "stop a level when |update| < this",
                            [](C& c) -> float& { return c.tracking.icp_threshold; },
                            {"l", "icp-threshold"}));
  rows.push_back(number_row("dist_threshold_m", s, "ICP association distance gate, metres",
                            [](C& c) -> float& { return c.tracking.dist_threshold_m; }));
  rows.push_back(number_row("normal_threshold", s, "ICP association normal gate (cosine)",
                            [](C& c) -> float& { return c.tracking.normal_threshold; }));
  rows.push_back(number_row("max_rms_error_m", s, "accept test: largest residual RMS, metres",
                            [](C& c) -> float& { return c.tracking.max_rms_error_m; }));
  rows.push_back(number_row("min_inlier_fraction", s, "accept test: smallest inliers / pixels",
                            [](C& c) -> float& { return c.tracking.min_inlier_fraction; }));
  rows.push_back(number_row("half_sample_range_m", s, "pyramid half-sample range, metres",
                            [](C& c) -> float& { return c.tracking.half_sample_range_m; }));
  rows.push_back(on_off_row(
      "relocalise", s,
      "keep keyframes while tracking is good and, when tracking is lost or a map is loaded, "
      "find the camera again from them before integrating anything (on|off; docs/tracking.md)",
      [](C& c) -> bool& { return c.tracking.relocalise; }));
  rows.push_back(integer_row(
      "relocalise_keyframes", s,
      "relocalisation: keyframes the database holds at most (about 3 KB each with 500 ferns: the "
      "code, the pose and the 40x30 small depth image)",
      [](C& c) -> int& { return c.tracking.relocalise_keyframes; }));
  rows.push_back(integer_row("relocalise_ferns", s,
                             "relocalisation: random ferns (4 depth tests each) per keyframe code",
                             [](C& c) -> int& { return c.tracking.relocalise_ferns; }));
  rows.push_back(choice_row(
      "loop_closure", s,
      "off | online: keep keyframes, verify loops between frames, optimise a pose graph on a "
      "host thread and rebuild the map at its poses; trajectory.txt optimised, odometry.txt raw "
      "(kfx run only, with Ceres: kfx::Reconstruction and Python's kfx.Reconstruction refuse "
      "online; docs/loop_closure.md)",
      Choices<LoopClosureMode>{{"off", LoopClosureMode::kOff},
                               {"online", LoopClosureMode::kOnline}},
      [](C& c) -> LoopClosureMode& { return c.tracking.loop_closure; }));
  rows.push_back(
      integer_row("loop_min_gap_frames", s,
                  "loop closure: a loop joins frames at least this many apart in time (>= 1)",
                  [](C& c) -> int& { return c.tracking.loop_min_gap_frames; }));
  rows.push_back(number_row(
      "relocalise_harvest", s,
      "relocalisation: a well-tracked frame becomes a keyframe when this share of its ferns "
      "differs from its nearest keyframe's (smaller: more keyframes, nearer candidates)",
      [](C& c) -> float& { return c.tracking.relocalise_harvest; }));
  rows.push_back(on_off_row(
      "relocalise_align", s,
      "relocalisation: align a lost frame's small depth image to each candidate keyframe's on "
      "the host and start the attempt at the keyframe's pose moved by that alignment (on|off; "
      "docs/tracking.md)",
      [](C& c) -> bool& { return c.tracking.relocalise_align; }));
  rows.push_back(on_off_row(
      "relocalise_each_frame", s,
      "locate every frame alone in the loaded map from its nearest keyframes, with no memory of "
      "the previous frame's pose, and integrate nothing (on|off; needs relocalise=on and a "
      "loaded map; docs/tracking.md)",
      [](C& c) -> bool& { return c.tracking.relocalise_each_frame; }));
  rows.push_back(integer_row(
      "localise_candidates", s,
      "relocalisation: nearest keyframes tried for a frame located alone (relocalise_each_frame, "
      "Reconstruction::localise)",
      [](C& c) -> int& { return c.tracking.localise_candidates; }));
  rows.push_back(integer_row(
      "localise_confirm_passes", s,
      "relocalisation: for a frame located alone, passes after the first that may confirm a "
      "pose, each from where the last ended, until one moves it less than 2 cm and 2 degrees "
      "(1: exactly one)",
      [](C& c) -> int& { return c.tracking.localise_confirm_passes; }));
  rows.push_back(integer_row(
      "localise_perturb", s,
      "relocalisation: of the keyframes a frame located alone tries, how many nearest are also "
      "tried from 12 poses around theirs (moved localise_perturb_m along, turned "
      "localise_perturb_deg about each camera axis) when no keyframe's own pose locates it "
      "(0: none)",
      [](C& c) -> int& { return c.tracking.localise_perturb; }));
  rows.push_back(number_row(
      "localise_perturb_m", s,
      "relocalisation: localise_perturb's move along each camera axis, metres (0: no moves)",
      [](C& c) -> float& { return c.tracking.localise_perturb_m; }));
  rows.push_back(number_row(
      "localise_perturb_deg", s,
      "relocalisation: localise_perturb's turn about each camera axis, degrees (0: no turns)",
      [](C& c) -> float& { return c.tracking.localise_perturb_deg; }));
  rows.push_back(number_row(
      "localise_max_misfit", s,
      "relocalisation: a frame located alone is refused when more than this share of its pixels "
      "met the map and did not fit it (too far, or normals that disagree; 1: no limit; 0.07 "
      "kept right poses and refused wrong ones with localise_perturb on 256-voxel maps of real "
      "rooms, docs/tracking.md)",
      [](C& c) -> float& { return c.tracking.localise_max_misfit; }));
  rows.push_back(number_row(
      "localise_min_inliers", s,
      "relocalisation: a frame located alone is refused when fewer than this share of its "
      "pixels are inliers (0.5; with candidates aligned to the view, 0.3 together with "
      "localise_max_misfit=0.07 located more frames of real rooms and none falsely, "
      "docs/tracking.md)",
      [](C& c) -> float& { return c.tracking.localise_min_inliers; }));
  return section;
}

}  // namespace kfx::settings
