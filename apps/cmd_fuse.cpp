/// `kfx fuse INPUT --trajectory T.txt --out DIR`: the input's frames integrated into a fresh map
/// at the poses a trajectory gives (no tracking), with the outputs of `kfx run`.

#include <memory>

#include "commands.hpp"
#include "io/trajectory.hpp"
#include "run_command.hpp"
#include "staged_run.hpp"

namespace kfx::cli {
namespace {

/// Where `kfx fuse --overwrite` writes before its outputs replace the earlier ones (hidden: a
/// killed fusion's leftover is no output of kfx; the next fuse into the folder removes it).
constexpr const char* kFuseStagingFolder = ".kfx-fuse.partial";

}  // namespace

void add_fuse_command(CLI::App& app) {
  auto* command = app.add_subcommand(
      "fuse", "integrate a sequence's frames at the poses of a trajectory (no tracking)");
  auto options = std::make_shared<RunOptions>();
  auto outputs = std::make_shared<RunOutputs>();
  auto trajectory = std::make_shared<std::string>();
  add_run_options(*command, *options);
  command
      ->add_option("--trajectory", *trajectory,
                   "the poses, TUM format as trajectory.txt (camera to volume frame): each frame "
                   "whose stamp has a line is integrated there; the others are left out")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("-o,--out", outputs->dir, "output folder")->required();
  command->add_flag("--overwrite", outputs->overwrite,
                    "replace an earlier run in the output folder once the fusion is complete (a "
                    "fusion that fails leaves it as it was)");
  command->add_flag("!--no-mesh", outputs->mesh, "do not write mesh.ply");
  command->add_flag("--cloud", outputs->cloud, "also write cloud.ply (the last raycast)");
  command->add_flag("--save-volume", outputs->save_volume,
                    "also write the map (volume.kfxtsdf, or map.kfxblocks with volume=blocks)");
  command->add_flag("--renders", outputs->renders,
                    "write the renders as PNG under DIR/renders/ every render_rate frames");
  command->add_flag("!--no-report", outputs->report, "do not write report.html");
  command->callback([options, outputs, trajectory] {
    RunOutputs given = *outputs;
    given.given_poses = io::read_tum_trajectory(*trajectory);
    KFX_CHECK(!given.given_poses.empty(), *trajectory << ": no pose in the file");
    given.given_poses_label = *trajectory;
    given.command_name = "kfx fuse";
    // Replacing an earlier run, the fusion writes into a staging folder first: deleting the
    // earlier outputs before it could fail (an input that yields no frame at the poses, a full
    // disk, Ctrl-C) would leave neither run.
    if (given.overwrite) {
      run_sequence_staged(*options, given, kFuseStagingFolder);
    } else {
      run_sequence(*options, given);
    }
  });
}

}  // namespace kfx::cli
