/// `kfx report DIR`: remakes DIR/report.html from a finished run's output folder.

#include <iostream>

#include "commands.hpp"
#include "output/report_html.hpp"

namespace kfx::cli {

void add_report_command(CLI::App& app) {
  auto* command = app.add_subcommand("report", "make report.html from a finished run's folder");
  auto dir = std::make_shared<std::string>();
  command->add_option("dir", *dir, "output folder of `kfx run`")->required();
  command->callback([dir] {
    const output::ReportResult r = output::write_report(*dir);
    std::cout << "wrote " << r.path << (r.has_mesh ? "" : " (no mesh.ply: no model in the 3D view)")
              << (r.has_3d_view ? "" : " (three.js not found: no 3D view; install libjs-three)")
              << "\n";
  });
}

}  // namespace kfx::cli
