#include "output/report_html.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>

#include "core/platform.hpp"
#include "eval/report.hpp"
#include "io/atomic_file.hpp"
#include "io/trajectory.hpp"
#include "output/frame_rate_text.hpp"
#include "output/mesh_view.hpp"
#include "output/report_page.hpp"
#include "pipeline/config.hpp"

namespace kfx::output {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// The 3D view shows at most this many triangles (a browser on a laptop stays fluid).
constexpr size_t kMaxViewTriangles = 300000;
/// The page shows the renders of at most this many frames, evenly spread over the run.
constexpr int kMaxRenderFrames = 8;

std::string read_file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  KFX_CHECK(in, "cannot read '" << path << "'");
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

std::string base64(const void* data, size_t size) {
  static const char* kDigits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* p = static_cast<const unsigned char*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (size_t i = 0; i < size; i += 3) {
    const unsigned v =
        (p[i] << 16) | (i + 1 < size ? p[i + 1] << 8 : 0) | (i + 2 < size ? p[i + 2] : 0);
    out += kDigits[(v >> 18) & 63];
    out += kDigits[(v >> 12) & 63];
    out += i + 1 < size ? kDigits[(v >> 6) & 63] : '=';
    out += i + 2 < size ? kDigits[v & 63] : '=';
  }
  return out;
}

/// Text safe inside a <script> element: "</" never appears (JSON and JS read "<\/" as "</").
std::string script_safe(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    out += text[i];
    if (text[i] == '<' && i + 1 < text.size() && text[i + 1] == '/') out += '\\';
  }
  return out;
}

/// slambench.log as columns by header name, one value per frame.
std::map<std::string, std::vector<double>> read_slambench_log(const std::string& path) {
  std::ifstream in(path);
  KFX_CHECK(in, "cannot read '" << path << "'");
  std::string line;
  KFX_CHECK(std::getline(in, line), path << ": empty log");
  std::vector<std::string> names;
  {
    std::istringstream header(line);
    for (std::string name; header >> name;) names.push_back(name);
  }
  KFX_CHECK(!names.empty() && names[0] == "frame",
            path << ": not a SLAMBench log header: " << line);
  std::map<std::string, std::vector<double>> columns;
  int line_number = 1;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty()) continue;
    std::istringstream fields(line);
    for (const auto& name : names) {
      double v = 0;
      KFX_CHECK(fields >> v, path << " line " << line_number << ": expected " << names.size()
                                  << " numbers (column '" << name << "' missing or bad)");
      columns[name].push_back(v);
    }
  }
  return columns;
}

/// Keys of the settings whose values came from the input (stats.json's settings_from_input).
std::set<std::string> settings_from_input(const json& stats) {
  std::set<std::string> keys;
  for (const auto& key : stats.value("settings_from_input", json::array())) {
    keys.insert(key.get<std::string>());
  }
  return keys;
}

/// The settings as "key=value": those the input chose (`from_input` true) or the others that
/// differ from the preset's (changed by the user).
std::vector<std::string> changed_settings(const json& stats, bool from_input) {
  std::vector<std::string> changed;
  if (!stats.contains("config") || !stats.contains("preset")) return changed;
  const std::set<std::string> input_keys = settings_from_input(stats);
  PipelineConfig preset;
  try {
    preset = make_preset(stats["preset"].get<std::string>());
  } catch (const Error&) {
    return changed;  // a preset this kfx does not know: list nothing rather than guess
  }
  for (const auto& field : config_fields()) {
    const auto& section = stats["config"].value(field.section, json::object());
    if (!section.contains(field.key)) continue;
    const std::string value = section[field.key].get<std::string>();
    if (input_keys.count(field.key) != 0) {
      if (from_input) changed.push_back(field.key + "=" + value);
    } else if (!from_input && value != field.format(preset)) {
      changed.push_back(field.key + "=" + value);
    }
  }
  return changed;
}

/// Whether the run's ATE flipped y (stats.json schema 2: flat `ate_flip_y`; schema 1 nested it
/// under `ate`), so the plots are aligned as the ATE was.
bool evaluated_with_flip_y(const json& stats) {
  if (stats.contains("ate_flip_y")) return stats["ate_flip_y"].get<bool>();
  if (stats.contains("ate") && stats["ate"].is_object()) return stats["ate"].value("flip_y", false);
  return false;
}

/// The frames whose tracking ran and failed: stats.json's `lost_frames`; for a run written
/// before it existed, the log's untracked frames on the tracking rate after the bootstrap
/// frames (from the run's settings; the reference view may then start later than this says).
json lost_frames(const json& stats, const std::map<std::string, std::vector<double>>& log) {
  if (stats.contains("lost_frames")) return stats["lost_frames"];
  int bootstrap = 4, rate = 1;
  if (stats.contains("config")) {
    const json& config = stats["config"];
    bootstrap = std::stoi(config.value("quality", json::object()).value("bootstrap_frames", "4"));
    rate = std::stoi(config.value("tracking", json::object()).value("tracking_rate", "1"));
  }
  json lost = json::array();
  const auto frame = log.find("frame"), tracked = log.find("tracked");
  if (frame == log.end() || tracked == log.end()) return lost;
  for (size_t i = 0; i < frame->second.size(); ++i) {
    const int f = static_cast<int>(frame->second[i]);
    if (f >= bootstrap && f % std::max(1, rate) == 0 && tracked->second[i] == 0) lost.push_back(f);
  }
  return lost;
}

json position(const Eigen::Vector3d& p) { return json::array({p.x(), p.y(), p.z()}); }

/// Trajectory plots and the translational error: aligned onto the ground truth when there is
/// one (as the ATE does), else the estimate alone in the volume frame.
/// `frame_numbers`: slambench.log's frame column, one per pose of `est` (the input's numbers,
/// which skip bad frames); the pose's index where it does not match.
json trajectory_data(const std::vector<io::StampedPose>& est, const std::string& gt_path,
                     const json& stats, const std::vector<double>& frame_numbers,
                     ReportResult& result) {
  const auto frame_number = [&](size_t i) {
    return frame_numbers.size() == est.size() ? static_cast<int>(frame_numbers[i])
                                              : static_cast<int>(i);
  };
  json t;
  json path = json::array();
  for (const auto& p : est) path.push_back(json::array({p.t[0], p.t[1], p.t[2]}));
  t["volume_path"] = path;  // the 3D view: same frame as mesh.ply
  if (!fs::exists(gt_path)) {
    t["frame"] = "volume";
    t["est"] = path;
    t["est_frames"] = json::array();
    for (size_t i = 0; i < est.size(); ++i) t["est_frames"].push_back(frame_number(i));
    t["note"] = "no groundtruth.txt in the folder: the estimate alone, in the volume frame";
    return t;
  }
  const auto gt = io::read_tum_trajectory(gt_path);
  eval::EvalOptions options;
  options.flip_y = evaluated_with_flip_y(stats);
  const eval::EvalResult r =
      eval::evaluate_trajectories(est, gt, options, "trajectory.txt", gt_path);
  result.has_ground_truth = true;
  Eigen::Matrix3Xd est_m, gt_m;
  eval::paired_positions(est, gt, r.association, options.flip_y, &est_m, &gt_m);
  const Eigen::Matrix3Xd aligned = r.ate.alignment.apply(est_m);
  json est_aligned = json::array(), est_frames = json::array(), errors = json::array();
  size_t gt_first = gt.size(), gt_last = 0;
  for (size_t i = 0; i < r.association.pairs.size(); ++i) {
    est_aligned.push_back(position(aligned.col(i)));
    est_frames.push_back(frame_number(r.association.pairs[i].est_index));
    errors.push_back(r.ate.errors_m[i]);
    gt_first = std::min(gt_first, r.association.pairs[i].gt_index);
    gt_last = std::max(gt_last, r.association.pairs[i].gt_index);
  }
  json gt_path_json = json::array();
  for (size_t i = gt_first; i <= gt_last && i < gt.size(); ++i) {
    gt_path_json.push_back(json::array({gt[i].t[0], gt[i].t[1], gt[i].t[2]}));
  }
  t["frame"] = "ground truth";
  t["est"] = est_aligned;
  t["est_frames"] = est_frames;
  t["gt"] = gt_path_json;
  t["errors_m"] = errors;
  t["note"] =
      std::string("estimate aligned onto the ground truth as for the ATE (rigid, no scale") +
      (options.flip_y ? ", estimate y flipped)" : ")");
  return t;
}

json renders_data(const std::string& run_dir, ReportResult& result) {
  json out = json::array();
  const fs::path folder = fs::path(run_dir) / "renders";
  if (!fs::is_directory(folder)) return out;
  std::map<int, std::map<std::string, std::string>> frames;  // frame → kind → path
  const std::regex name(R"((depth|track|volume|colour)_(\d{6})\.png)");
  for (const auto& entry : fs::directory_iterator(folder)) {
    std::smatch m;
    const std::string file = entry.path().filename().string();
    if (std::regex_match(file, m, name)) frames[std::stoi(m[2])][m[1]] = entry.path().string();
  }
  std::vector<int> all;
  for (const auto& [frame, kinds] : frames) all.push_back(frame);
  const int n = static_cast<int>(all.size());
  const int shown = std::min(n, kMaxRenderFrames);
  for (int i = 0; i < shown; ++i) {
    const int frame = all[shown == 1 ? 0 : static_cast<size_t>(i) * (n - 1) / (shown - 1)];
    json item{{"frame", frame}};
    for (const auto& [kind, path] : frames[frame]) {
      const std::string bytes = read_file_bytes(path);
      item[kind] = "data:image/png;base64," + base64(bytes.data(), bytes.size());
    }
    out.push_back(item);
  }
  result.render_frames = shown;
  result.render_frames_in_run = n;
  return out;
}

/// Every warning as stretches of frames: stats.json's `warning_stretches`; for a run written
/// before it existed, the lost frames as runs of consecutive frames (all that run recorded per
/// frame).
json warning_stretches(const json& stats, const json& lost) {
  if (stats.contains("warning_stretches")) return stats["warning_stretches"];
  json out = json::array();
  for (size_t i = 0; i < lost.size();) {
    size_t j = i + 1;
    while (j < lost.size() && lost[j].get<int>() == lost[j - 1].get<int>() + 1) ++j;
    out.push_back({{"cause", "lost_tracking"},
                   {"description", "tracking lost (pose kept, frame not integrated)"},
                   {"first_frame", lost[i]},
                   {"last_frame", lost[j - 1]},
                   {"frames", j - i}});
    i = j;
  }
  return out;
}

json mesh_data(const std::string& run_dir, ReportResult& result) {
  const std::string path = run_dir + "/mesh.ply";
  if (!fs::exists(path))
    return json{{"missing", "no mesh.ply in the folder (run without --no-mesh)"}};
  const ViewMesh source = read_view_mesh(path);
  const ViewMesh mesh = thin_for_view(source, kMaxViewTriangles);
  result.has_mesh = true;
  json data{{"positions", base64(mesh.positions_m.data(), mesh.positions_m.size() * sizeof(float))},
            {"indices", base64(mesh.triangles.data(), mesh.triangles.size() * sizeof(uint32_t))},
            {"vertices", mesh.vertex_count()},
            {"triangles", mesh.triangle_count()},
            {"source_vertices", mesh.source_vertices},
            {"source_triangles", mesh.source_triangles},
            {"thinning_cell_m", mesh.cell_m}};
  if (!mesh.colours.empty()) data["colours"] = base64(mesh.colours.data(), mesh.colours.size());
  return data;
}

json summary_data(const json& stats, const ReportResult& result) {
  json s;
  s["input"] = stats.value("input", "");
  s["input_description"] = stats.value("input_description", "");
  s["backend"] = stats.value("backend", "");
  s["device"] = stats.value("device", "");
  s["preset"] = stats.value("preset", "");
  s["settings_changed"] = changed_settings(stats, false);
  s["settings_from_input"] = changed_settings(stats, true);
  s["config"] = stats.value("config", json::object());
  s["frames"] = stats.value("frames", 0);
  s["tracked"] = stats.value("tracked", 0);
  s["integrated"] = stats.value("integrated", 0);
  s["frames_per_second"] = stats.value("frames_per_second", 0.0);
  // As the terminal rounds it.
  s["frames_per_second_text"] = frame_rate_text(stats.value("frames_per_second", 0.0));
  s["interrupted"] = stats.value("interrupted", false);
  s["frames_in_input"] = stats.value("frames_in_input", json(nullptr));
  s["colour"] = stats.value("colour", json::object());
  s["memory_definitions"] = stats.value("memory_definitions", json::object());
  // Divergence (schema 2's flat names), for the summary beside the stretches.
  for (const char* key :
       {"diverged_frames", "divergence_bound_m", "first_diverged_frame", "departure_frame"}) {
    if (stats.contains(key)) s[key] = stats[key];
  }
  s["kfx_version"] = stats.value("kfx_version", "");
  s["energy"] = stats.value("energy", json::object());  // per domain: figures or the reason
  s["lost"] = stats.value("lost", 0);
  // stats.json schema 2's flat names; the page shows what the run itself computed.
  for (const char* key : {"ate_rmse_m", "ate_flip_y", "rpe_translation_rmse_m",
                          "rpe_rotation_rmse_deg", "rpe_delta_frames"}) {
    if (stats.contains(key)) s[key] = stats[key];
  }
  if (stats.contains("ate_error")) s["ate_error"] = stats["ate_error"];
  // The block map's memory (volume=blocks only).
  for (const char* key :
       {"map_blocks", "map_bytes", "map_blocks_swapped", "map_swapped_bytes", "map_swap_passes",
        "map_frames_short_of_blocks", "map_first_frame_short_of_blocks"}) {
    if (stats.contains(key)) s[key] = stats[key];
  }
  s["ground_truth"] = result.has_ground_truth;
  return s;
}

}  // namespace

std::string find_three_js_dir() {
  if (const char* dir = std::getenv("KFX_THREE_JS_DIR")) return dir;
  return "/usr/share/javascript/three";
}

ReportResult write_report(const std::string& run_dir) {
  ReportResult result;
  result.path = run_dir + "/report.html";
  const std::string stats_path = run_dir + "/stats.json";
  KFX_CHECK(fs::is_directory(run_dir), "'" << run_dir << "': no such folder");
  KFX_CHECK(fs::exists(stats_path),
            "'" << run_dir << "' holds no stats.json: not a finished kfx run");
  json stats;
  try {
    stats = json::parse(read_file_bytes(stats_path));
  } catch (const json::exception& e) {
    KFX_FAIL(stats_path << ": not valid JSON (" << e.what() << ")");
  }
  const auto est = io::read_tum_trajectory(run_dir + "/trajectory.txt");
  const auto log = read_slambench_log(run_dir + "/slambench.log");

  json data;
  const auto frame_column = log.find("frame");
  const std::vector<double> frame_numbers =
      frame_column == log.end() ? std::vector<double>{} : frame_column->second;
  try {
    data["trajectory"] =
        trajectory_data(est, run_dir + "/groundtruth.txt", stats, frame_numbers, result);
  } catch (const Error& e) {
    data["trajectory"] = trajectory_data(est, "", stats, frame_numbers, result);
    data["trajectory"]["note"] = std::string("ground truth not usable: ") + e.what();
  }
  // A run `kfx optimise` closed loops over: its raw odometry beside the optimised trajectory
  // (each aligned onto the ground truth on its own, as each one's ATE is), and the loops.
  if (stats.contains("loop_closure") && fs::exists(run_dir + "/odometry.txt")) {
    const auto odometry = io::read_tum_trajectory(run_dir + "/odometry.txt");
    ReportResult unused;  // the figures the report returns are the optimised trajectory's
    try {
      data["odometry"] = trajectory_data(odometry, run_dir + "/groundtruth.txt", stats, {}, unused);
    } catch (const Error&) {
      data["odometry"] = trajectory_data(odometry, "", stats, {}, unused);
    }
    data["loop_closure"] = stats["loop_closure"];
  }
  data["log"] = log;
  data["lost_frames"] = lost_frames(stats, log);
  data["warning_stretches"] = warning_stretches(stats, data["lost_frames"]);
  // Every warning line the terminal said, with its frame (absent from runs written before).
  data["warning_lines"] = stats.value("warnings", json::array());
  data["tracking_states"] = stats.value("tracking_states", json(nullptr));
  data["renders"] = renders_data(run_dir, result);
  data["render_frames_in_run"] = result.render_frames_in_run;
  data["mesh"] = mesh_data(run_dir, result);
  data["summary"] = summary_data(stats, result);

  const std::string three_dir = find_three_js_dir();
  std::string three;
  const std::string three_main = three_dir + "/three.min.js";
  const std::string three_orbit = three_dir + "/examples/js/controls/OrbitControls.js";
  if (fs::exists(three_main) && fs::exists(three_orbit)) {
    three = read_file_bytes(three_main) + "\n" + read_file_bytes(three_orbit);
    result.has_3d_view = true;
  }
  data["has_three"] = result.has_3d_view;
  data["three_dir"] = three_dir;

  std::string page = report_page_template();
  auto substitute = [&page](const std::string& marker, const std::string& text) {
    const size_t at = page.find(marker);
    KFX_CHECK(at != std::string::npos, "report template lacks " << marker);
    page.replace(at, marker.size(), text);
  };
  // The data first: three.js's own text must not be searched for markers.
  substitute("/*KFX_DATA*/", "const KFX = " + script_safe(data.dump()) + ";");
  substitute("/*KFX_THREE*/", script_safe(three));
  io::AtomicFile file(result.path);
  file.stream() << page;
  file.commit();
  return result;
}

}  // namespace kfx::output
