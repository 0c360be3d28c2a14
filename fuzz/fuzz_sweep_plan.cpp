/// Sweep plans: arbitrary JSON text parsed, its sequences resolved and every run × sequence
/// validated (configurations built), as `kfx sweep --dry-run` does; also the command line's
/// per-sequence settings strings.

#include "core/platform.hpp"
#include "fuzz_support.hpp"
#include "study/sweep_plan.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text = kfx::fuzz::as_text(data, size);
  try {
    const kfx::sweep::SweepPlan plan = kfx::sweep::parse_sweep_plan(text, "fuzz", "/nonexistent");
    const auto sequences = kfx::sweep::resolve_sequences(plan, kfx::sweep::SequenceOptions{});
    const auto runs = kfx::sweep::select_runs(plan, {});
    kfx::sweep::validate_sweep(runs, sequences);
  } catch (const kfx::Error&) {
  }
  try {
    kfx::sweep::parse_sequence_settings(text);
  } catch (const kfx::Error&) {
  }
  return 0;
}
