#include "eval/divergence.hpp"

#include <cmath>

#include "core/platform.hpp"

namespace kfx::eval {

DivergenceResult compute_divergence(const AteResult& ate, const Association& association,
                                    const std::vector<io::StampedPose>& est, double bound_m) {
  KFX_CHECK(std::isfinite(bound_m) && bound_m > 0.0,
            "divergence: the bound must be a positive number of metres, got " << bound_m);
  KFX_CHECK(ate.errors_m.size() == association.pairs.size(),
            "divergence: " << ate.errors_m.size() << " ATE errors for "
                           << association.pairs.size() << " associated poses");
  DivergenceResult result;
  result.bound_m = bound_m;
  result.frames_evaluated = ate.errors_m.size();
  for (std::size_t k = 0; k < ate.errors_m.size(); ++k) {
    if (!(ate.errors_m[k] > bound_m)) continue;
    ++result.frames_over;
    if (result.any_over) continue;
    const std::size_t index = association.pairs[k].est_index;
    KFX_CHECK(index < est.size(), "divergence: pair " << k << " indexes outside the estimate");
    result.any_over = true;
    result.first_over_index = index;
    result.first_over_stamp_s = est[index].stamp_s;
  }
  return result;
}

}  // namespace kfx::eval
