/// `kfx live --out DIR [...]`: live reconstruction from a RealSense camera or an OpenNI2 device.
/// A RealSense camera is reached through pyrealsense2 (librealsense is not packaged here), an
/// OpenNI2 device through the library's `openni2:` input; the frame queue, the drops and the
/// clean stop are the Python package's, so this hands over to it (`python -m kfx.live`, same
/// arguments), naming what is missing when it cannot.

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "commands.hpp"
#include "core/platform.hpp"

namespace kfx::cli {
namespace {

/// Run by the chosen Python: imports kfx.live, or says plainly which package is missing.
constexpr const char* kBootstrap =
    "import sys\n"
    "try:\n"
    "    import kfx.live\n"
    "except ImportError as e:\n"
    "    sys.exit('kfx live: error: ' + sys.executable + ' cannot import the kfx Python package ('"
    " + str(e) + '); install it (pip install kfx, or kfx[realsense] for a RealSense camera) '"
    "'or set KFX_PYTHON to a Python '"
    "'that has it')\n"
    "sys.exit(kfx.live.main(sys.argv[1:]))\n";

}  // namespace

void add_live_command(CLI::App& app) {
  CLI::App* command = app.add_subcommand(
      "live",
      "reconstruct live from a RealSense camera (pyrealsense2) or an OpenNI2 device (--openni "
      "[URI]), or a recording played at its pace (--from-file REC, --openni FILE.oni), until "
      "Ctrl-C; runs the Python package's kfx.live: `kfx live --help` lists its options");
  // Every argument, --help included, belongs to kfx.live.
  command->prefix_command();
  command->set_help_flag();
  command->callback([command] {
    const char* chosen = std::getenv("KFX_PYTHON");
    const std::string python = chosen && *chosen ? chosen : "python3";
    std::vector<std::string> args = {python, "-c", kBootstrap};
    for (const std::string& arg : command->remaining()) args.push_back(arg);
    std::vector<char*> argv;
    for (std::string& arg : args) argv.push_back(arg.data());
    argv.push_back(nullptr);
    execvp(argv[0], argv.data());
    KFX_FAIL("kfx live runs the Python package kfx (pip install kfx[realsense]) but cannot run '"
             << python << "': " << std::strerror(errno)
             << "; install Python 3 or set KFX_PYTHON to the Python that has kfx");
  });
}

}  // namespace kfx::cli
