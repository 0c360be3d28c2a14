/// Settings strings: `key=value` assignments (--set, SLAMBench flags) applied to a preset and
/// validated, and synthetic input specs.

#include "core/platform.hpp"
#include "fuzz_support.hpp"
#include "io/synthetic.hpp"
#include "pipeline/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text = kfx::fuzz::as_text(data, size);
  try {
    kfx::PipelineConfig config = kfx::make_preset("exact");
    // Several assignments separated by newlines, as repeated --set options.
    size_t start = 0;
    while (start <= text.size()) {
      const size_t end = std::min(text.find('\n', start), text.size());
      kfx::set_config_assignment(config, text.substr(start, end - start));
      start = end + 1;
    }
    config.validate();
    config.dump();
  } catch (const kfx::Error&) {
  }
  try {
    kfx::io::parse_synthetic_spec("synthetic:" + text);
  } catch (const kfx::Error&) {
  }
  return 0;
}
