/// The CUDA backend: the whole frame on the device. Every buffer is allocated once; stages are
/// thin launches of the shared kernel bodies on one non-blocking stream; decisions stay in the
/// device-side TrackingState. Each frame shape (which stages run) is recorded once as a CUDA
/// graph and replayed; the depth upload for a frame goes through pinned memory on a second
/// stream, and the state after the frame comes back asynchronously into pinned memory.
/// KFX_CUDA_SYNC=1 turns graphs off and synchronises after every launch (debugging).

#include <algorithm>
#include <array>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <utility>

#include "backend/backend.hpp"
#include "backend/block_map_mesh.hpp"
#include "backend/cuda/cuda_block_map.cuh"
#include "backend/cuda/cuda_icp_persistent.cuh"
#include "backend/cuda/cuda_kernels.cuh"
#include "backend/cuda/cuda_memory.hpp"
#include "backend/cuda/cuda_mesh.hpp"
#include "backend/frame_buffers.hpp"
#include "backend/memory_budget.hpp"
#include "kernels/camera_move.hpp"
#include "map/map_set.hpp"

namespace kfx {

uint64_t cuda_free_bytes();  // cuda_memory_info.cpp

bool cuda_device_present(std::string* why_not) {
  int count = 0;
  const cudaError_t status = cudaGetDeviceCount(&count);
  if (status != cudaSuccess || count == 0) {
    // Without a GPU the runtime finds no driver and says the driver is "insufficient": say
    // what the user needs to know instead.
    const bool driver_loaded = std::filesystem::exists("/proc/driver/nvidia/version");
    if (why_not) {
      if (count == 0 && (status == cudaSuccess || status == cudaErrorNoDevice || !driver_loaded)) {
        *why_not = std::string("this machine has no NVIDIA GPU") +
                   (driver_loaded ? "" : " (no NVIDIA driver is loaded)") + "; use --backend cpu";
      } else {
        *why_not = std::string("no usable CUDA device (") + cudaGetErrorString(status) + ")";
      }
    }
    cudaGetLastError();  // clear the sticky error of a failed query
    return false;
  }
  return true;
}

int cuda_visible_device_count() {
  int count = 0;
  if (cudaGetDeviceCount(&count) != cudaSuccess) {
    cudaGetLastError();  // clear the sticky error of a failed query
    return 0;
  }
  return count;
}

void cuda_select_device(int index) {
  const int count = cuda_visible_device_count();
  KFX_CHECK(index >= 0 && index < count, "GPU " << index << " does not exist: " << count
                                                << " CUDA device" << (count == 1 ? " is" : "s are")
                                                << " visible (indices 0 to " << count - 1 << ")");
  KFX_CUDA_CHECK(cudaSetDevice(index));
}

namespace cuda {
namespace {

constexpr int kStages = static_cast<int>(Stage::kCount);

dim3 grid_for(int width, int height, dim3 block) {
  return dim3((width + block.x - 1) / block.x, (height + block.y - 1) / block.y);
}

/// The CUDA backend's map: device memory, the device block map.
using DeviceMap = VoxelMap<DeviceMemory, DeviceBlockMap>;

/// The map `setup` asks for (BackendSetup::map_kind), not yet cleared; a block map's per-frame
/// key list is sized for `compute_pixels` (new_key_capacity_for).
DeviceMap make_device_map(const BackendSetup& setup, int compute_pixels) {
  if (setup.map_kind == MapKind::kBlocks) {
    return DeviceMap(DeviceBlockMap(setup.block_capacity, setup.volume_res_vox, setup.volume_size_m,
                                    setup.colour, new_key_capacity_for(compute_pixels)));
  }
  return DeviceMap(DeviceMap::Cube(setup.volume_res_vox, setup.volume_size_m, setup.colour));
}

class CudaBackend final : public Backend {
 public:
  explicit CudaBackend(const BackendSetup& setup) : setup_(setup), buffers_(setup) {
    KFX_CUDA_CHECK(cudaGetDevice(&device_));
    KFX_CUDA_CHECK(cudaGetDeviceProperties(&properties_, device_));
    const char* sync = std::getenv("KFX_CUDA_SYNC");
    debug_sync_ = sync && std::string(sync) == "1";
    // Programmatic dependent launch needs sm_90 (its gain on an H200: bench/RESULTS.md, "CUDA
    // backend, exact preset, 320×240"); setting cuda_pdl=off turns it off.
    programmatic_launch_ = setup.cuda.pdl && properties_.major >= 9;
    const int w = setup.compute_width_px(), h = setup.compute_height_px();
    const size_t input_pixels = static_cast<size_t>(setup.input_width_px) * setup.input_height_px;
    staged_pose_ = DeviceBuffer<Mat4f>(1);
    for (int p = 0; p < 2; ++p) {
      input_mm_[p] = DeviceBuffer<uint16_t>(input_pixels);
      staging_mm_[p] = PinnedBuffer<uint16_t>(input_pixels);
      state_readback_[p] = PinnedBuffer<TrackingState>(1);
      // A staged pose for relocalisation's attempts and for frames at given poses.
      staged_pose_host_[p] = PinnedBuffer<Mat4f>(1);
      if (setup.colour || setup.photometric) {
        input_rgb_[p] = DeviceBuffer<Rgb8>(input_pixels);
        staging_rgb_[p] = PinnedBuffer<Rgb8>(input_pixels);
      }
    }
    // Tuning (settings cuda_reduce_blocks, cuda_z_chunks): the cap on the ICP reduction grid
    // (0: one block per SM) and the z-ranges per integration column (0: 4096 / resolution, the
    // fastest of 2..64 on an H200 at 256³ and at 512³, bench/RESULTS.md).
    const int max_blocks =
        setup.cuda.reduce_blocks > 0 ? setup.cuda.reduce_blocks : properties_.multiProcessorCount;
    reduce_blocks_ = std::max(1, std::min((w * h + kReduceBlock - 1) / kReduceBlock, max_blocks));
    z_chunks_ = std::max(1, setup.cuda.z_chunks > 0 ? setup.cuda.z_chunks
                                                    : 4096 / std::max(1, setup.volume_res_vox));
    partials_ = DeviceBuffer<double>(static_cast<size_t>(reduce_blocks_) * kAccumulatorSize);
    if (setup.cuda.icp_persistent) {
      // Setting cuda_icp_persistent: one cooperative launch per pyramid level. Results are the
      // same either way, so where the device cannot launch it, ICP falls back (and says so).
      std::string why_not;
      persistent_icp_blocks_ =
          std::min(persistent_icp_max_blocks(device_, &why_not),
                   persistent_icp_grid(properties_.multiProcessorCount, setup.pipelines_on_device));
      if (persistent_icp_blocks_ > 0) {
        level_partials_ =
            DeviceBuffer<double>(2 * static_cast<size_t>(reduce_blocks_) * kAccumulatorSize);
        level_barrier_ = DeviceBuffer<unsigned int>(2);
        KFX_CUDA_CHECK(
            cudaMemsetAsync(level_barrier_.data(), 0, level_barrier_.bytes(), stream_.get()));
      } else {
        std::cerr << "kfx: cuda_icp_persistent=on is not possible here (" << why_not
                  << "); ICP runs one launch per iteration instead\n";
      }
    }
    blocks_done_ = DeviceBuffer<unsigned int>(1);
    KFX_CUDA_CHECK(cudaMemsetAsync(blocks_done_.data(), 0, sizeof(unsigned int), stream_.get()));
    // Setting cuda_fused_preprocess: preprocess and pyramid in one launch each (the same bits).
    fused_preprocess_ = setup.cuda.fused_preprocess;
    max_depth_scratch_ = DeviceBuffer<unsigned int>(2);
    KFX_CUDA_CHECK(
        cudaMemsetAsync(max_depth_scratch_.data(), 0, max_depth_scratch_.bytes(), stream_.get()));
    // Setting depth_undistortion: the table mm -> m reads, uploaded once (it never changes).
    if (!setup.depth_source_px.empty()) {
      const auto& table = setup.depth_source_px;
      source_px_ = DeviceImage<SourcePixel>(table.width(), table.height());
      KFX_CUDA_CHECK(cudaMemcpyAsync(source_px_.data(), table.data(), source_px_.bytes(),
                                     cudaMemcpyHostToDevice, stream_.get()));
    }
    // Pixels an ICP stride skips stay 0 ("not tracked" in the track render), as on the CPU.
    KFX_CUDA_CHECK(cudaMemsetAsync(buffers_.track_outcome.data(), 0, buffers_.track_outcome.bytes(),
                                   stream_.get()));
    state_ = DeviceBuffer<TrackingState>(1);
    maps_ = std::make_unique<MapSet<DeviceMap>>(make_device_map(setup, w * h));
    map().clear(DeviceMemory{stream_.get()});
    map_grid_ = std::max(1, properties_.multiProcessorCount * kMapBlocksPerSm);
    for (auto& parity : stage_events_) {
      for (auto& stage : parity) {
        stage[0] = std::make_unique<Event>();
        stage[1] = std::make_unique<Event>();
      }
    }
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
  }

  ~CudaBackend() override { cudaStreamSynchronize(stream_.get()); }

  std::string name() const override { return "cuda"; }
  std::string device_name() const override {
    return std::string(properties_.name) + ", " + std::to_string(properties_.multiProcessorCount) +
           " SMs, compute capability " + std::to_string(properties_.major) + "." +
           std::to_string(properties_.minor);
  }

  std::string device_pci_bus_id() const override {
    char bus_id[32] = {};
    if (cudaDeviceGetPCIBusId(bus_id, sizeof(bus_id), device_) != cudaSuccess) {
      cudaGetLastError();  // clear the error of a failed query; no id means NVML device 0
      return "";
    }
    return bus_id;
  }

  void reset(const Mat4f& T_world_cam) override {
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    map().clear(DeviceMemory{stream_.get()});
    *state_readback_[0].data() = initial_tracking_state(T_world_cam);
    KFX_CUDA_CHECK(cudaMemcpyAsync(state_.data(), state_readback_[0].data(), sizeof(TrackingState),
                                   cudaMemcpyHostToDevice, stream_.get()));
    KFX_CUDA_CHECK(
        cudaMemsetAsync(buffers_.ref_vertex.data(), 0, buffers_.ref_vertex.bytes(), stream_.get()));
    KFX_CUDA_CHECK(
        cudaMemsetAsync(max_depth_scratch_.data(), 0, max_depth_scratch_.bytes(), stream_.get()));
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    pending_.clear();
    frames_submitted_ = 0;
  }

  int create_map() override {
    KFX_CHECK(!in_frame_, "create_map() inside a frame (between begin_frame and end_frame)");
    check_another_map_fits(setup_, maps_->count(), cuda_free_bytes(), "free GPU memory");
    // Allocated outside any recording (cudaMalloc may not run in a capture), cleared in stream
    // order: frames in flight do not touch the new map.
    DeviceMap map = make_device_map(setup_, setup_.compute_width_px() * setup_.compute_height_px());
    map.clear(DeviceMemory{stream_.get()});
    return maps_->add(std::move(map));
  }

  void select_map(int handle) override {
    KFX_CHECK(!in_frame_, "select_map() inside a frame (between begin_frame and end_frame)");
    maps_->select(handle);
    // The state's block count is the selected map's, as a frame's allocation leaves it; in
    // stream order, after the frames in flight (which count their own map).
    if (map().kind() == MapKind::kBlocks) {
      KFX_CUDA_CHECK(cudaMemcpyAsync(&state_.data()->map_blocks,
                                     &map().blocks("select_map()").args().counts->blocks,
                                     sizeof(int), cudaMemcpyDeviceToDevice, stream_.get()));
    }
  }

  int map_count() const override { return maps_->count(); }
  int selected_map() const override { return maps_->selected(); }

  void set_pose(const Mat4f& T_world_cam) override {
    // The readback buffer is free only while no frame's state waits in it.
    KFX_CHECK(pending_.empty(), "set_pose() with a frame in flight");
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    TrackingState& host = *state_readback_[0].data();
    KFX_CUDA_CHECK(cudaMemcpy(&host, state_.data(), sizeof(TrackingState), cudaMemcpyDeviceToHost));
    move_camera(host, T_world_cam);
    KFX_CUDA_CHECK(cudaMemcpy(state_.data(), &host, sizeof(TrackingState), cudaMemcpyHostToDevice));
  }

  void upload_depth(ImageView<const uint16_t> depth_mm) override {
    check_depth_frame(depth_mm, setup_);
    parity_ = frames_submitted_ % 2;
    // The frame two back used these buffers: wait until it has finished with them.
    KFX_CUDA_CHECK(cudaEventSynchronize(frame_done_[parity_].get()));
    std::memcpy(staging_mm_[parity_].data(), depth_mm.data, depth_mm.size() * sizeof(uint16_t));
    KFX_CUDA_CHECK(cudaMemcpyAsync(input_mm_[parity_].data(), staging_mm_[parity_].data(),
                                   depth_mm.size() * sizeof(uint16_t), cudaMemcpyHostToDevice,
                                   copy_stream_.get()));
    KFX_CUDA_CHECK(cudaEventRecord(upload_done_[parity_].get(), copy_stream_.get()));
  }

  void upload_colour(ImageView<const Rgb8> rgb) override {
    check_colour_frame(rgb, setup_);
    // After upload_depth(), which waited for the frame two back: these buffers are free.
    const size_t bytes = static_cast<size_t>(rgb.size()) * sizeof(Rgb8);
    std::memcpy(staging_rgb_[parity_].data(), rgb.data, bytes);
    KFX_CUDA_CHECK(cudaMemcpyAsync(input_rgb_[parity_].data(), staging_rgb_[parity_].data(), bytes,
                                   cudaMemcpyHostToDevice, copy_stream_.get()));
    KFX_CUDA_CHECK(cudaEventRecord(upload_done_[parity_].get(), copy_stream_.get()));
  }

  void begin_frame(int shape) override {
    KFX_CUDA_CHECK(cudaStreamWaitEvent(stream_.get(), upload_done_[parity_].get(), 0));
    in_frame_ = true;
    // A recording captures the selected map's addresses: each map has recordings of its own.
    graph_key_ = GraphKey{maps_->selected(), shape * 2 + parity_};
    replaying_ = !debug_sync_ && graphs_.count(graph_key_) > 0;
    capturing_ = !debug_sync_ && !replaying_;
    if (capturing_) {
      KFX_CUDA_CHECK(cudaStreamBeginCapture(stream_.get(), cudaStreamCaptureModeThreadLocal));
    }
  }

  void end_frame() override {
    if (!replaying_) {
      KFX_CUDA_CHECK(cudaMemcpyAsync(state_readback_[parity_].data(), state_.data(),
                                     sizeof(TrackingState), cudaMemcpyDeviceToHost, stream_.get()));
    }
    if (capturing_) {
      cudaGraph_t graph = nullptr;
      KFX_CUDA_CHECK(cudaStreamEndCapture(stream_.get(), &graph));
      graphs_.emplace(graph_key_, GraphExec(graph));
      capturing_ = false;
      replaying_ = true;
    }
    if (replaying_) graphs_.at(graph_key_).launch(stream_.get());
    replaying_ = false;
    in_frame_ = false;
    KFX_CUDA_CHECK(cudaEventRecord(frame_done_[parity_].get(), stream_.get()));
    pending_.push_back(parity_);
    ++frames_submitted_;
  }

  void stage_pose(const Mat4f& T_world_cam) override {
    // upload_depth() waited for the frame two back, the last reader of this parity's buffer.
    *staged_pose_host_[parity_].data() = T_world_cam;
    KFX_CUDA_CHECK(cudaMemcpyAsync(staged_pose_.data(), staged_pose_host_[parity_].data(),
                                   sizeof(Mat4f), cudaMemcpyHostToDevice, stream_.get()));
  }

  void adopt_staged_pose() override {
    if (replaying_) return;
    launch(adopt_pose_kernel, dim3(1), dim3(1), state_.data(),
           static_cast<const Mat4f*>(staged_pose_.data()));
  }

  void preprocess(const BilateralParams& p) override {
    if (replaying_) return;
    const int w = setup_.compute_width_px(), h = setup_.compute_height_px();
    if (fused_preprocess_) {
      const MmToMArgs mm{input_view(), buffers_.depth_m.view(), setup_.compute_ratio, p.max_depth_m,
                         source_px_.view()};
      const PreprocessArgs a{p, mm, buffers_.level_depth[0].view()};
      const dim3 tile(kTileWidthPx, kTileHeightPx);
      launch(preprocess_kernel, grid_for(w, h, tile), tile, a, state_.data(),
             max_depth_scratch_.data());
      if (setup_.photometric) build_intensity();
      return;
    }
    KFX_CUDA_CHECK(cudaMemsetAsync(&state_.data()->max_depth_m, 0, sizeof(float), stream_.get()));
    const MmToMArgs mm{input_view(), buffers_.depth_m.view(), setup_.compute_ratio, p.max_depth_m,
                       source_px_.view()};
    const dim3 block(32, 8);
    launch(mm_to_m_kernel, grid_for(w, h, block), block, mm, state_.data());
    const BilateralArgs b{p, buffers_.depth_m.view(), buffers_.level_depth[0].view()};
    launch(pixel_kernel<BilateralBody, BilateralArgs>, grid_for(w, h, block), block, b, w, h);
    if (setup_.photometric) build_intensity();
  }

  /// This frame's intensity pyramid (photometric term) from its colour image.
  void build_intensity() {
    const dim3 block(32, 8);
    const ImageView<const Rgb8> rgb{input_rgb_[parity_].data(), setup_.input_width_px,
                                    setup_.input_height_px, setup_.input_width_px};
    const IntensityArgs a{rgb, buffers_.level_intensity[0].view(), setup_.compute_ratio};
    launch(pixel_kernel<IntensityBody, IntensityArgs>, grid_for(a.out.width, a.out.height, block),
           block, a, a.out.width, a.out.height);
    for (int l = 1; l < setup_.pyramid_levels; ++l) {
      const HalfIntensityArgs h{buffers_.level_intensity[l - 1].view(),
                                buffers_.level_intensity[l].view()};
      launch(pixel_kernel<HalfIntensityBody, HalfIntensityArgs>,
             grid_for(h.out.width, h.out.height, block), block, h, h.out.width, h.out.height);
    }
  }

  void keep_intensity(bool always) override {
    if (replaying_ || !setup_.photometric) return;
    const dim3 block(32, 8);
    for (int l = 0; l < setup_.pyramid_levels; ++l) {
      const KeepIntensityArgs a{buffers_.level_intensity[l].view(),
                                buffers_.ref_intensity[l].view(), state_.data(), always ? 1 : 0};
      launch(pixel_kernel<KeepIntensityBody, KeepIntensityArgs>,
             grid_for(a.current.width, a.current.height, block), block, a, a.current.width,
             a.current.height);
    }
    launch(keep_intensity_pose_kernel, dim3(1), dim3(1), state_.data(), always ? 1 : 0);
  }

  void build_pyramid(const PyramidParams& p) override {
    if (replaying_) return;
    if (fused_preprocess_) return build_pyramid_fused(p);
    const dim3 block(32, 8);
    for (int l = 1; l < setup_.pyramid_levels; ++l) {
      const HalfSampleArgs a{buffers_.level_depth[l - 1].view(), buffers_.level_depth[l].view(),
                             p.half_sample_range_m};
      launch(pixel_kernel<HalfSampleBody, HalfSampleArgs>,
             grid_for(a.out_m.width, a.out_m.height, block), block, a, a.out_m.width,
             a.out_m.height);
    }
    for (int l = 0; l < setup_.pyramid_levels; ++l) {
      const DepthToVertexArgs v{buffers_.level_depth[l].view(), buffers_.level_vertex[l].view(),
                                p.level_intrinsics[l].inverse_matrix()};
      const int w = v.vertex.width, h = v.vertex.height;
      launch(pixel_kernel<DepthToVertexBody, DepthToVertexArgs>, grid_for(w, h, block), block, v, w,
             h);
      const VertexToNormalArgs n{buffers_.level_vertex[l].view(), buffers_.level_normal[l].view(),
                                 p.level_intrinsics[l].handedness()};
      launch(pixel_kernel<VertexToNormalBody, VertexToNormalArgs>, grid_for(w, h, block), block, n,
             w, h);
    }
  }

  /// Every level's depth, vertices and normals in one launch (pyramid_kernel).
  void build_pyramid_fused(const PyramidParams& p) {
    PyramidArgs a;
    a.levels = setup_.pyramid_levels;
    a.half_sample_range_m = p.half_sample_range_m;
    PyramidGrid grid;
    for (int l = 0; l < a.levels; ++l) {
      a.depth_m[l] = buffers_.level_depth[l].view();
      a.vertex[l] = buffers_.level_vertex[l].view();
      a.normal[l] = buffers_.level_normal[l].view();
      a.inverse_k[l] = p.level_intrinsics[l].inverse_matrix();
      a.handedness[l] = p.level_intrinsics[l].handedness();
      const dim3 tiles =
          grid_for(a.vertex[l].width, a.vertex[l].height, dim3(kTileWidthPx, kTileHeightPx));
      grid.blocks_across[l] = static_cast<int>(tiles.x);
      grid.first_block[l + 1] = grid.first_block[l] + static_cast<int>(tiles.x * tiles.y);
    }
    launch(pyramid_kernel, dim3(grid.first_block[a.levels]), dim3(kTileWidthPx, kTileHeightPx), a,
           grid);
  }

  void begin_tracking(const IcpGuessParams& p) override {
    if (replaying_) return;
    launch(begin_tracking_kernel, dim3(1), dim3(1), state_.data(), p);
  }

  void icp_iteration(int level, const IcpParams& p) override {
    if (replaying_) return;
    const TrackArgs a = buffers_.track_args(level, p, state_.data());
    launch(a.photometric.weight > 0.0f ? icp_iteration_kernel<true> : icp_iteration_kernel<false>,
           dim3(icp_reduce_blocks(a)), dim3(kReduceBlock), a, state_.data(), partials_.data(),
           blocks_done_.data(), level);
  }

  void icp_level(int level, int iterations, const IcpParams& p) override {
    if (persistent_icp_blocks_ == 0) return Backend::icp_level(level, iterations, p);
    if (replaying_ || iterations <= 0) return;
    const TrackArgs a = buffers_.track_args(level, p, state_.data());
    launch_icp_level(stream_.get(), persistent_icp_blocks_, a, state_.data(),
                     level_partials_.data(), level_barrier_.data(), level, iterations,
                     icp_reduce_blocks(a));
    launched();
  }

  void accept_or_revert(const AcceptParams& p) override {
    if (replaying_) return;
    launch(accept_kernel, dim3(1), dim3(1), state_.data(), p);
  }

  void skip_tracking() override {
    if (replaying_) return;
    launch(skip_tracking_kernel, dim3(1), dim3(1), state_.data());
  }

  void allocate_blocks(const IntegrateParams& p, bool always) override {
    if (replaying_) return;
    map().visit([&](auto& storage) { allocate_in(storage, p, always); });
  }

  /// The dense cube holds every voxel already.
  void allocate_in(DeviceMap::Cube&, const IntegrateParams&, bool) {}

  /// The blocks this frame's band reaches that the map lacks (cuda_block_map.cuh), five
  /// launches whose counts stay on the device.
  void allocate_in(DeviceBlockMap& blocks, const IntegrateParams& p, bool always) {
    const DeviceBlockMapArgs m = blocks.args();
    launch(begin_block_allocation_kernel, dim3(1), dim3(1), state_.data(), always, m.counts);
    const BlockAllocArgs a{p.k, p.mu_m, m.map, buffers_.depth_m.view(), state_.data()};
    const dim3 block(32, 8);
    launch(gather_new_blocks_kernel, grid_for(a.depth_m.width, a.depth_m.height, block), block, a,
           m);
    launch(allocate_new_blocks_kernel, dim3(map_grid_), dim3(kMapThreads), m);
    launch(init_new_blocks_kernel, dim3(map_grid_), dim3(kMapThreads), m);
    launch(finish_block_allocation_kernel, dim3(1), dim3(1), state_.data(), m);
  }

  void integrate(const IntegrateParams& p, bool always) override {
    if (replaying_) return;
    launch(prepare_integration_kernel, dim3(1), dim3(1), state_.data(), always);
    const ImageView<const Rgb8> colour_image{
        input_rgb_[parity_].data(), setup_.colour ? setup_.input_width_px : 0,
        setup_.colour ? setup_.input_height_px : 0, setup_.input_width_px};
    map().visit([&](auto& storage) { integrate_into(storage, p, colour_image); });
  }

  /// Integration into the block map: the visible blocks, 64 threads each.
  void integrate_into(DeviceBlockMap& blocks, const IntegrateParams& p,
                      ImageView<const Rgb8> colour_image) {
    // Colour goes into each block's own colours (OneBlockView::colour), not a dense field.
    const DeviceBlockMapArgs m = blocks.args();
    const IntegrateArgsT<OneBlockView> a{p,
                                         OneBlockView{},
                                         buffers_.depth_m.view(),
                                         state_.data(),
                                         buffers_.level_normal[0].view(),
                                         ColourVolumeView{},
                                         colour_image};
    launch(find_visible_blocks_kernel, dim3(map_grid_), dim3(kMapThreads), m, a);
    const dim3 rows(kBlockSide * kBlockSide, kMapThreads / (kBlockSide * kBlockSide));
    launch(integrate_blocks_kernel, dim3(map_grid_), rows, m, a);
  }

  /// Integration into the dense cube: a thread per voxel column and z-range.
  void integrate_into(DeviceMap::Cube& cube, const IntegrateParams& p,
                      ImageView<const Rgb8> colour_image) {
    const IntegrateArgs a{p,
                          cube.view(),
                          buffers_.depth_m.view(),
                          state_.data(),
                          buffers_.level_normal[0].view(),
                          cube.colour_view(),
                          colour_image};
    const int res = cube.res;
    const dim3 block(32, 4);
    dim3 grid = grid_for(res, res, block);
    grid.z = z_chunks_;
    launch(integrate_kernel, grid, block, a, z_chunks_);
  }

  void raycast(const RaycastParams& p) override {
    if (replaying_) return;
    launch(set_reference_kernel, dim3(1), dim3(1), state_.data(), p.k);
    map().visit([&](auto& storage) { raycast_map(p, storage); });
  }

  template <class Storage>
  void raycast_map(const RaycastParams& p, Storage& storage) {
    using Map = decltype(storage.view());
    RaycastArgsT<Map> a{p, storage.view(), buffers_.ref_vertex.view(), buffers_.ref_normal.view(),
                        state_.data()};
    if (p.tile_bounds) a.ranges = ray_ranges(p, storage);
    const dim3 block(16, 8);
    const int w = (a.vertex.width + p.block_x_px - 1) / p.block_x_px;
    const int h = (a.vertex.height + p.block_y_px - 1) / p.block_y_px;
    if (raycast_step_of(p) == RaycastStep::kTsdf) {
      launch(pixel_kernel<RaycastBlockBodyT<Map, RaycastStep::kTsdf>, RaycastArgsT<Map>>,
             grid_for(w, h, block), block, a, w, h);
    } else {
      launch(pixel_kernel<RaycastBlockBodyT<Map, RaycastStep::kKFusion>, RaycastArgsT<Map>>,
             grid_for(w, h, block), block, a, w, h);
    }
    if (p.normals != RaycastNormals::kNeighbours) return;
    const RaycastNeighbourNormalArgs n{buffers_.ref_vertex.view(), buffers_.ref_normal.view(),
                                       p.k.handedness()};
    const dim3 pixels(32, 8);
    launch(pixel_kernel<RaycastNeighbourNormalBody, RaycastNeighbourNormalArgs>,
           grid_for(n.normal.width, n.normal.height, pixels), pixels, n, n.normal.width,
           n.normal.height);
  }

  /// The touched blocks' depth range per tile from the raycast's pose (kernels/ray_range.hpp),
  /// computed on the device in the frame's stream (two launches).
  RayRangeTiles ray_ranges(const RaycastParams& p, DeviceBlockMap& blocks) {
    const RayRangeArgs r = ray_range_args(p, setup_.compute_width_px(), setup_.compute_height_px(),
                                          buffers_.ray_range_tiles());
    const int tiles = r.tiles.tiles_x * r.tiles.tiles_y;
    launch(clear_ray_ranges_kernel, dim3((tiles + kMapThreads - 1) / kMapThreads),
           dim3(kMapThreads), r.tiles);
    launch(ray_ranges_of_blocks_kernel, dim3(map_grid_), dim3(kMapThreads), blocks.args(), r,
           static_cast<const TrackingState*>(state_.data()));
    return r.tiles;
  }
  /// The dense cube keeps no ranges.
  RayRangeTiles ray_ranges(const RaycastParams&, DeviceMap::Cube&) { return {}; }

  void render(const RenderParams& p) override {
    if (replaying_) return;
    const int w = setup_.compute_width_px(), h = setup_.compute_height_px();
    const dim3 block(32, 8);
    const RenderDepthArgs d =
        make_render_depth_args(buffers_.depth_m.view(), buffers_.render_depth.view(), p);
    launch(pixel_kernel<RenderDepthBody, RenderDepthArgs>, grid_for(w, h, block), block, d, w, h);
    const RenderTrackArgs t =
        make_render_track_args(buffers_.track_outcome.view(), buffers_.render_track.view(), p);
    launch(pixel_kernel<RenderTrackBody, RenderTrackArgs>, grid_for(w, h, block), block, t, w, h);
    const dim3 ray_block(16, 8);
    map().visit([&](auto& storage) {
      using Map = decltype(storage.view());
      const Map map = storage.view();
      const RenderVolumeArgsT<Map> v =
          make_render_volume_args(map, buffers_.render_volume.view(), state_.data(), p);
      launch(pixel_kernel<RenderVolumeBodyT<Map>, RenderVolumeArgsT<Map>>,
             grid_for(w, h, ray_block), ray_block, v, w, h);
      if (!setup_.colour) return;
      const RenderColourArgsT<Map> c = make_render_colour_args(
          map, dense_colour_view(storage), buffers_.render_colour.view(), state_.data(), p);
      launch(pixel_kernel<RenderColourBodyT<Map>, RenderColourArgsT<Map>>,
             grid_for(w, h, ray_block), ray_block, c, w, h);
    });
  }

  TrackingState read_state() override {
    KFX_CHECK(!pending_.empty(), "read_state() without a submitted frame");
    const int parity = pending_.front();
    pending_.pop_front();
    last_read_parity_ = parity;
    KFX_CUDA_CHECK(cudaEventSynchronize(frame_done_[parity].get()));
    for (int s = 0; s < kStages; ++s) {
      float ms = 0.0f;
      if (stage_timed_[s]) {  // a stage the pipeline never brackets has no recorded events
        KFX_CUDA_CHECK(cudaEventElapsedTime(&ms, stage_events_[parity][s][0]->get(),
                                            stage_events_[parity][s][1]->get()));
      }
      last_stage_ms_[s] = ms;
    }
    return *state_readback_[parity].data();
  }

  void begin_stage(Stage stage) override { record_stage_event(stage, 0); }
  void end_stage(Stage stage) override { record_stage_event(stage, 1); }
  std::array<double, kStages> frame_stage_ms() override { return last_stage_ms_; }

  DebugMaps read_maps() override {
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    DebugMaps maps;
    maps.depth_m = download(buffers_.depth_m);
    maps.filtered_m = download(buffers_.level_depth[0]);
    maps.ref_vertex = download(buffers_.ref_vertex);
    maps.ref_normal = download(buffers_.ref_normal);
    maps.track_outcome = download(buffers_.track_outcome);
    for (int l = 0; l < setup_.pyramid_levels; ++l) {
      maps.level_depth_m.push_back(download(buffers_.level_depth[l]));
      maps.level_vertex.push_back(download(buffers_.level_vertex[l]));
      maps.level_normal.push_back(download(buffers_.level_normal[l]));
    }
    return maps;
  }

  Renders read_renders() override {
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    Renders renders{download(buffers_.render_depth),
                    download(buffers_.render_track),
                    download(buffers_.render_volume),
                    {}};
    if (setup_.colour) renders.colour = download(buffers_.render_colour);
    return renders;
  }

  std::vector<ColourVoxel> read_colour_volume() override {
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    return map().visit([&](auto& storage) { return dense_colours(storage); });
  }

  std::vector<Voxel> read_volume() override {
    const DeviceMap::Cube& cube = map().cube("read_volume()");
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    std::vector<Voxel> voxels(cube.voxels.size());
    KFX_CUDA_CHECK(
        cudaMemcpy(voxels.data(), cube.voxels.data(), cube.voxels.bytes(), cudaMemcpyDeviceToHost));
    return voxels;
  }

  void reserve_mesh_extraction() override {
    map().visit([&](auto& storage) { reserve_mesh_extraction_for(storage); });
  }
  /// A block map is meshed on the host, sized per call by the blocks in the map.
  void reserve_mesh_extraction_for(DeviceBlockMap&) {}
  void reserve_mesh_extraction_for(DeviceMap::Cube& cube) {
    mesh_.reserve(cube.res, stream_.get());
  }

  MeshView extract_mesh() override {
    return map().visit([&](auto& storage) { return extract_mesh_of(storage); });
  }
  /// The host's marching cubes over a host copy of the blocks (block_map_mesh.hpp): the CPU's
  /// bodies and order, so both backends give the same bytes for the same map.
  MeshView extract_mesh_of(DeviceBlockMap& blocks) {
    return extract_block_map_mesh(blocks.download(stream_.get()), block_mesh_vertices_,
                                  block_mesh_triangles_);
  }
  /// The GPU's marching cubes over the cube, in stream order after any submitted frame.
  MeshView extract_mesh_of(DeviceMap::Cube& cube) {
    return mesh_.extract(cube.view(), stream_.get(), debug_sync_);
  }

  void read_blocks_into(BlockMapContents& out) override {
    map().blocks("read_blocks()").download_into(out, stream_.get());
  }

  void upload_blocks(const BlockMapContents& contents) override {
    const int count = map().blocks("upload_blocks()").upload(contents, stream_.get());
    KFX_CUDA_CHECK(
        cudaMemcpy(&state_.data()->map_blocks, &count, sizeof(int), cudaMemcpyHostToDevice));
  }

  void upload_volume(const std::vector<Voxel>& voxels) override {
    const DeviceMap::Cube& cube = map().cube("upload_volume()");
    KFX_CHECK(
        voxels.size() == cube.voxels.size(),
        "volume of " << voxels.size() << " voxels given, the backend holds " << cube.voxels.size());
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    KFX_CUDA_CHECK(
        cudaMemcpy(cube.voxels.data(), voxels.data(), cube.voxels.bytes(), cudaMemcpyHostToDevice));
    KFX_CUDA_CHECK(cudaMemset(cube.brick_touched.data(), 1, cube.brick_touched.bytes()));
    KFX_CUDA_CHECK(
        cudaMemset(cube.super_brick_touched.data(), 1, cube.super_brick_touched.bytes()));
  }

  void upload_colour_volume(const std::vector<ColourVoxel>& colours) override {
    check_colour_volume_upload(colours, setup_);
    const DeviceMap::Cube& cube = map().cube("upload_colour_volume()");
    check_colour_field_size(colours, cube.colours.size());
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    KFX_CUDA_CHECK(cudaMemcpy(cube.colours.data(), colours.data(), cube.colours.bytes(),
                              cudaMemcpyHostToDevice));
  }

 private:
  /// A host copy of the dense cube's colour field (after the stream is idle); empty for a block
  /// map (its colours are in its blocks) or without colour.
  static std::vector<ColourVoxel> dense_colours(const DeviceMap::Cube& cube) {
    std::vector<ColourVoxel> colours(cube.colours.size());
    if (!colours.empty()) {
      KFX_CUDA_CHECK(cudaMemcpy(colours.data(), cube.colours.data(), cube.colours.bytes(),
                                cudaMemcpyDeviceToHost));
    }
    return colours;
  }
  static std::vector<ColourVoxel> dense_colours(const DeviceBlockMap&) { return {}; }

  /// Blocks of one ICP iteration's reduction: one per kReduceBlock samples, at most
  /// reduce_blocks_. Both ICP paths use it: it fixes the order of the float sums.
  int icp_reduce_blocks(const TrackArgs& a) const {
    const int samples = track_grid_width(a) * track_grid_height(a);
    return std::min(reduce_blocks_, (samples + kReduceBlock - 1) / kReduceBlock);
  }

  template <class T>
  HostImage<T> download(const DeviceImage<T>& image) {
    HostImage<T> host(image.width(), image.height());
    KFX_CUDA_CHECK(cudaMemcpy(host.data(), image.data(), image.bytes(), cudaMemcpyDeviceToHost));
    return host;
  }

  /// Launches `kernel` on the pipeline's stream; with programmatic dependent launch enabled it
  /// may start while the previous kernel finishes (each kernel waits for it first thing).
  template <class... KernelArgs, class... Args>
  void launch(void (*kernel)(KernelArgs...), dim3 grid, dim3 block, Args&&... args) {
    cudaLaunchConfig_t config{};
    config.gridDim = grid;
    config.blockDim = block;
    config.stream = stream_.get();
    cudaLaunchAttribute attribute{};
    attribute.id = cudaLaunchAttributeProgrammaticStreamSerialization;
    attribute.val.programmaticStreamSerializationAllowed = programmatic_launch_ ? 1 : 0;
    config.attrs = &attribute;
    config.numAttrs = 1;
    KFX_CUDA_CHECK(cudaLaunchKernelEx(&config, kernel, std::forward<Args>(args)...));
    launched();
  }

  void launched() {
    KFX_CUDA_LAUNCH_CHECK();
    if (debug_sync_) KFX_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
  }

  void record_stage_event(Stage stage, int which) {
    if (replaying_) return;
    stage_timed_[static_cast<int>(stage)] = true;
    cudaEvent_t event = stage_events_[parity_][static_cast<int>(stage)][which]->get();
    // Inside a capture the record becomes a graph node that records on every replay.
    KFX_CUDA_CHECK(cudaEventRecordWithFlags(
        event, stream_.get(), capturing_ ? cudaEventRecordExternal : cudaEventRecordDefault));
  }

  ImageView<const uint16_t> input_view() const {
    return {input_mm_[parity_].data(), setup_.input_width_px, setup_.input_height_px,
            setup_.input_width_px};
  }

  BackendSetup setup_;
  int device_ = 0;
  cudaDeviceProp properties_{};
  bool debug_sync_ = false;
  bool programmatic_launch_ = false;  ///< programmatic dependent launch (setting cuda_pdl)
  Stream stream_;
  Stream copy_stream_;
  std::array<DeviceBuffer<uint16_t>, 2> input_mm_;
  std::array<PinnedBuffer<uint16_t>, 2> staging_mm_;
  std::array<DeviceBuffer<Rgb8>, 2> input_rgb_;  ///< colour input (colour, photometric), by parity
  std::array<PinnedBuffer<Rgb8>, 2> staging_rgb_;
  std::array<PinnedBuffer<TrackingState>, 2> state_readback_;
  /// The pose a relocalisation attempt or a given-pose frame adopts (host slots by parity).
  std::array<PinnedBuffer<Mat4f>, 2> staged_pose_host_;
  DeviceBuffer<Mat4f> staged_pose_;
  int last_read_parity_ = 0;
  std::array<Event, 2> upload_done_{Event(false), Event(false)};
  std::array<Event, 2> frame_done_{Event(false), Event(false)};
  FrameBuffers<DeviceImage, DeviceBuffer> buffers_;
  /// The undistortion table (BackendSetup::depth_source_px); unallocated (no data) without one.
  DeviceImage<SourcePixel> source_px_;
  int reduce_blocks_ = 1;
  int z_chunks_ = 16;
  DeviceBuffer<double> partials_;
  DeviceBuffer<unsigned int> blocks_done_;
  bool fused_preprocess_ = true;  ///< setting cuda_fused_preprocess
  /// The fused preprocess's frame maximum and finished-block count (0, 0 between frames).
  DeviceBuffer<unsigned int> max_depth_scratch_;
  /// Co-resident blocks of the persistent ICP kernel; 0 = one launch per iteration.
  int persistent_icp_blocks_ = 0;
  DeviceBuffer<double> level_partials_;  ///< its two halves of reduce_blocks_ accumulators
  /// Its grid barrier's two counters: arrivals, and arrivals before a launch.
  DeviceBuffer<unsigned int> level_barrier_;
  DeviceBuffer<TrackingState> state_;
  MeshExtractor mesh_;  ///< its buffers are allocated on first use
  /// The maps: map 0 from BackendSetup::map_kind, more from create_map(); stages act on the
  /// selected one, map(). Then the block map's grid-stride kernels' grid, and the host mesh of
  /// a block map (grows to the largest so far).
  std::unique_ptr<MapSet<DeviceMap>> maps_;  ///< made once the stream exists (map 0 is cleared)
  DeviceMap& map() { return maps_->current(); }
  int map_grid_ = 1;
  std::vector<MeshVertex> block_mesh_vertices_;
  std::vector<MeshTriangle> block_mesh_triangles_;
  std::array<std::array<std::array<std::unique_ptr<Event>, 2>, kStages>, 2> stage_events_;
  std::array<double, kStages> last_stage_ms_{};
  std::array<bool, kStages> stage_timed_{};
  /// A recorded frame: (selected map, shape · 2 + parity).
  using GraphKey = std::pair<int, int>;
  std::map<GraphKey, GraphExec> graphs_;
  std::deque<int> pending_;
  int frames_submitted_ = 0;
  int parity_ = 0;
  GraphKey graph_key_{0, 0};
  bool in_frame_ = false;  ///< between begin_frame() and end_frame()
  bool capturing_ = false;
  bool replaying_ = false;
};

}  // namespace
}  // namespace cuda

std::unique_ptr<Backend> make_cuda_backend(const BackendSetup& setup) {
  return std::make_unique<cuda::CudaBackend>(setup);
}

}  // namespace kfx
