/// The CPU backend: every stage is an OpenMP loop over rows calling the shared kernel bodies.
/// Reductions are per-row partial sums added in row order, so runs repeat bit for bit.

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <fstream>
#include <new>
#include <thread>

#include "backend/backend.hpp"
#include "backend/block_map_mesh.hpp"
#include "backend/frame_buffers.hpp"
#include "backend/memory_budget.hpp"
#include "kernels/block_allocation.hpp"
#include "kernels/camera_move.hpp"
#include "kernels/integrate.hpp"
#include "kernels/marching_cubes.hpp"
#include "kernels/photometric.hpp"
#include "kernels/preprocess.hpp"
#include "kernels/raycast.hpp"
#include "kernels/render.hpp"
#include "kernels/track.hpp"
#include "map/host_block_map.hpp"
#include "map/map_set.hpp"

namespace kfx {
namespace {

/// Host memory for FrameBuffers' arrays.
template <class T>
using HostArray = std::vector<T>;

/// Calls body(x, y) for every pixel of a width × height grid, rows spread over threads.
template <class Body>
void for_each_pixel(int width, int height, Body body) {
#pragma omp parallel for schedule(static)
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) body(x, y);
  }
}

#if defined(__GNUC__) || defined(__clang__)
#define KFX_CPU_FLATTEN __attribute__((flatten))
#else
#define KFX_CPU_FLATTEN
#endif

/// One row of raycast blocks, with the whole kernel body (raycast_block down to the march)
/// compiled into this loop. Since the volume render became raycast_ray's second caller, GCC
/// no longer inlines the march here on its own, and out of line it ran slower on the CPU
/// (bench/RESULTS.md, "One commit, before and after the restructuring"). `flatten` asks for
/// that on the host only, so the
/// kernel body and the CUDA build stay as they are.
template <RaycastStep Step, class Map>
KFX_CPU_FLATTEN void raycast_row(int block_y, int blocks_x, const RaycastArgsT<Map>& a) {
  for (int x = 0; x < blocks_x; ++x) raycast_block<Step>(x, block_y, a);
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

/// The CPU backend's map: host memory, the host block map.
using HostMap = VoxelMap<HostMemory, HostBlockMap>;

/// The map `setup` asks for (BackendSetup::map_kind), not yet cleared.
HostMap make_host_map(const BackendSetup& setup) {
  if (setup.map_kind == MapKind::kBlocks) {
    return HostMap(HostBlockMap(setup.block_capacity, setup.volume_res_vox, setup.volume_size_m,
                                setup.colour));
  }
  return HostMap(HostMap::Cube(setup.volume_res_vox, setup.volume_size_m, setup.colour));
}

class CpuBackend final : public Backend {
 public:
  explicit CpuBackend(const BackendSetup& setup)
      : setup_(setup),
        input_mm_(setup.input_width_px, setup.input_height_px),
        buffers_(setup),
        maps_(make_host_map(setup)),
        row_partials_(static_cast<size_t>(setup.compute_height_px()) * kAccumulatorSize) {
    auto& normals = buffers_.ref_normal.pixels();
    std::fill(normals.begin(), normals.end(), Vec3f{kInvalidNormal, 0, 0});
  }

  std::string name() const override { return "cpu"; }
  std::string device_name() const override {
    return cpu_model_name() + ", " + std::to_string(omp_get_max_threads()) + " OpenMP threads";
  }

  void reset(const Mat4f& T_world_cam) override {
    map().clear(HostMemory{});
    auto& vertices = buffers_.ref_vertex.pixels();
    std::fill(vertices.begin(), vertices.end(), Vec3f{0, 0, 0});
    state_ = initial_tracking_state(T_world_cam);
    finished_.clear();
  }

  void set_pose(const Mat4f& T_world_cam) override { move_camera(state_, T_world_cam); }

  int create_map() override {
    KFX_CHECK(!in_frame_, "create_map() inside a frame (between begin_frame and end_frame)");
    check_another_map_fits(setup_, maps_.count(), host_bytes_available(),
                           "the host's available memory (MemAvailable in /proc/meminfo)");
    HostMap map;
    try {
      map = make_host_map(setup_);
    } catch (const std::bad_alloc&) {
      KFX_FAIL("not enough host memory: another map ("
               << static_cast<double>(map_bytes(setup_)) / (1024.0 * 1024.0 * 1024.0)
               << " GiB) could not be allocated");
    }
    map.clear(HostMemory{});
    return maps_.add(std::move(map));
  }

  void select_map(int handle) override {
    KFX_CHECK(!in_frame_, "select_map() inside a frame (between begin_frame and end_frame)");
    maps_.select(handle);
    // The state's block count is the selected map's, as a frame's allocation leaves it.
    if (map().kind() == MapKind::kBlocks)
      state_.map_blocks = map().blocks("select_map()").block_count();
  }

  int map_count() const override { return maps_.count(); }
  int selected_map() const override { return maps_.selected(); }

  void upload_depth(ImageView<const uint16_t> depth_mm) override {
    check_depth_frame(depth_mm, setup_);
    std::copy(depth_mm.data, depth_mm.data + depth_mm.size(), input_mm_.data());
  }

  void upload_colour(ImageView<const Rgb8> rgb) override {
    check_colour_frame(rgb, setup_);
    if (input_rgb_.width() != rgb.width || input_rgb_.height() != rgb.height) {
      input_rgb_ = HostImage<Rgb8>(rgb.width, rgb.height);
    }
    std::copy(rgb.data, rgb.data + rgb.size(), input_rgb_.data());
  }

  // The CPU runs each stage as it is called; end_frame() keeps the frame's result until read,
  // so a caller may submit the next frame first (as with the GPU).
  void begin_frame(int /*shape*/) override { in_frame_ = true; }
  void end_frame() override {
    in_frame_ = false;
    finished_.push_back(FinishedFrame{state_, stage_ms_});
    stage_ms_.fill(0.0);
  }

  void stage_pose(const Mat4f& T_world_cam) override { staged_pose_ = T_world_cam; }
  void adopt_staged_pose() override { move_camera(state_, staged_pose_); }

  void preprocess(const BilateralParams& p) override {
    begin_frame_state(state_);
    const MmToMArgs mm{input_mm_.view(), buffers_.depth_m.view(), setup_.compute_ratio,
                       p.max_depth_m, source_view()};
    const int w = buffers_.depth_m.width(), h = buffers_.depth_m.height();
    float max_depth_m = 0.0f;
#pragma omp parallel for schedule(static) reduction(max : max_depth_m)
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) max_depth_m = std::max(max_depth_m, mm_to_m_pixel(x, y, mm));
    }
    state_.max_depth_m = max_depth_m;
    const BilateralArgs b{p, buffers_.depth_m.view(), buffers_.level_depth[0].view()};
    for_each_pixel(w, h, [&](int x, int y) { bilateral_pixel(x, y, b); });
    if (setup_.photometric) build_intensity();
  }

  void keep_intensity(bool always) override {
    if (!setup_.photometric) return;
    for (int l = 0; l < setup_.pyramid_levels; ++l) {
      const KeepIntensityArgs a{buffers_.level_intensity[l].view(),
                                buffers_.ref_intensity[l].view(), &state_, always ? 1 : 0};
      for_each_pixel(a.current.width, a.current.height,
                     [&](int x, int y) { keep_intensity_pixel(x, y, a); });
    }
    keep_intensity_pose(state_, always ? 1 : 0);
  }

  void build_pyramid(const PyramidParams& p) override {
    for (int l = 1; l < setup_.pyramid_levels; ++l) {
      const HalfSampleArgs a{buffers_.level_depth[l - 1].view(), buffers_.level_depth[l].view(),
                             p.half_sample_range_m};
      for_each_pixel(buffers_.level_depth[l].width(), buffers_.level_depth[l].height(),
                     [&](int x, int y) { half_sample_pixel(x, y, a); });
    }
    for (int l = 0; l < setup_.pyramid_levels; ++l) {
      const DepthToVertexArgs v{buffers_.level_depth[l].view(), buffers_.level_vertex[l].view(),
                                p.level_intrinsics[l].inverse_matrix()};
      for_each_pixel(v.vertex.width, v.vertex.height,
                     [&](int x, int y) { depth_to_vertex_pixel(x, y, v); });
      const VertexToNormalArgs n{buffers_.level_vertex[l].view(), buffers_.level_normal[l].view(),
                                 p.level_intrinsics[l].handedness()};
      for_each_pixel(n.normal.width, n.normal.height,
                     [&](int x, int y) { vertex_to_normal_pixel(x, y, n); });
    }
  }

  void begin_tracking(const IcpGuessParams& p) override { kfx::begin_tracking(state_, p); }

  void icp_iteration(int level, const IcpParams& p) override {
    if (level_converged(state_, level)) return;
    const TrackArgs a = buffers_.track_args(level, p, &state_);
    const int grid_w = track_grid_width(a), grid_h = track_grid_height(a);
#pragma omp parallel for schedule(static)
    for (int j = 0; j < grid_h; ++j) {
      double acc[kAccumulatorSize] = {};  // local: stays in registers, no aliasing
      for (int i = 0; i < grid_w; ++i) track_sample(i, j, a, acc);
      std::copy(acc, acc + kAccumulatorSize,
                &row_partials_[static_cast<size_t>(j) * kAccumulatorSize]);
    }
    double total[kAccumulatorSize] = {};
    for (int j = 0; j < grid_h; ++j) {  // fixed order: repeatable
      const double* acc = &row_partials_[static_cast<size_t>(j) * kAccumulatorSize];
      for (int i = 0; i < kAccumulatorSize; ++i) total[i] += acc[i];
    }
    icp_update(state_, total, p.icp_threshold, level);
  }

  void accept_or_revert(const AcceptParams& p) override { kfx::accept_or_revert(state_, p); }
  void skip_tracking() override { state_.tracked = 0; }

  void allocate_blocks(const IntegrateParams& p, bool always) override {
    map().visit([&](auto& storage) { allocate_in(storage, p, always); });
  }

  /// The dense cube holds every voxel already.
  void allocate_in(HostMap::Cube&, const IntegrateParams&, bool) {}

  /// The blocks this frame's band reaches that the map lacks, gathered by the threads and
  /// allocated by the map in key order.
  void allocate_in(HostBlockMap& blocks, const IntegrateParams& p, bool always) {
    prepare_integration(state_, always);
    state_.map_blocks_dropped = 0;
    if (!state_.integrate_now) return;
    const BlockAllocArgs a{p.k, p.mu_m, blocks.view(), buffers_.depth_m.view(), &state_};
    const int w = buffers_.depth_m.width(), h = buffers_.depth_m.height();
    // Each thread gathers the keys its rows reach that the map lacks; the map sorts them, so
    // which thread found a key first does not matter.
    // Neighbouring pixels reach the same blocks again and again: a small direct-mapped set of
    // the keys a thread checked lately spares most of the hash lookups (a key it forgot is
    // checked, and perhaps listed, again: the map deduplicates).
    constexpr int kSeenBits = 12;
    std::vector<std::vector<uint64_t>> found(static_cast<size_t>(omp_get_max_threads()));
#pragma omp parallel
    {
      std::vector<uint64_t>& mine = found[static_cast<size_t>(omp_get_thread_num())];
      std::vector<uint64_t> seen(size_t{1} << kSeenBits, kEmptyBlockKey);
#pragma omp for schedule(static)
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          band_blocks_of_pixel(x, y, a, [&](uint64_t key) {
            uint64_t& slot = seen[(key * 0x9e3779b97f4a7c15ull) >> (64 - kSeenBits)];
            if (slot == key) return;
            slot = key;
            if (a.map.hash.find(key) < 0) mine.push_back(key);
          });
        }
      }
    }
    std::vector<uint64_t> candidates;
    for (const auto& keys : found) candidates.insert(candidates.end(), keys.begin(), keys.end());
    const BlockAllocation allocation = blocks.allocate(candidates);
    state_.map_blocks = blocks.block_count();
    state_.map_blocks_dropped = allocation.dropped;
  }

  void integrate(const IntegrateParams& p, bool always) override {
    prepare_integration(state_, always);
    if (!state_.integrate_now) return;
    map().visit([&](auto& storage) { integrate_into(storage, p); });
  }

  /// Integration into the dense cube: every voxel column.
  void integrate_into(HostMap::Cube& cube, const IntegrateParams& p) {
    const IntegrateArgs a{p,
                          cube.view(),
                          buffers_.depth_m.view(),
                          &state_,
                          buffers_.level_normal[0].view(),
                          cube.colour_view(),
                          input_rgb_.view()};
    // x-lines: each thread walks contiguous voxels (the GPU takes z-lines instead). Threads
    // take whole brick layers, so no two write the same brick flag (super-brick flags are shared:
    // VolumeView::mark_touched sets them atomically).
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
    map().visit([&](auto& storage) { raycast_map(p, storage.view()); });
    neighbour_normals(p);
  }

  /// raycast_normals=neighbours: every normal from the hits (raycast_neighbour_normal_pixel).
  void neighbour_normals(const RaycastParams& p) {
    if (p.normals != RaycastNormals::kNeighbours) return;
    const RaycastNeighbourNormalArgs n{buffers_.ref_vertex.view(), buffers_.ref_normal.view(),
                                       p.k.handedness()};
    for_each_pixel(n.normal.width, n.normal.height,
                   [&](int x, int y) { raycast_neighbour_normal_pixel(x, y, n); });
  }

  void render(const RenderParams& p) override {
    const int w = buffers_.depth_m.width(), h = buffers_.depth_m.height();
    const RenderDepthArgs d =
        make_render_depth_args(buffers_.depth_m.view(), buffers_.render_depth.view(), p);
    for_each_pixel(w, h, [&](int x, int y) { render_depth_pixel(x, y, d); });
    const RenderTrackArgs t =
        make_render_track_args(buffers_.track_outcome.view(), buffers_.render_track.view(), p);
    for_each_pixel(w, h, [&](int x, int y) { render_track_pixel(x, y, t); });
    map().visit([&](auto& storage) {
      const auto map = storage.view();
      render_volume(make_render_volume_args(map, buffers_.render_volume.view(), &state_, p));
      if (!setup_.colour) return;
      render_colour(make_render_colour_args(map, dense_colour_view(storage),
                                            buffers_.render_colour.view(), &state_, p));
    });
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
    DebugMaps maps;
    maps.depth_m = buffers_.depth_m;
    maps.filtered_m = buffers_.level_depth[0];
    maps.ref_vertex = buffers_.ref_vertex;
    maps.ref_normal = buffers_.ref_normal;
    maps.track_outcome = buffers_.track_outcome;
    for (int l = 0; l < setup_.pyramid_levels; ++l) {
      maps.level_depth_m.push_back(buffers_.level_depth[l]);
      maps.level_vertex.push_back(buffers_.level_vertex[l]);
      maps.level_normal.push_back(buffers_.level_normal[l]);
    }
    return maps;
  }
  Renders read_renders() override {
    return Renders{buffers_.render_depth, buffers_.render_track, buffers_.render_volume,
                   buffers_.render_colour};
  }
  std::vector<Voxel> read_volume() override {
    const HostMap::Cube& cube = map().cube("read_volume()");
    return std::vector<Voxel>(cube.voxels.data(), cube.voxels.data() + cube.voxels.size());
  }
  std::vector<ColourVoxel> read_colour_volume() override {
    return map().visit([](auto& storage) { return dense_colours(storage); });
  }

  void reserve_mesh_extraction() override {
    map().visit([&](auto& storage) { reserve_mesh_extraction_for(storage); });
  }
  /// A block map's mesh is sized per call by the blocks in the map.
  void reserve_mesh_extraction_for(HostBlockMap&) {}
  void reserve_mesh_extraction_for(HostMap::Cube&) {
    if (!mesh_run_offset_.empty()) return;
    const size_t r = static_cast<size_t>(setup_.volume_res_vox);
    const size_t runs = static_cast<size_t>(mc_run_count(setup_.volume_res_vox));
    const size_t bricks = static_cast<size_t>(bricks_per_side(setup_.volume_res_vox));
    try {
      mesh_vertex_count_.assign(runs << kBrickShift, 0);
      mesh_triangle_offset_.assign(kMcZChunks * r * r + 1, 0);
      mesh_brick_signs_.assign(bricks * bricks * bricks, 0);
      mesh_brick_active_.assign(bricks * bricks * bricks, 0);
      mesh_run_offset_.assign(runs + 1, 0);
    } catch (const std::bad_alloc&) {
      mesh_run_offset_ = {};
      KFX_FAIL("mesh extraction of a "
               << r << "^3 volume needs "
               << mesh_scratch_bytes(setup_.volume_res_vox) / double(1 << 30)
               << " GiB of host memory beyond the volume, which could "
                  "not be allocated (use --no-mesh or a smaller -v)");
    }
  }

  MeshView extract_mesh() override {
    return map().visit([&](auto& storage) { return extract_mesh_of(storage); });
  }

  /// Marching cubes over the block map (kernels/marching_cubes_blocks.hpp).
  MeshView extract_mesh_of(HostBlockMap& blocks) {
    return extract_block_map_mesh(blocks.view(), mesh_vertices_, mesh_triangles_);
  }

  /// Marching cubes over the dense cube (kernels/marching_cubes.hpp).
  MeshView extract_mesh_of(HostMap::Cube& cube) {
    reserve_mesh_extraction_for(cube);
    const int res = cube.res;
    const VolumeView volume = cube.view();
    // Pass 0: which bricks can hold any of the mesh.
    const int b = bricks_per_side(res);
#pragma omp parallel for collapse(2) schedule(static)
    for (int bz = 0; bz < b; ++bz) {
      for (int by = 0; by < b; ++by) {
        for (int bx = 0; bx < b; ++bx) {
          mesh_brick_signs_[bx + static_cast<size_t>(by) * b + static_cast<size_t>(bz) * b * b] =
              mc_brick_sign_bits(volume, bx, by, bz);
        }
      }
    }
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < static_cast<long long>(mesh_brick_active_.size()); ++i) {
      const int bx = static_cast<int>(i % b), by = static_cast<int>(i / b % b),
                bz = static_cast<int>(i / b / b);
      mesh_brick_active_[i] = mc_brick_active(mesh_brick_signs_.data(), bx, by, bz, b);
    }
    MarchingCubesArgs a{volume,
                        &kMcTable,
                        mesh_brick_active_.data(),
                        mesh_vertex_count_.data(),
                        mesh_run_offset_.data(),
                        mesh_triangle_offset_.data(),
                        nullptr,
                        nullptr};
#pragma omp parallel for collapse(2) schedule(dynamic, 4)
    for (int chunk = 0; chunk < kMcZChunks; ++chunk) {
      for (int y = 0; y < res; ++y) {
        for (int x = 0; x < res; ++x) mc_count_column(x, y, chunk, a);
      }
    }
    // Compaction: vertex offsets per run, triangle offsets per segment.
    uint64_t vertex_total = 0;
    for (size_t run = 0; run + 1 < mesh_run_offset_.size(); ++run) {
      mesh_run_offset_[run] = static_cast<uint32_t>(vertex_total);
      vertex_total += mc_run_vertex_count(a, static_cast<long long>(run));
    }
    check_mesh_total(vertex_total, "vertices");
    mesh_run_offset_.back() = static_cast<uint32_t>(vertex_total);
    const size_t triangle_total = exclusive_scan(mesh_triangle_offset_, "triangles");
    // The output arrays only grow: no allocation or zero fill once they are large enough.
    if (mesh_vertices_.size() < vertex_total) mesh_vertices_.resize(vertex_total);
    if (mesh_triangles_.size() < triangle_total) mesh_triangles_.resize(triangle_total);
    a.vertices = mesh_vertices_.data();
    a.triangles = mesh_triangles_.data();
#pragma omp parallel for collapse(2) schedule(dynamic, 4)
    for (int chunk = 0; chunk < kMcZChunks; ++chunk) {
      for (int y = 0; y < res; ++y) {
        for (int x = 0; x < res; ++x) mc_write_column(x, y, chunk, a);
      }
    }
    return MeshView{mesh_vertices_.data(), static_cast<size_t>(vertex_total),
                    mesh_triangles_.data(), triangle_total};
  }

  void read_blocks_into(BlockMapContents& out) override {
    map().blocks("read_blocks()").contents_into(out);
  }
  void upload_blocks(const BlockMapContents& contents) override {
    HostBlockMap& blocks = map().blocks("upload_blocks()");
    blocks.load(contents);
    state_.map_blocks = blocks.block_count();
  }

  void upload_volume(const std::vector<Voxel>& voxels) override {
    const HostMap::Cube& cube = map().cube("upload_volume()");
    KFX_CHECK(
        voxels.size() == cube.voxels.size(),
        "volume of " << voxels.size() << " voxels given, the backend holds " << cube.voxels.size());
    std::copy(voxels.begin(), voxels.end(), cube.voxels.data());
    HostMemory{}.fill_bytes(cube.brick_touched, 1);
    HostMemory{}.fill_bytes(cube.super_brick_touched, 1);
  }

  void upload_colour_volume(const std::vector<ColourVoxel>& colours) override {
    check_colour_volume_upload(colours, setup_);
    const HostMap::Cube& cube = map().cube("upload_colour_volume()");
    check_colour_field_size(colours, cube.colours.size());
    std::copy(colours.begin(), colours.end(), cube.colours.data());
  }

 private:
  /// A host copy of the dense cube's colour field; empty for a block map (its colours are in
  /// its blocks) or without colour.
  static std::vector<ColourVoxel> dense_colours(const HostMap::Cube& cube) {
    return std::vector<ColourVoxel>(cube.colours.data(), cube.colours.data() + cube.colours.size());
  }
  static std::vector<ColourVoxel> dense_colours(const HostBlockMap&) { return {}; }

  /// Integration into the block map: every allocated block in view, one block per task.
  void integrate_into(HostBlockMap& blocks, const IntegrateParams& p) {
    const BlockMapView map = blocks.view();
    // Colour goes into each block's own colours (OneBlockView::colour), not a dense field.
    IntegrateArgsT<OneBlockView> a{p,
                                   OneBlockView{},
                                   buffers_.depth_m.view(),
                                   &state_,
                                   buffers_.level_normal[0].view(),
                                   ColourVolumeView{},
                                   input_rgb_.view()};
#pragma omp parallel for schedule(dynamic, 16) firstprivate(a)
    for (int b = 0; b < map.block_count; ++b) {
      const BlockInView extent = block_view_extent(map, b, a);
      if (extent == BlockInView::kOutside) continue;
      a.volume = one_block_view(map, b);
      // A block wholly in view needs no bounds per row (integrate_row_range).
      integrate_block(a, extent == BlockInView::kPartly);
    }
  }

  template <class Map>
  void raycast_map(const RaycastParams& p, const Map& map) {
    RaycastArgsT<Map> a{p, map, buffers_.ref_vertex.view(), buffers_.ref_normal.view(), &state_};
    if (p.tile_bounds) a.ranges = ray_ranges(p, map);
    const int blocks_x = (buffers_.ref_vertex.width() + p.block_x_px - 1) / p.block_x_px;
    const int blocks_y = (buffers_.ref_vertex.height() + p.block_y_px - 1) / p.block_y_px;
    if (raycast_step_of(p) == RaycastStep::kTsdf) {
#pragma omp parallel for schedule(dynamic, 2)
      for (int y = 0; y < blocks_y; ++y) raycast_row<RaycastStep::kTsdf>(y, blocks_x, a);
    } else {
#pragma omp parallel for schedule(dynamic, 2)
      for (int y = 0; y < blocks_y; ++y) raycast_row<RaycastStep::kKFusion>(y, blocks_x, a);
    }
  }

  /// The touched blocks' depth range per tile from the raycast's pose (kernels/ray_range.hpp):
  /// each thread widens its own copy of the tiles over its share of the blocks, then the copies
  /// are merged (min and max: any order gives the same tiles).
  RayRangeTiles ray_ranges(const RaycastParams& p, const BlockMapView& map) {
    const RayRangeArgs r = ray_range_args(p, buffers_.ref_vertex.width(),
                                          buffers_.ref_vertex.height(), buffers_.ray_range_tiles());
    const size_t tiles = buffers_.ray_near_bits.size();
    std::fill_n(r.tiles.near_bits, tiles, kRayRangeEmptyNear);
    std::fill_n(r.tiles.far_bits, tiles, kRayRangeEmptyFar);
    const Mat4f T_cam_world = rigid_inverse(state_.T_world_raycast);
#pragma omp parallel
    {
      std::vector<uint32_t> near(tiles, kRayRangeEmptyNear), far(tiles, kRayRangeEmptyFar);
#pragma omp for schedule(static) nowait
      for (int b = 0; b < map.block_count; ++b) {
        widen_ray_ranges(map, b, T_cam_world, r, [&](int i, uint32_t near_bits, uint32_t far_bits) {
          near[i] = std::min(near[i], near_bits);
          far[i] = std::max(far[i], far_bits);
        });
      }
#pragma omp critical
      for (size_t i = 0; i < tiles; ++i) {
        r.tiles.near_bits[i] = std::min(r.tiles.near_bits[i], near[i]);
        r.tiles.far_bits[i] = std::max(r.tiles.far_bits[i], far[i]);
      }
    }
    return r.tiles;
  }
  /// The dense cube keeps no ranges.
  RayRangeTiles ray_ranges(const RaycastParams&, const VolumeView&) { return {}; }

  template <class Args>
  void render_volume(const Args& v) {
    const int w = buffers_.depth_m.width(), h = buffers_.depth_m.height();
#pragma omp parallel for schedule(dynamic, 2)
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) render_volume_pixel(x, y, v);
    }
  }

  template <class Args>
  void render_colour(const Args& c) {
    const int w = buffers_.depth_m.width(), h = buffers_.depth_m.height();
#pragma omp parallel for schedule(dynamic, 2)
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) render_colour_pixel(x, y, c);
    }
  }

  /// This frame's intensity pyramid (photometric term) from its colour image.
  void build_intensity() {
    KFX_CHECK(input_rgb_.width() == setup_.input_width_px,
              "photometric_weight > 0 but no colour image was uploaded for this frame");
    const IntensityArgs a{input_rgb_.view(), buffers_.level_intensity[0].view(),
                          setup_.compute_ratio};
    for_each_pixel(a.out.width, a.out.height, [&](int x, int y) { intensity_pixel(x, y, a); });
    for (int l = 1; l < setup_.pyramid_levels; ++l) {
      const HalfIntensityArgs h{buffers_.level_intensity[l - 1].view(),
                                buffers_.level_intensity[l].view()};
      for_each_pixel(h.out.width, h.out.height,
                     [&](int x, int y) { half_intensity_pixel(x, y, h); });
    }
  }

  /// The undistortion table as mm → m reads it; no data when there is none.
  ImageView<const SourcePixel> source_view() const {
    return setup_.depth_source_px.empty() ? ImageView<const SourcePixel>{}
                                          : setup_.depth_source_px.view();
  }

  /// Throws kfx::Error when a mesh has more `what` than PLY's int indices address.
  static void check_mesh_total(uint64_t total, const char* what) {
    KFX_CHECK(total <= 0x7fffffffu,
              "the mesh has " << total << " " << what << ", more than PLY's int indices address");
  }

  /// Exclusive prefix sum in place over all but the last entry, which receives the total.
  static size_t exclusive_scan(std::vector<uint32_t>& counts, const char* what) {
    uint64_t total = 0;
    for (size_t i = 0; i + 1 < counts.size(); ++i) {
      const uint32_t count = counts[i];
      counts[i] = static_cast<uint32_t>(total);
      total += count;
    }
    check_mesh_total(total, what);
    counts.back() = static_cast<uint32_t>(total);
    return static_cast<size_t>(total);
  }

  BackendSetup setup_;
  HostImage<uint16_t> input_mm_;
  HostImage<Rgb8> input_rgb_;  ///< this frame's colour image (colour or photometric), input size
  FrameBuffers<HostImage, HostArray> buffers_;
  /// The maps: map 0 from BackendSetup::map_kind, more from create_map(); stages act on the
  /// selected one, map().
  MapSet<HostMap> maps_;
  HostMap& map() { return maps_.current(); }
  bool in_frame_ = false;  ///< between begin_frame() and end_frame()
  std::vector<double> row_partials_;
  // Mesh extraction (MarchingCubesArgs), allocated on first use.
  std::vector<uint8_t> mesh_brick_signs_;       ///< mc_brick_sign_bits per brick
  std::vector<uint8_t> mesh_brick_active_;      ///< mc_brick_active per brick
  std::vector<uint8_t> mesh_vertex_count_;      ///< a byte per voxel, by run
  std::vector<uint32_t> mesh_run_offset_;       ///< mc_run_count() + 1
  std::vector<uint32_t> mesh_triangle_offset_;  ///< kMcZChunks·res² + 1
  std::vector<MeshVertex> mesh_vertices_;       ///< the mesh: grows to the largest so far
  std::vector<MeshTriangle> mesh_triangles_;
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
  Mat4f staged_pose_;  ///< stage_pose()'s, for adopt_staged_pose()
};

}  // namespace

void limit_cpu_threads_of_this_thread(int threads) { omp_set_num_threads(std::max(1, threads)); }

int cpu_threads_available() { return omp_get_max_threads(); }

std::unique_ptr<Backend> make_cpu_backend(const BackendSetup& setup) {
  return std::make_unique<CpuBackend>(setup);
}

}  // namespace kfx
