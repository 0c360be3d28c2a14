/// The CPU backend: every stage is an OpenMP loop over rows calling the shared kernel bodies.
/// Reductions are per-row partial sums added in row order, so runs repeat bit for bit.

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <fstream>
#include <thread>

#include "backend/backend.hpp"
#include "backend/stage_args.hpp"
#include "kernels/integrate.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/raycast.hpp"
#include "kernels/render.hpp"
#include "kernels/track.hpp"

namespace kfx {
namespace {

/// Calls body(x, y) for every pixel of a width × height grid, rows spread over threads.
template <class Body>
void for_each_pixel(int width, int height, Body body) {
#pragma omp parallel for schedule(static)
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) body(x, y);
  }
}

std::string cpu_model_name() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return line.substr(colon + 2);
    }
  }
  return "unknown CPU";
}

class CpuBackend final : public Backend {
 public:
  explicit CpuBackend(const BackendSetup& setup) : setup_(setup) {
    const int w = setup.compute_width_px(), h = setup.compute_height_px();
    input_mm_ = HostImage<uint16_t>(setup.input_width_px, setup.input_height_px);
    depth_m_ = HostImage<float>(w, h);
    for (int l = 0; l < setup.pyramid_levels; ++l) {
      level_depth_[l] = HostImage<float>(w >> l, h >> l);
      level_vertex_[l] = HostImage<Vec3f>(w >> l, h >> l);
      level_normal_[l] = HostImage<Vec3f>(w >> l, h >> l);
    }
    ref_vertex_ = HostImage<Vec3f>(w, h);
    ref_normal_ = HostImage<Vec3f>(w, h, Vec3f{kInvalidNormal, 0, 0});
    track_outcome_ = HostImage<int8_t>(w, h);
    render_depth_ = HostImage<Rgba8>(w, h);
    render_track_ = HostImage<Rgba8>(w, h);
    render_volume_ = HostImage<Rgba8>(w, h);
    row_partials_.assign(static_cast<size_t>(h) * kAccumulatorSize, 0.0);
    volume_.assign(static_cast<size_t>(setup.volume_res_vox) * setup.volume_res_vox *
                       setup.volume_res_vox,
                   Voxel{});
    const size_t bricks = bricks_per_side(setup.volume_res_vox);
    brick_touched_.assign(bricks * bricks * bricks, 0);
    state_ = TrackingState{};
  }

  std::string name() const override { return "cpu"; }
  std::string device_name() const override {
    return cpu_model_name() + ", " + std::to_string(omp_get_max_threads()) + " OpenMP threads";
  }

  void reset(const Mat4f& T_world_cam) override {
    const Voxel empty{static_cast<int16_t>(kTsdfScale), 0};
    std::fill(volume_.begin(), volume_.end(), empty);
    std::fill(brick_touched_.begin(), brick_touched_.end(), 0);
    state_ = TrackingState{};
    finished_.clear();
    state_.frame_index = -1;
    state_.T_world_cam = T_world_cam;
    state_.T_world_cam_before = T_world_cam;
    state_.T_world_raycast = T_world_cam;
  }

  void upload_depth(const HostImage<uint16_t>& depth_mm) override {
    KFX_CHECK(depth_mm.width() == setup_.input_width_px &&
                  depth_mm.height() == setup_.input_height_px,
              "depth frame is " << depth_mm.width() << "x" << depth_mm.height()
                                << ", the pipeline was set up for " << setup_.input_width_px
                                << "x" << setup_.input_height_px);
    input_mm_.pixels() = depth_mm.pixels();
  }

  // The CPU runs each stage as it is called; end_frame() keeps the frame's result until read,
  // so a caller may submit the next frame first (as with the GPU).
  void begin_frame(int /*shape*/) override {}
  void end_frame() override {
    finished_.push_back(FinishedFrame{state_, stage_ms_});
    stage_ms_.fill(0.0);
  }

  void preprocess(const PreprocessParams& p) override {
    begin_frame_state(state_);
    const MmToMArgs mm{input_mm_.view(), depth_m_.view(), setup_.compute_ratio};
    const int w = depth_m_.width(), h = depth_m_.height();
    float max_depth_m = 0.0f;
#pragma omp parallel for schedule(static) reduction(max : max_depth_m)
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) max_depth_m = std::max(max_depth_m, mm_to_m_pixel(x, y, mm));
    }
    state_.max_depth_m = max_depth_m;
    const BilateralArgs b = make_bilateral_args(depth_m_.view(), level_depth_[0].view(), p);
    for_each_pixel(w, h, [&](int x, int y) { bilateral_pixel(x, y, b); });
  }

  void build_pyramid(const PyramidParams& p) override {
    for (int l = 1; l < setup_.pyramid_levels; ++l) {
      const HalfSampleArgs a{level_depth_[l - 1].view(), level_depth_[l].view(),
                             p.half_sample_range_m};
      for_each_pixel(level_depth_[l].width(), level_depth_[l].height(),
                     [&](int x, int y) { half_sample_pixel(x, y, a); });
    }
    for (int l = 0; l < setup_.pyramid_levels; ++l) {
      const DepthToVertexArgs v{level_depth_[l].view(), level_vertex_[l].view(),
                                p.level_intrinsics[l].inverse_matrix()};
      for_each_pixel(v.vertex.width, v.vertex.height,
                     [&](int x, int y) { depth_to_vertex_pixel(x, y, v); });
      const VertexToNormalArgs n{level_vertex_[l].view(), level_normal_[l].view(),
                                 p.level_intrinsics[l].handedness()};
      for_each_pixel(n.normal.width, n.normal.height,
                     [&](int x, int y) { vertex_to_normal_pixel(x, y, n); });
    }
  }

  void begin_tracking() override { kfx::begin_tracking(state_); }

  void icp_iteration(int level, const IcpParams& p) override {
    if (level_converged(state_, level)) return;
    const TrackArgs a = make_track_args(level_vertex_[level].view(), level_normal_[level].view(),
                                        ref_vertex_.view(), ref_normal_.view(), &state_, p);
    const int w = a.in_vertex.width, h = a.in_vertex.height, s = p.stride_px;
    const double weight = static_cast<double>(s) * s;  // each tracked pixel stands for its block
    const bool keep_outcome = level == 0;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < h; y += s) {
      double acc[kAccumulatorSize] = {};  // local: stays in registers, no aliasing
      for (int x = 0; x < w; x += s) {
        const TrackRow row = track_pixel(x, y, a);
        accumulate_row(acc, row, weight);
        if (keep_outcome) track_outcome_(x, y) = static_cast<int8_t>(row.outcome);
      }
      std::copy(acc, acc + kAccumulatorSize, &row_partials_[static_cast<size_t>(y) * kAccumulatorSize]);
    }
    double total[kAccumulatorSize] = {};
    for (int y = 0; y < h; y += s) {  // fixed order: repeatable
      const double* acc = &row_partials_[static_cast<size_t>(y) * kAccumulatorSize];
      for (int i = 0; i < kAccumulatorSize; ++i) total[i] += acc[i];
    }
    icp_update(state_, total, p.icp_threshold, level);
  }

  void accept_or_revert(const AcceptParams& p) override { kfx::accept_or_revert(state_, p); }
  void skip_tracking() override { state_.tracked = 0; }

  void integrate(const IntegrateParams& p, bool always) override {
    prepare_integration(state_, always);
    if (!state_.integrate_now) return;
    const IntegrateArgs a = make_integrate_args(volume_view(), depth_m_.view(), &state_, p);
    // x-lines: each thread walks contiguous voxels (the GPU takes z-lines instead). Threads
    // take whole brick layers, so no two write the same brick flag.
    const int res = setup_.volume_res_vox;
    const int brick = 1 << kBrickShift;
#pragma omp parallel for schedule(dynamic, 1)
    for (int z_brick = 0; z_brick < bricks_per_side(res); ++z_brick) {
      for (int z = z_brick * brick; z < std::min(res, (z_brick + 1) * brick); ++z) {
        for (int y = 0; y < res; ++y) integrate_row(y, z, a);
      }
    }
  }

  void raycast(const RaycastParams& p) override {
    set_reference_view(state_, p.k);
    const RaycastArgs a =
        make_raycast_args(volume_view(), ref_vertex_.view(), ref_normal_.view(), &state_, p);
    const int blocks_x = (ref_vertex_.width() + p.block_x_px - 1) / p.block_x_px;
    const int blocks_y = (ref_vertex_.height() + p.block_y_px - 1) / p.block_y_px;
#pragma omp parallel for schedule(dynamic, 2)
    for (int y = 0; y < blocks_y; ++y) {
      for (int x = 0; x < blocks_x; ++x) raycast_block(x, y, a);
    }
  }

  void render(const RenderParams& p) override {
    const int w = depth_m_.width(), h = depth_m_.height();
    const RenderDepthArgs d = make_render_depth_args(depth_m_.view(), render_depth_.view(), p);
    for_each_pixel(w, h, [&](int x, int y) { render_depth_pixel(x, y, d); });
    const RenderTrackArgs t =
        make_render_track_args(track_outcome_.view(), render_track_.view(), p);
    for_each_pixel(w, h, [&](int x, int y) { render_track_pixel(x, y, t); });
    const RenderVolumeArgs v =
        make_render_volume_args(volume_view(), render_volume_.view(), &state_, p);
#pragma omp parallel for schedule(dynamic, 2)
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) render_volume_pixel(x, y, v);
    }
  }

  TrackingState read_state() override {
    KFX_CHECK(!finished_.empty(), "read_state() without a submitted frame");
    const FinishedFrame frame = finished_.front();
    finished_.pop_front();
    last_stage_ms_ = frame.stage_ms;
    return frame.state;
  }

  void begin_stage(Stage stage) override {
    stage_start_[static_cast<int>(stage)] = std::chrono::steady_clock::now();
  }
  void end_stage(Stage stage) override {
    const int i = static_cast<int>(stage);
    stage_ms_[i] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                             stage_start_[i])
                       .count();
  }
  std::array<double, static_cast<int>(Stage::kCount)> frame_stage_ms() override {
    return last_stage_ms_;
  }

  DebugMaps read_maps() override {
    return DebugMaps{depth_m_, level_depth_[0], ref_vertex_, ref_normal_, track_outcome_};
  }
  Renders read_renders() override { return Renders{render_depth_, render_track_, render_volume_}; }
  std::vector<Voxel> read_volume() override { return volume_; }

 private:
  VolumeView volume_view() {
    return VolumeView{volume_.data(), setup_.volume_res_vox, setup_.volume_size_m,
                      brick_touched_.data()};
  }

  BackendSetup setup_;
  HostImage<uint16_t> input_mm_;
  HostImage<float> depth_m_;
  std::array<HostImage<float>, kMaxPyramidLevels> level_depth_;
  std::array<HostImage<Vec3f>, kMaxPyramidLevels> level_vertex_;
  std::array<HostImage<Vec3f>, kMaxPyramidLevels> level_normal_;
  HostImage<Vec3f> ref_vertex_;
  HostImage<Vec3f> ref_normal_;
  HostImage<int8_t> track_outcome_;
  HostImage<Rgba8> render_depth_, render_track_, render_volume_;
  std::vector<double> row_partials_;
  std::vector<Voxel> volume_;
  std::vector<uint8_t> brick_touched_;
  TrackingState state_{};
  std::array<std::chrono::steady_clock::time_point, static_cast<int>(Stage::kCount)> stage_start_;
  std::array<double, static_cast<int>(Stage::kCount)> stage_ms_{};
  std::array<double, static_cast<int>(Stage::kCount)> last_stage_ms_{};
  /// A frame's state and stage times, kept from end_frame() until read_state().
  struct FinishedFrame {
    TrackingState state;
    std::array<double, static_cast<int>(Stage::kCount)> stage_ms;
  };
  std::deque<FinishedFrame> finished_;
};

}  // namespace

std::unique_ptr<Backend> make_cpu_backend(const BackendSetup& setup) {
  return std::make_unique<CpuBackend>(setup);
}

}  // namespace kfx
