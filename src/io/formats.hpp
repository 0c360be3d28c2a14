#pragma once
/// Internal: the per-format reader factories behind open_reader(), and constants they share.
/// Callers outside src/io/ use open_reader() (reader.hpp) instead.

#include <memory>
#include <string>
#include <vector>

#include "io/reader.hpp"

namespace kfx::io {

/// ICL-NUIM's true camera at 640×480 (fy negative: the renderer's image y points up).
inline constexpr Intrinsics kIclNuimIntrinsics{481.2f, -480.0f, 319.5f, 239.5f};

/// Default raw PNG depth units per metre of TUM RGB-D and ICL-NUIM PNG depth images.
inline constexpr double kPngDepthScalePerM = 5000.0;

/// Opens a TUM RGB-D folder (depth.txt or an associations file), or one such listing file.
/// Ground truth comes from groundtruth.txt unless `options.ground_truth_path` is set (the
/// caller applies that override).
std::unique_ptr<Reader> open_tum_folder(const std::string& path, const ReaderOptions& options);

/// Opens an ICL-NUIM PNG folder (associations.txt, depth/n.png, *.gt.freiburg).
std::unique_ptr<Reader> open_icl_png_folder(const std::string& folder,
                                            const ReaderOptions& options);

/// Opens an ICL-NUIM native POV-Ray folder (scene_00_NNNN.depth and .txt, *.gt.freiburg).
std::unique_ptr<Reader> open_icl_native_folder(const std::string& folder,
                                               const ReaderOptions& options);

/// Opens an OpenNI 2 recording (.oni) through OpenNI 2's player; throws kfx::Error naming the
/// file when kfx was built without OpenNI2 or the file is not a readable recording.
std::unique_ptr<Reader> open_oni_recording(const std::string& path);

/// How an input names an OpenNI2 device: `openni2:` (the first device), `openni2:URI`.
inline constexpr const char* kOpenNI2Prefix = "openni2:";

/// Opens an OpenNI2 device, `input` being `openni2:[URI][?real_time=on|off&colour=on|off]`: the
/// first device OpenNI2 finds, the one at URI, or an .oni recording (a URI OpenNI2 plays as a
/// device, at its recorded pace unless real_time=off). Throws kfx::Error naming the device when
/// kfx was built without OpenNI2, no device is found, or its streams cannot be read.
std::unique_ptr<Reader> open_openni2_device(const std::string& input);

/// True when `folder` holds ICL-NUIM native depth files (scene_00_NNNN.depth).
bool has_icl_native_files(const std::string& folder);

}  // namespace kfx::io
