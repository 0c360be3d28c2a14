#include "output/run_config.hpp"

#include "io/atomic_file.hpp"

namespace kfx::output {

void write_run_config(const std::string& path, const PipelineConfig& config,
                      const std::string& preset) {
  io::AtomicFile file(path);
  file.stream() << "# kfx " << KFX_VERSION << " configuration (preset " << preset << ")\n"
                << config.dump();
  file.commit();
}

}  // namespace kfx::output
