#pragma once
/// kfx's public API: KinectFusion (dense RGB-D SLAM) for CPUs and NVIDIA GPUs.
///
///   kfx::Sequence sequence("synthetic:frames=40");
///   kfx::Reconstruction reconstruction(kfx::Settings("exact").backend("cpu"), sequence);
///   kfx::SequenceFrame frame;
///   while (sequence.next(frame) == kfx::ReadStatus::kOk) reconstruction.process(frame);
///   reconstruction.save_mesh("mesh.ply");
///
/// Every error is a kfx::Error whose message names the problem.

#include "kfx/camera.hpp"
#include "kfx/error.hpp"
#include "kfx/frame.hpp"
#include "kfx/model.hpp"
#include "kfx/reconstruction.hpp"
#include "kfx/sequence.hpp"
#include "kfx/settings.hpp"
