/// kfx: one command-line tool with subcommands (run, eval, convert, ...).

#include <exception>
#include <iostream>

#include "commands.hpp"
#include "core/platform.hpp"

int main(int argc, char** argv) {
  CLI::App app{"kfx: KinectFusion (dense RGB-D SLAM) for CPUs and GPUs, exact and approximate"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("kfx ") + KFX_VERSION);
  kfx::cli::add_run_command(app);
  kfx::cli::add_eval_command(app);
  kfx::cli::add_convert_command(app);
  kfx::cli::add_bench_command(app);
  kfx::cli::add_settings_command(app);
  kfx::cli::add_sweep_command(app);
  kfx::cli::add_mesh_command(app);
  kfx::cli::add_report_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const kfx::Error& e) {
    std::cerr << "kfx: error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "kfx: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
