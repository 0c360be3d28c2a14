#pragma once
/// The report page's HTML, style and script (src/output/report_page/report.{html,css,js},
/// embedded at build time by cmake/embed_report_page.cmake), with two markers write_report fills:
/// /*KFX_THREE*/ (three.js and its OrbitControls, inlined) and /*KFX_DATA*/ (`const KFX = {...}`,
/// the run's data). The script sets body[data-status] to "ok" when every part was drawn, or
/// "error" with the messages in #errors when any script error happened (the browser test reads
/// both), and body[data-mesh-pixels] to the pixels of the 3D view that differ from its
/// background after the first frame. Opened as report.html#model it shows the 3D view alone,
/// filling the window (for pictures of the model).

namespace kfx::output {

/// The page template (static text).
const char* report_page_template();

}  // namespace kfx::output
