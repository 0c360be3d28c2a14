/// kfx: one command-line tool with subcommands (run, eval, convert, ...).

#include <cstring>
#include <exception>
#include <iostream>
#include <string>

#include "backend/backend.hpp"
#include "commands.hpp"
#include "core/platform.hpp"
#include "interrupt.hpp"

int main(int argc, char** argv) {
  // Before anything touches CUDA: --concurrent pipelines each get a hardware queue.
  kfx::allow_many_cuda_streams();
  CLI::App app{"kfx: KinectFusion (dense RGB-D SLAM) for CPUs and GPUs, exact and approximate"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("kfx ") + KFX_VERSION);
  kfx::cli::add_run_command(app);
  kfx::cli::add_fuse_command(app);
  kfx::cli::add_optimise_command(app);
  kfx::cli::add_eval_command(app);
  kfx::cli::add_convert_command(app);
  kfx::cli::add_bench_command(app);
  kfx::cli::add_settings_command(app);
  kfx::cli::add_sweep_command(app);
  kfx::cli::add_mesh_command(app);
  kfx::cli::add_report_command(app);
  kfx::cli::add_colour_eval_command(app);
  kfx::cli::add_live_command(app);
  // CLI11 reports an unknown first word only as an unexpected argument; name it plainly.
  if (argc > 1 && argv[1][0] != '-') {
    std::string known;
    bool found = false;
    for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
      found = found || sub->get_name() == argv[1];
      known += (known.empty() ? "" : ", ") + sub->get_name();
    }
    if (!found) {
      std::cerr << "kfx: error: unknown subcommand '" << argv[1] << "'; the subcommands are "
                << known << " (kfx --help)\n";
      return 2;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const kfx::cli::Interrupted& e) {
    std::cerr << "kfx: " << e.what() << "\n";
    return kfx::cli::kInterruptedExitStatus;
  } catch (const kfx::Error& e) {
    std::cerr << "kfx: error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "kfx: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
