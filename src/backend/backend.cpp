/// Backend selection shared by both builds.

#include "backend/backend.hpp"

#include <cstdlib>
#include <new>

#include "backend/frame_buffers.hpp"
#include "backend/memory_budget.hpp"

namespace kfx {

#if defined(KFX_HAVE_CUDA)
// Defined in src/backend/cuda/.
bool cuda_device_present(std::string* why_not);
int cuda_visible_device_count();
void cuda_select_device(int index);
std::unique_ptr<Backend> make_cuda_backend(const BackendSetup& setup);
uint64_t cuda_free_bytes();
#endif

namespace {

/// The CPU backend after checking that its buffers fit in the host's available memory.
std::unique_ptr<Backend> make_checked_cpu_backend(const BackendSetup& setup) {
  const uint64_t needed = backend_bytes_needed(setup);
  check_memory_fits(setup, needed, host_bytes_available(),
                    "the host's available memory (MemAvailable in /proc/meminfo)");
  try {
    return make_cpu_backend(setup);
  } catch (const std::bad_alloc&) {
    // The estimate fitted but the allocation failed (overcommit limits, other processes).
    KFX_FAIL("not enough host memory: the CPU backend could not allocate its buffers (about "
             << static_cast<double>(needed) / (1024.0 * 1024.0 * 1024.0) << " GiB for a "
             << setup.volume_res_vox << "^3 volume)");
  }
}

}  // namespace

const char* stage_name(Stage stage) {
  switch (stage) {
    case Stage::kPreprocess:
      return "preprocess";
    case Stage::kTrack:
      return "track";
    case Stage::kIntegrate:
      return "integrate";
    case Stage::kRaycast:
      return "raycast";
    case Stage::kRender:
      return "render";
    default:
      return "?";
  }
}

void check_depth_frame(ImageView<const uint16_t> depth_mm, const BackendSetup& setup) {
  KFX_CHECK(depth_mm.width == setup.input_width_px && depth_mm.height == setup.input_height_px,
            "depth frame is " << depth_mm.width << "x" << depth_mm.height
                              << ", the pipeline was set up for " << setup.input_width_px << "x"
                              << setup.input_height_px);
  KFX_CHECK(depth_mm.pitch == depth_mm.width && depth_mm.data != nullptr,
            "depth frame rows are not packed (pitch " << depth_mm.pitch << " for width "
                                                      << depth_mm.width << ")");
}

void check_colour_frame(ImageView<const Rgb8> rgb, const BackendSetup& setup) {
  KFX_CHECK(setup.colour || setup.photometric,
            "a colour image was given but the pipeline was set up without colour (colour off, "
            "photometric_weight 0)");
  KFX_CHECK(rgb.width == setup.input_width_px && rgb.height == setup.input_height_px &&
                rgb.pitch == rgb.width,
            "colour image is " << rgb.width << "x" << rgb.height << ", the pipeline was set up for "
                               << setup.input_width_px << "x" << setup.input_height_px
                               << " (the depth image's size)");
}

void check_colour_volume_upload(const std::vector<ColourVoxel>& /*colours*/,
                                const BackendSetup& setup) {
  KFX_CHECK(setup.colour, "a colour field was given but the pipeline was set up without colour");
  KFX_CHECK(setup.map_kind == MapKind::kDense,
            "a dense colour field cannot be loaded into a block map (its blocks carry colour)");
}

void check_colour_field_size(const std::vector<ColourVoxel>& colours, size_t field_size) {
  KFX_CHECK(colours.size() == field_size, "colour field of " << colours.size()
                                                             << " voxels given, the backend holds "
                                                             << field_size);
}

BackendKind parse_backend_kind(const std::string& text) {
  if (text == "cpu") return BackendKind::kCpu;
  if (text == "cuda") return BackendKind::kCuda;
  if (text == "auto") return BackendKind::kAuto;
  KFX_FAIL("unknown backend '" << text << "' (expected cpu, cuda or auto)");
}

bool cuda_available(std::string* why_not) {
#if defined(KFX_HAVE_CUDA)
  return cuda_device_present(why_not);
#else
  if (why_not) *why_not = "this kfx was built without the CUDA backend (nvcc was not found)";
  return false;
#endif
}

int cuda_device_count() {
#if defined(KFX_HAVE_CUDA)
  return cuda_visible_device_count();
#else
  return 0;
#endif
}

void allow_many_cuda_streams() {
  setenv("CUDA_DEVICE_MAX_CONNECTIONS", "32", /*overwrite=*/0);  // 32: CUDA's maximum
}

std::unique_ptr<Backend> make_backend(BackendKind kind, const BackendSetup& setup) {
  KFX_CHECK(kind != BackendKind::kCpu || setup.device_index < 0,
            "a GPU index (" << setup.device_index << ") was given for the CPU backend; GPU "
                            << "indices apply to the CUDA backend only");
  if (kind == BackendKind::kCpu) return make_checked_cpu_backend(setup);
  std::string why_not;
  const bool have_cuda = cuda_available(&why_not);
  if (kind == BackendKind::kCuda || setup.device_index >= 0) {
    KFX_CHECK(have_cuda, "the CUDA backend was requested but " << why_not);
  }
#if defined(KFX_HAVE_CUDA)
  if (have_cuda) {
    // Before anything touches the device: the memory check and the backend's streams, buffers
    // and graphs all belong to the current device.
    if (setup.device_index >= 0) cuda_select_device(setup.device_index);
    check_memory_fits(setup, backend_bytes_needed(setup), cuda_free_bytes(), "free GPU memory");
    return make_cuda_backend(setup);
  }
#endif
  return make_checked_cpu_backend(setup);
}

}  // namespace kfx
