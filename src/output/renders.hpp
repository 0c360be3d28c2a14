#pragma once
/// The renders of a run as PNG files: DIR/renders/{depth,track,volume}_NNNNNN.png, NNNNNN the
/// frame number as in slambench.log.

#include <string>

#include "backend/backend.hpp"

namespace kfx::output {

/// Sub-folder of the output folder that holds the renders.
constexpr const char* kRendersFolder = "renders";

/// Path of one render: `out_dir`/renders/`kind`_NNNNNN.png (kind: depth, track or volume).
std::string render_path(const std::string& out_dir, const std::string& kind, int frame);

/// Writes frame `frame`'s three renders (each PNG atomically), creating the folder if needed.
/// Throws kfx::Error naming the file that cannot be written.
void write_renders(const std::string& out_dir, int frame, const Renders& renders);

}  // namespace kfx::output
