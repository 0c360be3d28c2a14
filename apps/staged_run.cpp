#include "staged_run.hpp"

#include <exception>
#include <filesystem>

#include "core/platform.hpp"
#include "output/run_folder.hpp"

namespace kfx::cli {
namespace {

namespace fs = std::filesystem;

/// Removes the staging folder when the run fails (and the output folder, when the run created
/// it and it is left empty), so the earlier outputs are all that remains.
class StagingCleanup {
 public:
  StagingCleanup(std::string staging, std::string out_dir)
      : staging_(std::move(staging)), out_dir_(std::move(out_dir)), existed_(fs::exists(out_dir_)) {
    std::error_code ec;
    fs::remove_all(staging_, ec);  // a killed run's leftover
    KFX_CHECK(!ec, "cannot remove the leftover '" << staging_ << "': " << ec.message());
  }
  ~StagingCleanup() {
    if (std::uncaught_exceptions() == 0) return;
    std::error_code ec;
    fs::remove_all(staging_, ec);
    if (!existed_ && fs::is_empty(out_dir_, ec) && !ec) fs::remove(out_dir_, ec);
  }
  StagingCleanup(const StagingCleanup&) = delete;
  StagingCleanup& operator=(const StagingCleanup&) = delete;

 private:
  std::string staging_, out_dir_;
  bool existed_;
};

}  // namespace

void run_sequence_staged(const RunOptions& options, RunOutputs outputs,
                         const std::string& staging_name) {
  const std::string out_dir = outputs.dir;
  const std::string staging = out_dir + "/" + staging_name;
  outputs.dir = staging;
  outputs.final_dir = out_dir;
  outputs.overwrite = true;  // the staging folder is this run's own
  const StagingCleanup cleanup(staging, out_dir);
  run_sequence(options, outputs);
  output::replace_run_outputs(staging, out_dir);
}

}  // namespace kfx::cli
