/// The CUDA backend: the whole frame on the device. Every buffer is allocated once; stages are
/// thin launches of the shared kernel bodies on one non-blocking stream; decisions stay in the
/// device-side TrackingState. Each frame shape (which stages run) is recorded once as a CUDA
/// graph and replayed; the depth upload for a frame goes through pinned memory on a second
/// stream, and the state after the frame comes back asynchronously into pinned memory.
/// KFX_CUDA_SYNC=1 turns graphs off and synchronises after every launch (debugging).

#include <array>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <map>

#include "backend/backend.hpp"
#include "backend/stage_args.hpp"
#include "backend/cuda/cuda_kernels.cuh"
#include "backend/cuda/cuda_memory.hpp"

namespace kfx {

bool cuda_device_present(std::string* why_not) {
  int count = 0;
  const cudaError_t status = cudaGetDeviceCount(&count);
  if (status != cudaSuccess || count == 0) {
    if (why_not) {
      *why_not = status != cudaSuccess
                     ? std::string("no usable CUDA device (") + cudaGetErrorString(status) + ")"
                     : std::string("no CUDA device is present");
    }
    cudaGetLastError();  // clear the sticky error of a failed query
    return false;
  }
  return true;
}

namespace cuda {
namespace {

constexpr int kStages = static_cast<int>(Stage::kCount);

dim3 grid_for(int width, int height, dim3 block) {
  return dim3((width + block.x - 1) / block.x, (height + block.y - 1) / block.y);
}

class CudaBackend final : public Backend {
 public:
  explicit CudaBackend(const BackendSetup& setup) : setup_(setup) {
    KFX_CUDA_CHECK(cudaGetDevice(&device_));
    KFX_CUDA_CHECK(cudaGetDeviceProperties(&properties_, device_));
    const char* sync = std::getenv("KFX_CUDA_SYNC");
    debug_sync_ = sync && std::string(sync) == "1";
    // Programmatic dependent launch is on by default on Hopper (measured: −2.4 % per frame,
    // bench/RESULTS.md); KFX_CUDA_PDL=0 turns it off.
    const char* pdl = std::getenv("KFX_CUDA_PDL");
    programmatic_launch_ = !(pdl && std::string(pdl) == "0") && properties_.major >= 9;
    const int w = setup.compute_width_px(), h = setup.compute_height_px();
    const size_t input_pixels = static_cast<size_t>(setup.input_width_px) * setup.input_height_px;
    for (int p = 0; p < 2; ++p) {
      input_mm_[p] = DeviceBuffer<uint16_t>(input_pixels);
      staging_mm_[p] = PinnedBuffer<uint16_t>(input_pixels);
      state_readback_[p] = PinnedBuffer<TrackingState>(1);
    }
    depth_m_ = DeviceBuffer<float>(static_cast<size_t>(w) * h);
    for (int l = 0; l < setup.pyramid_levels; ++l) {
      const size_t n = static_cast<size_t>(w >> l) * (h >> l);
      level_depth_[l] = DeviceBuffer<float>(n);
      level_vertex_[l] = DeviceBuffer<Vec3f>(n);
      level_normal_[l] = DeviceBuffer<Vec3f>(n);
    }
    ref_vertex_ = DeviceBuffer<Vec3f>(static_cast<size_t>(w) * h);
    ref_normal_ = DeviceBuffer<Vec3f>(static_cast<size_t>(w) * h);
    track_outcome_ = DeviceBuffer<int8_t>(static_cast<size_t>(w) * h);
    // Tuning (bench only): KFX_CUDA_REDUCE_BLOCKS caps the ICP reduction grid,
    // KFX_CUDA_Z_CHUNKS splits each integration column into that many z-ranges.
    const char* blocks_env = std::getenv("KFX_CUDA_REDUCE_BLOCKS");
    // Defaults measured on an H200 (bench/RESULTS.md): one reduction block per SM, 16 z-chunks.
    const int max_blocks = blocks_env ? std::atoi(blocks_env) : properties_.multiProcessorCount;
    reduce_blocks_ = std::max(1, std::min((w * h + kReduceBlock - 1) / kReduceBlock, max_blocks));
    const char* chunks_env = std::getenv("KFX_CUDA_Z_CHUNKS");
    z_chunks_ = chunks_env ? std::max(1, std::atoi(chunks_env)) : 16;
    partials_ = DeviceBuffer<double>(static_cast<size_t>(reduce_blocks_) * kAccumulatorSize);
    blocks_done_ = DeviceBuffer<unsigned int>(1);
    KFX_CUDA_CHECK(cudaMemsetAsync(blocks_done_.data(), 0, sizeof(unsigned int), stream_.get()));
    const long long voxels = static_cast<long long>(setup.volume_res_vox) *
                             setup.volume_res_vox * setup.volume_res_vox;
    volume_ = DeviceBuffer<Voxel>(static_cast<size_t>(voxels));
    const size_t bricks = bricks_per_side(setup.volume_res_vox);
    brick_touched_ = DeviceBuffer<uint8_t>(bricks * bricks * bricks);
    state_ = DeviceBuffer<TrackingState>(1);
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
    const long long voxels = static_cast<long long>(volume_.size());
    launch(init_volume_kernel, dim3(static_cast<unsigned>((voxels + 255) / 256)), dim3(256),
           volume_.data(), voxels);
    KFX_CUDA_CHECK(cudaMemsetAsync(brick_touched_.data(), 0, brick_touched_.bytes(), stream_.get()));
    TrackingState initial{};
    initial.frame_index = -1;
    initial.T_world_cam = T_world_cam;
    initial.T_world_cam_before = T_world_cam;
    initial.T_world_raycast = T_world_cam;
    *state_readback_[0].data() = initial;
    KFX_CUDA_CHECK(cudaMemcpyAsync(state_.data(), state_readback_[0].data(),
                                   sizeof(TrackingState), cudaMemcpyHostToDevice, stream_.get()));
    KFX_CUDA_CHECK(cudaMemsetAsync(ref_vertex_.data(), 0, ref_vertex_.bytes(), stream_.get()));
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    pending_.clear();
    frames_submitted_ = 0;
  }

  void upload_depth(const HostImage<uint16_t>& depth_mm) override {
    KFX_CHECK(depth_mm.width() == setup_.input_width_px &&
                  depth_mm.height() == setup_.input_height_px,
              "depth frame is " << depth_mm.width() << "x" << depth_mm.height()
                                << ", the pipeline was set up for " << setup_.input_width_px
                                << "x" << setup_.input_height_px);
    parity_ = frames_submitted_ % 2;
    // The frame two back used these buffers: wait until it has finished with them.
    KFX_CUDA_CHECK(cudaEventSynchronize(frame_done_[parity_].get()));
    std::memcpy(staging_mm_[parity_].data(), depth_mm.data(),
                depth_mm.pixels().size() * sizeof(uint16_t));
    KFX_CUDA_CHECK(cudaMemcpyAsync(input_mm_[parity_].data(), staging_mm_[parity_].data(),
                                   depth_mm.pixels().size() * sizeof(uint16_t),
                                   cudaMemcpyHostToDevice, copy_stream_.get()));
    KFX_CUDA_CHECK(cudaEventRecord(upload_done_[parity_].get(), copy_stream_.get()));
  }

  void begin_frame(int shape) override {
    KFX_CUDA_CHECK(cudaStreamWaitEvent(stream_.get(), upload_done_[parity_].get(), 0));
    graph_key_ = shape * 2 + parity_;
    replaying_ = !debug_sync_ && graphs_.count(graph_key_) > 0;
    capturing_ = !debug_sync_ && !replaying_;
    if (capturing_) {
      KFX_CUDA_CHECK(cudaStreamBeginCapture(stream_.get(), cudaStreamCaptureModeThreadLocal));
    }
  }

  void end_frame() override {
    if (!replaying_) {
      KFX_CUDA_CHECK(cudaMemcpyAsync(state_readback_[parity_].data(), state_.data(),
                                     sizeof(TrackingState), cudaMemcpyDeviceToHost,
                                     stream_.get()));
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
    KFX_CUDA_CHECK(cudaEventRecord(frame_done_[parity_].get(), stream_.get()));
    pending_.push_back(parity_);
    ++frames_submitted_;
  }

  void preprocess(const PreprocessParams& p) override {
    if (replaying_) return;
    const int w = setup_.compute_width_px(), h = setup_.compute_height_px();
    KFX_CUDA_CHECK(
        cudaMemsetAsync(&state_.data()->max_depth_m, 0, sizeof(float), stream_.get()));
    const MmToMArgs mm{input_view(), depth_view(), setup_.compute_ratio};
    const dim3 block(32, 8);
    launch(mm_to_m_kernel, grid_for(w, h, block), block, mm, state_.data());
    const BilateralArgs b = make_bilateral_args(depth_view(), level_depth_view(0), p);
    launch(pixel_kernel<BilateralBody, BilateralArgs>, grid_for(w, h, block), block, b, w, h);
  }

  void build_pyramid(const PyramidParams& p) override {
    if (replaying_) return;
    const dim3 block(32, 8);
    for (int l = 1; l < setup_.pyramid_levels; ++l) {
      const HalfSampleArgs a{level_depth_view(l - 1), level_depth_view(l), p.half_sample_range_m};
      launch(pixel_kernel<HalfSampleBody, HalfSampleArgs>, grid_for(a.out_m.width, a.out_m.height, block), block,
             a, a.out_m.width, a.out_m.height);
    }
    for (int l = 0; l < setup_.pyramid_levels; ++l) {
      const DepthToVertexArgs v{level_depth_view(l), level_vertex_view(l),
                                p.level_intrinsics[l].inverse_matrix()};
      const int w = v.vertex.width, h = v.vertex.height;
      launch(pixel_kernel<DepthToVertexBody, DepthToVertexArgs>, grid_for(w, h, block), block, v, w, h);
      const VertexToNormalArgs n{level_vertex_view(l), level_normal_view(l),
                                 p.level_intrinsics[l].handedness()};
      launch(pixel_kernel<VertexToNormalBody, VertexToNormalArgs>, grid_for(w, h, block), block, n, w, h);
    }
  }

  void begin_tracking() override {
    if (replaying_) return;
    launch(begin_tracking_kernel, dim3(1), dim3(1), state_.data());
  }

  void icp_iteration(int level, const IcpParams& p) override {
    if (replaying_) return;
    const TrackArgs a = make_track_args(level_vertex_view(level), level_normal_view(level),
                                        ref_view(ref_vertex_), ref_view(ref_normal_), state_.data(), p);
    const int pixels = ((a.in_vertex.width + p.stride_px - 1) / p.stride_px) *
                       ((a.in_vertex.height + p.stride_px - 1) / p.stride_px);
    const int blocks = std::min(reduce_blocks_, (pixels + kReduceBlock - 1) / kReduceBlock);
    launch(icp_iteration_kernel, dim3(blocks), dim3(kReduceBlock),
        a, state_.data(), partials_.data(), blocks_done_.data(), p.icp_threshold, level,
        level == 0 ? track_outcome_.data() : nullptr);
  }

  void accept_or_revert(const AcceptParams& p) override {
    if (replaying_) return;
    launch(accept_kernel, dim3(1), dim3(1), state_.data(), p);
  }

  void skip_tracking() override {
    if (replaying_) return;
    launch(skip_tracking_kernel, dim3(1), dim3(1), state_.data());
  }

  void integrate(const IntegrateParams& p, bool always) override {
    if (replaying_) return;
    launch(prepare_integration_kernel, dim3(1), dim3(1), state_.data(), always);
    const IntegrateArgs a = make_integrate_args(volume_view(), depth_view(), state_.data(), p);
    const int res = setup_.volume_res_vox;
    const dim3 block(32, 4);
    dim3 grid = grid_for(res, res, block);
    grid.z = z_chunks_;
    launch(integrate_kernel, grid, block, a, z_chunks_);
  }

  void raycast(const RaycastParams& p) override {
    if (replaying_) return;
    launch(set_reference_kernel, dim3(1), dim3(1), state_.data(), p.k);
    const RaycastArgs a = make_raycast_args(volume_view(), ref_view(ref_vertex_),
                                            ref_view(ref_normal_), state_.data(), p);
    const dim3 block(16, 8);
    const int w = (a.vertex.width + p.block_x_px - 1) / p.block_x_px;
    const int h = (a.vertex.height + p.block_y_px - 1) / p.block_y_px;
    launch(pixel_kernel<RaycastBlockBody, RaycastArgs>, grid_for(w, h, block), block, a, w, h);
  }

  TrackingState read_state() override {
    KFX_CHECK(!pending_.empty(), "read_state() without a submitted frame");
    const int parity = pending_.front();
    pending_.pop_front();
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
    const int w = setup_.compute_width_px(), h = setup_.compute_height_px();
    DebugMaps maps;
    maps.depth_m = download(depth_m_, w, h);
    maps.filtered_m = download(level_depth_[0], w, h);
    maps.ref_vertex = download(ref_vertex_, w, h);
    maps.ref_normal = download(ref_normal_, w, h);
    maps.track_outcome = download(track_outcome_, w, h);
    return maps;
  }

  std::vector<Voxel> read_volume() override {
    KFX_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    std::vector<Voxel> voxels(volume_.size());
    KFX_CUDA_CHECK(cudaMemcpy(voxels.data(), volume_.data(), volume_.bytes(),
                              cudaMemcpyDeviceToHost));
    return voxels;
  }

 private:
  template <class T>
  HostImage<T> download(const DeviceBuffer<T>& buffer, int w, int h) {
    HostImage<T> image(w, h);
    KFX_CUDA_CHECK(cudaMemcpy(image.data(), buffer.data(), sizeof(T) * w * h,
                              cudaMemcpyDeviceToHost));
    return image;
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
    KFX_CUDA_CHECK(cudaEventRecordWithFlags(event, stream_.get(),
                                            capturing_ ? cudaEventRecordExternal
                                                       : cudaEventRecordDefault));
  }

  ImageView<const uint16_t> input_view() const {
    return {input_mm_[parity_].data(), setup_.input_width_px, setup_.input_height_px,
            setup_.input_width_px};
  }
  ImageView<float> depth_view() const {
    const int w = setup_.compute_width_px(), h = setup_.compute_height_px();
    return {depth_m_.data(), w, h, w};
  }
  ImageView<float> level_depth_view(int l) const {
    const int w = setup_.compute_width_px() >> l, h = setup_.compute_height_px() >> l;
    return {level_depth_[l].data(), w, h, w};
  }
  ImageView<Vec3f> level_vertex_view(int l) const {
    const int w = setup_.compute_width_px() >> l, h = setup_.compute_height_px() >> l;
    return {level_vertex_[l].data(), w, h, w};
  }
  ImageView<Vec3f> level_normal_view(int l) const {
    const int w = setup_.compute_width_px() >> l, h = setup_.compute_height_px() >> l;
    return {level_normal_[l].data(), w, h, w};
  }
  ImageView<Vec3f> ref_view(const DeviceBuffer<Vec3f>& buffer) const {
    const int w = setup_.compute_width_px(), h = setup_.compute_height_px();
    return {buffer.data(), w, h, w};
  }
  VolumeView volume_view() const {
    return VolumeView{volume_.data(), setup_.volume_res_vox, setup_.volume_size_m,
                      brick_touched_.data()};
  }

  BackendSetup setup_;
  int device_ = 0;
  cudaDeviceProp properties_{};
  bool debug_sync_ = false;
  bool programmatic_launch_ = false;  ///< programmatic dependent launch (KFX_CUDA_PDL=0: off)
  Stream stream_;
  Stream copy_stream_;
  std::array<DeviceBuffer<uint16_t>, 2> input_mm_;
  std::array<PinnedBuffer<uint16_t>, 2> staging_mm_;
  std::array<PinnedBuffer<TrackingState>, 2> state_readback_;
  std::array<Event, 2> upload_done_{Event(false), Event(false)};
  std::array<Event, 2> frame_done_{Event(false), Event(false)};
  DeviceBuffer<float> depth_m_;
  std::array<DeviceBuffer<float>, kMaxPyramidLevels> level_depth_;
  std::array<DeviceBuffer<Vec3f>, kMaxPyramidLevels> level_vertex_;
  std::array<DeviceBuffer<Vec3f>, kMaxPyramidLevels> level_normal_;
  DeviceBuffer<Vec3f> ref_vertex_;
  DeviceBuffer<Vec3f> ref_normal_;
  DeviceBuffer<int8_t> track_outcome_;
  int reduce_blocks_ = 1;
  int z_chunks_ = 16;
  DeviceBuffer<double> partials_;
  DeviceBuffer<unsigned int> blocks_done_;
  DeviceBuffer<Voxel> volume_;
  DeviceBuffer<uint8_t> brick_touched_;
  DeviceBuffer<TrackingState> state_;
  std::array<std::array<std::array<std::unique_ptr<Event>, 2>, kStages>, 2> stage_events_;
  std::array<double, kStages> last_stage_ms_{};
  std::array<bool, kStages> stage_timed_{};
  std::map<int, GraphExec> graphs_;
  std::deque<int> pending_;
  int frames_submitted_ = 0;
  int parity_ = 0;
  int graph_key_ = 0;
  bool capturing_ = false;
  bool replaying_ = false;
};

}  // namespace
}  // namespace cuda

std::unique_ptr<Backend> make_cuda_backend(const BackendSetup& setup) {
  return std::make_unique<cuda::CudaBackend>(setup);
}

}  // namespace kfx
