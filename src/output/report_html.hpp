#pragma once
/// report.html: one self-contained page about a finished run, made from its output folder alone
/// (stats.json, trajectory.txt, groundtruth.txt, slambench.log, renders/, mesh.ply). Opens
/// offline: plots are SVG drawn by inline script, renders and the mesh are inlined as base64,
/// and the 3D view's library (three.js from Debian's libjs-three) is inlined from its install.

#include <string>

namespace kfx::output {

/// What write_report found and left out (for the command's message).
struct ReportResult {
  std::string path;          ///< the page written
  bool has_mesh = false;     ///< mesh.ply was found and shown
  bool has_3d_view = false;  ///< three.js was found (the 3D view needs it)
  bool has_ground_truth = false;
  int render_frames = 0;         ///< frames whose renders are shown
  int render_frames_in_run = 0;  ///< frames with renders in the folder
};

/// Where three.js is looked for: $KFX_THREE_JS_DIR, then Debian's /usr/share/javascript/three.
std::string find_three_js_dir();

/// Writes `run_dir`/report.html (under a temporary name, renamed when complete). Needs
/// stats.json, trajectory.txt and slambench.log; everything else is optional and the page says
/// what is missing. Throws kfx::Error naming the file and the problem.
ReportResult write_report(const std::string& run_dir);

}  // namespace kfx::output
