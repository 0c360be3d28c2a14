#pragma once
/// The loops as stats.json's loop_closure section lists them, for kfx run's online closure and
/// kfx optimise's offline one alike.

#include <nlohmann/json.hpp>
#include <vector>

#include "io/trajectory.hpp"
#include "loop/loop_record.hpp"

namespace kfx::loop {

/// One object per loop of `loops`: its keyframes' trajectory indices and stamps (`trajectory`:
/// the run's poses, indexed as the records' from_pose and to_pose), who proposed it, the
/// verification's verdict and figures, what a verified loop asks of the odometry (path_m,
/// correction_m, correction_rad) and what the pose graph made of it.
nlohmann::json loop_records_json(const std::vector<LoopRecord>& loops,
                                 const std::vector<io::StampedPose>& trajectory);

}  // namespace kfx::loop
