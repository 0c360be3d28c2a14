/// kfx::Reconstruction over kfx::Pipeline: the frame loop's bookkeeping (stamps, results,
/// trajectory) once, for the CLI, C++ callers and Python alike.

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <optional>

#include "api/depth_input.hpp"
#include "api/internal.hpp"
#include "api/render_view.hpp"
#include "core/platform.hpp"
#include "core/se3.hpp"
#include "io/trajectory.hpp"
#include "output/block_map_file.hpp"
#include "output/mesh_colour.hpp"
#include "output/mesh_file.hpp"
#include "output/mesh_ply.hpp"
#include "output/run_trajectory.hpp"
#include "output/volume_file.hpp"
#include "pipeline/frame_diagnostics.hpp"
#include "pipeline/inert_settings.hpp"

namespace kfx {

namespace api {

Pose to_pose(const Mat4f& m) {
  Pose p;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) p[r * 4 + c] = m.m[r][c];
  return p;
}

Mat4f to_mat4f(const Pose& p) {
  Mat4f m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m.m[r][c] = p[r * 4 + c];
  return m;
}

}  // namespace api

struct Reconstruction::Impl {
  PipelineConfig config;
  Camera camera;
  std::unique_ptr<Pipeline> pipeline;
  StageParams params;  ///< for renders from any pose
  std::vector<FrameResult> trajectory;
  std::deque<double> stamps_in_flight;
  std::deque<int> input_indices_in_flight;  ///< FrameView::input_index, −1 where not given
  HostImage<uint16_t> scratch_mm;           ///< converted depth when the caller's is not packed mm
  HostImage<Rgb8> scratch_rgb;              ///< the caller's colour, rows packed
  FrameReport last_report;
  std::string input;  ///< the sequence's name, when made for one (file headers name it)
  std::unique_ptr<FrameDiagnostics> diagnostics;  ///< warnings about the volume and the depth
  std::deque<DepthSample> samples_in_flight;      ///< judged when their frames are collected
  std::optional<double> last_stamp_s;  ///< the last submitted frame's, none since the start/reset
  /// Said once, with the first collected frame's warnings: what the input's format assumed
  /// (ResolvedSetup::warnings) and the settings that do nothing here (inert_settings.hpp).
  std::vector<std::string> input_warnings;
  /// The pose set_pose() or load_map() put the camera at, until the next frame is collected.
  std::optional<Pose> placed_pose;

  /// `from_input`: keys of `settings` that the input recommended rather than the user set.
  /// `caller_closes_loops`: as ReconstructionAccess::for_caller_closing_loops().
  Impl(const Settings& settings, const Camera& given,
       const std::vector<std::string>& from_input = {}, bool caller_closes_loops = false)
      : config(api::make_config(settings)) {
    // Online loop closure is the loop room's (src/loop/, on Ceres), a floor above this library,
    // which links neither: a reconstruction made here would run without it and say nothing. So
    // the setting is refused, before anything is allocated, unless the caller drives the
    // closure itself (kfx run).
    KFX_CHECK(caller_closes_loops || config.tracking.loop_closure == LoopClosureMode::kOff,
              "setting loop_closure=online: a reconstruction made through the library API "
              "(kfx::Reconstruction, Python's kfx.Reconstruction) does not close loops; online "
              "loop closure runs in `kfx run INPUT --set loop_closure=online`, and `kfx optimise "
              "RUN_DIR` closes the loops of a finished run: set loop_closure=off here");
    camera = given;
    const auto& k = config.input.camera_px;
    if (k[0] != 0 || k[1] != 0) {  // the setting `camera` replaces the camera's intrinsics
      camera.fx_px = k[0];
      camera.fy_px = k[1];
      camera.cx_px = k[2];
      camera.cy_px = k[3];
    }
    // The settings say which camera is used (settings_dump(), kfx run's config.txt).
    config.input.camera_px = {camera.fx_px, camera.fy_px, camera.cx_px, camera.cy_px};
    KFX_CHECK(camera.width_px > 0 && camera.height_px > 0,
              "camera of " << camera.width_px << "x" << camera.height_px << " pixels");
    KFX_CHECK(camera.fx_px != 0 && camera.fy_px != 0,
              "the camera has no intrinsics (fx, fy are 0): give them in the Camera or with the "
              "setting camera=fx,fy,cx,cy (pixels, input size)");
    if (config.input.distortion.none()) {
      const auto& d = camera.distortion;
      config.input.distortion = LensDistortion{d[0], d[1], d[2], d[3], d[4]};
    }
    config.validate();
    const Intrinsics intrinsics{camera.fx_px, camera.fy_px, camera.cx_px, camera.cy_px};
    pipeline =
        std::make_unique<Pipeline>(config, intrinsics, camera.width_px, camera.height_px,
                                   parse_backend_kind(settings.backend()), settings.cuda_device(),
                                   settings.reconstructions_on_device());
    params = pipeline->stage_params();
    diagnostics = std::make_unique<FrameDiagnostics>(config, intrinsics);
    // Settings the user set that this map kind, backend or configuration never reads.
    std::vector<std::string> user_keys;
    for (const auto& [key, value] : settings.overrides()) {
      if (std::find(from_input.begin(), from_input.end(), key) == from_input.end()) {
        user_keys.push_back(key);
      }
    }
    input_warnings = inert_setting_warnings(config, user_keys, pipeline->backend().name());
  }

  /// The frame's colour, rows packed, when the map fuses colour (setting colour) or tracking
  /// uses it (photometric_weight > 0); none else. A colour image nothing would read is an
  /// error when `colour_given` (the caller passed it for this frame: dropping it silently would
  /// hide a reconstruction made without colour), and ignored for a frame a reader read (which
  /// carries the input's colour whatever the settings).
  ImageView<const Rgb8> colour_view(const ColourView& colour, const std::string& label,
                                    bool colour_given) {
    const bool photometric = config.quality.photometric_weight > 0.0f;
    if (!config.colour.fuse && !photometric) {
      KFX_CHECK(!colour_given || colour.data == nullptr,
                label << ": a colour image was given, but this reconstruction uses none: it was "
                         "made with colour=off and photometric_weight=0 (set colour=on to fuse "
                         "colour into the map, or give no colour image)");
      return {};
    }
    KFX_CHECK(colour.data != nullptr,
              label << ": "
                    << (config.colour.fuse ? "the map fuses colour (setting colour=on)"
                                           : "tracking uses colour (photometric_weight > 0)")
                    << " but the frame has no colour image");
    KFX_CHECK(colour.width_px == camera.width_px && colour.height_px == camera.height_px,
              label << ": colour image is " << colour.width_px << "x" << colour.height_px
                    << ", the reconstruction was made for " << camera.width_px << "x"
                    << camera.height_px);
    const size_t row_bytes = 3 * static_cast<size_t>(colour.width_px);
    const size_t stride = colour.row_stride_bytes ? colour.row_stride_bytes : row_bytes;
    KFX_CHECK(stride >= row_bytes, label << ": colour rows are " << stride << " bytes apart, "
                                         << "less than a row of " << row_bytes);
    if (scratch_rgb.width() != colour.width_px || scratch_rgb.height() != colour.height_px) {
      scratch_rgb = HostImage<Rgb8>(colour.width_px, colour.height_px);
    }
    for (int y = 0; y < colour.height_px; ++y) {
      std::memcpy(&scratch_rgb(0, y), colour.data + y * stride, row_bytes);
    }
    return scratch_rgb.view();
  }

  /// The model's colour field, read from the backend; empty without colour.
  output::ColourField colour_field() { return output::read_colour_field(*pipeline); }

  /// The frame's number as the user knows it: the input's when given, else the count so far.
  int frame_number(const FrameView& frame) const {
    return frame.input_index >= 0 ? frame.input_index : pipeline->frame_count();
  }

  /// Checks `frame` and submits it. Throws, changing nothing, on a bad frame. `colour_given`:
  /// as colour_view().
  /// `given_pose`: integrated there, not tracked (frames may be in flight: the pose goes with
  /// the frame); `raycast_view` as Pipeline::submit_at_pose's.
  void submit(const FrameView& frame, bool colour_given, const Mat4f* given_pose = nullptr,
              bool raycast_view = true) {
    const std::string label = "frame " + std::to_string(frame_number(frame));
    KFX_CHECK(frame.depth.width_px == camera.width_px && frame.depth.height_px == camera.height_px,
              label << ": depth image is " << frame.depth.width_px << "x" << frame.depth.height_px
                    << ", the reconstruction was made for " << camera.width_px << "x"
                    << camera.height_px);
    const ImageView<const uint16_t> mm = api::depth_millimetres(frame.depth, scratch_mm, label);
    const ImageView<const Rgb8> rgb =
        colour_view(frame.colour, label, colour_given);  // checked before any change
    // As the readers refuse a listing whose stamps go back: the trajectory is ordered by them.
    KFX_CHECK(std::isfinite(frame.stamp_s),
              label << ": time stamp " << frame.stamp_s << " s is not a finite number");
    KFX_CHECK(!last_stamp_s || frame.stamp_s >= *last_stamp_s,
              label << ": time stamp " << frame.stamp_s << " s is earlier than the previous "
                    << "frame's (" << *last_stamp_s
                    << " s); stamps must not decrease (reset() starts over)");
    if (given_pose != nullptr) {
      const std::string problem = rigid_transform_problem(*given_pose);
      KFX_CHECK(problem.empty(), label << ": the given pose " << problem);
    }
    samples_in_flight.push_back(diagnostics->sample(mm));
    if (given_pose != nullptr) {
      pipeline->submit_at_pose(*given_pose, mm, rgb, raycast_view);
    } else {
      pipeline->submit(mm, rgb);
    }
    last_stamp_s = frame.stamp_s;
    stamps_in_flight.push_back(frame.stamp_s);
    input_indices_in_flight.push_back(frame.input_index);
  }

  /// Checks `frame` as submit() does and locates it alone (Pipeline::localise).
  Located localise(const FrameView& frame, bool colour_given) {
    const std::string label = "localise(): frame " + std::to_string(frame_number(frame));
    KFX_CHECK(frame.depth.width_px == camera.width_px && frame.depth.height_px == camera.height_px,
              label << ": depth image is " << frame.depth.width_px << "x" << frame.depth.height_px
                    << ", the reconstruction was made for " << camera.width_px << "x"
                    << camera.height_px);
    const ImageView<const uint16_t> mm = api::depth_millimetres(frame.depth, scratch_mm, label);
    const ImageView<const Rgb8> rgb = colour_view(frame.colour, label, colour_given);
    const Localisation where = pipeline->localise(mm, rgb);
    Located out;
    out.found = where.found;
    // Keyframes, not poses: the poses tried around a keyframe's (setting localise_perturb) are
    // that keyframe's.
    out.keyframes_tried = static_cast<int>(
        std::count_if(where.attempts.begin(), where.attempts.end(),
                      [](const LocaliseAttempt& a) { return a.perturbation < 0; }));
    if (where.found) out.T_world_cam = api::to_pose(where.T_world_cam);
    return out;
  }

  FrameResult collect() {
    KFX_CHECK(pipeline->frames_in_flight() > 0, "collect() without a submitted frame");
    last_report = pipeline->collect();
    FrameResult r;
    r.index = last_report.index;
    r.stamp_s = stamps_in_flight.front();
    stamps_in_flight.pop_front();
    r.input_index =
        input_indices_in_flight.front() >= 0 ? input_indices_in_flight.front() : r.index;
    input_indices_in_flight.pop_front();
    r.tracking_ran = last_report.tracking_ran;
    r.tracked = last_report.tracked;
    r.integrated = last_report.integrated;
    r.tracking_quality = last_report.quality;
    r.relocalised = last_report.relocalised;
    r.T_world_cam = api::to_pose(last_report.T_world_cam);
    r.computation_ms = last_report.computation_ms;
    r.icp_iterations = last_report.icp_iterations;
    r.tracking_constraint = last_report.constraint.eigenvalues[0];
    for (int i = 0; i < 6; ++i) r.weakest_direction[i] = last_report.constraint.weakest[i];
    r.warnings = std::move(input_warnings);  // said once, with the first frame
    input_warnings.clear();
    for (std::string& line :
         diagnostics->check(r.input_index, samples_in_flight.front(), last_report.T_world_cam,
                            last_report.tracked ? &last_report.constraint : nullptr)) {
      r.warnings.push_back(std::move(line));
    }
    samples_in_flight.pop_front();
    trajectory.push_back(r);
    placed_pose.reset();
    return r;
  }

  /// Collects every frame in flight (their results join the trajectory).
  void drain() {
    while (pipeline->frames_in_flight() > 0) collect();
  }

  output::SavedVolume volume() {
    drain();
    output::SavedVolume v;
    v.res = config.volume.resolution_vox;
    v.size_m = config.volume.size_m;
    v.voxels = pipeline->backend().read_volume();
    if (config.colour.fuse) v.colours = pipeline->backend().read_colour_volume();
    return v;
  }

  /// The map seen from `T_world_cam` at compute size, on the host from a copy of the map of
  /// either kind (render_view), so both backends give the same pictures.
  api::ViewImages view(const Mat4f& T_world_cam, bool want_depth) {
    drain();
    const int width_px = camera.width_px / config.input.compute_size_ratio;
    const int height_px = camera.height_px / config.input.compute_size_ratio;
    if (config.volume.kind == MapKind::kBlocks) {
      return api::render_view(pipeline->read_map(), params.render, width_px, height_px, T_world_cam,
                              want_depth);
    }
    output::SavedVolume v = volume();
    return api::render_view(v.voxels, v.res, v.size_m, params.render, width_px, height_px,
                            T_world_cam, want_depth);
  }

  /// Reads a dense map file into the cube (colour too where this map fuses it); returns the
  /// camera saved with it. Throws, changing nothing, on a file that does not fit.
  std::optional<output::MapCamera> load_dense_map(const std::string& path,
                                                  std::optional<KeyframeDatabase>& keyframes) {
    output::SavedVolume v = output::read_volume_file(path);
    const auto& vol = config.volume;
    KFX_CHECK(v.res == vol.resolution_vox && v.size_m == vol.size_m,
              path << ": the saved map is " << v.res << " voxels over " << v.size_m
                   << " m, this reconstruction's " << vol.resolution_vox << " over " << vol.size_m
                   << " m (set volume_resolution and volume_size_m to match)");
    check_map_camera(v.camera, path);
    drain();
    pipeline->backend().upload_volume(v.voxels);
    // A map saved with colour gives it back where this reconstruction fuses colour.
    if (config.colour.fuse && !v.colours.empty()) {
      pipeline->backend().upload_colour_volume(v.colours);
    }
    keyframes = std::move(v.keyframes);
    return v.camera;
  }

  /// The camera as a map file records it, at `pose`.
  output::MapCamera map_camera(const Pose& pose) const {
    output::MapCamera c;
    c.T_map_cam = api::to_mat4f(pose);
    c.fx_px = camera.fx_px;
    c.fy_px = camera.fy_px;
    c.cx_px = camera.cx_px;
    c.cy_px = camera.cy_px;
    c.width_px = camera.width_px;
    c.height_px = camera.height_px;
    return c;
  }

  /// Refuses a map saved with another camera (`saved`; none: an older file, not checked).
  void check_map_camera(const std::optional<output::MapCamera>& saved,
                        const std::string& path) const {
    if (!saved) return;
    const output::MapCamera& s = *saved;
    const auto near = [](float a, float b) { return std::fabs(a - b) <= 1e-4f * std::fabs(b); };
    const bool same = s.width_px == camera.width_px && s.height_px == camera.height_px &&
                      near(s.fx_px, camera.fx_px) && near(s.fy_px, camera.fy_px) &&
                      near(s.cx_px, camera.cx_px) && near(s.cy_px, camera.cy_px);
    KFX_CHECK(same, path << ": the map was saved with a camera of " << s.width_px << "x"
                         << s.height_px << " px, fx " << s.fx_px << ", fy " << s.fy_px << ", cx "
                         << s.cx_px << ", cy " << s.cy_px << "; this reconstruction's camera is "
                         << camera.width_px << "x" << camera.height_px << " px, fx " << camera.fx_px
                         << ", fy " << camera.fy_px << ", cx " << camera.cx_px << ", cy "
                         << camera.cy_px
                         << " (a map is tracked against with the camera that built it)");
  }
};

Reconstruction::Reconstruction(const Settings& settings, const Camera& camera)
    : impl_(std::make_unique<Impl>(settings, camera)) {}

Reconstruction::Reconstruction(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Reconstruction::Reconstruction(const Settings& settings, const Sequence& sequence) {
  const ResolvedSetup setup = resolve_setup(settings, sequence);
  impl_ = std::make_unique<Impl>(setup.settings, setup.camera, setup.settings_from_input);
  impl_->input = sequence.input();
  impl_->input_warnings.insert(impl_->input_warnings.begin(), setup.warnings.begin(),
                               setup.warnings.end());
}

Reconstruction::~Reconstruction() = default;
Reconstruction::Reconstruction(Reconstruction&&) noexcept = default;
Reconstruction& Reconstruction::operator=(Reconstruction&&) noexcept = default;

FrameResult Reconstruction::process(const FrameView& frame) {
  impl_->drain();
  impl_->submit(frame, true);
  return impl_->collect();
}

FrameResult Reconstruction::process(const SequenceFrame& frame) {
  impl_->drain();
  impl_->submit(frame.view(), false);
  return impl_->collect();
}

void Reconstruction::submit(const FrameView& frame) { impl_->submit(frame, true); }
void Reconstruction::submit(const SequenceFrame& frame) { impl_->submit(frame.view(), false); }
FrameResult Reconstruction::collect() { return impl_->collect(); }
FrameResult Reconstruction::integrate_at(const FrameView& frame, const Pose& T_world_cam) {
  const Mat4f pose = api::to_mat4f(T_world_cam);
  impl_->drain();  // the result returned is this frame's
  impl_->submit(frame, true, &pose);
  return impl_->collect();
}
FrameResult Reconstruction::integrate_at(const SequenceFrame& frame, const Pose& T_world_cam) {
  const Mat4f pose = api::to_mat4f(T_world_cam);
  impl_->drain();
  impl_->submit(frame.view(), false, &pose);
  return impl_->collect();
}
Located Reconstruction::localise(const FrameView& frame) {
  impl_->drain();
  return impl_->localise(frame, true);
}
Located Reconstruction::localise(const SequenceFrame& frame) {
  impl_->drain();
  return impl_->localise(frame.view(), false);
}
int Reconstruction::frames_in_flight() const { return impl_->pipeline->frames_in_flight(); }

void Reconstruction::reset() {
  impl_->drain();
  impl_->pipeline->reset();
  impl_->trajectory.clear();
  impl_->last_stamp_s.reset();
  // The camera starts over at the initial pose, not where set_pose() last put it.
  impl_->placed_pose.reset();
  const Camera& c = impl_->camera;
  impl_->diagnostics = std::make_unique<FrameDiagnostics>(
      impl_->config, Intrinsics{c.fx_px, c.fy_px, c.cx_px, c.cy_px});
}

Pose Reconstruction::pose() const {
  if (impl_->placed_pose) return *impl_->placed_pose;
  return impl_->trajectory.empty() ? initial_pose() : impl_->trajectory.back().T_world_cam;
}

void Reconstruction::set_pose(const Pose& T_world_cam) {
  const std::string problem = rigid_transform_problem(api::to_mat4f(T_world_cam));
  KFX_CHECK(problem.empty(), "set_pose(): the pose " << problem);
  impl_->drain();
  impl_->pipeline->set_pose(api::to_mat4f(T_world_cam));
  impl_->placed_pose = T_world_cam;
}
Pose Reconstruction::initial_pose() const { return api::to_pose(impl_->pipeline->initial_pose()); }
const std::vector<FrameResult>& Reconstruction::trajectory() const { return impl_->trajectory; }
int Reconstruction::frame_count() const { return impl_->pipeline->frame_count(); }

TriangleMesh Reconstruction::mesh() {
  impl_->drain();
  const MeshView view = impl_->pipeline->extract_mesh();
  TriangleMesh mesh;
  mesh.vertices_m.resize(view.vertex_count * 3);
  mesh.normals.resize(view.vertex_count * 3);
  for (size_t i = 0; i < view.vertex_count; ++i) {
    const MeshVertex& v = view.vertices[i];
    std::memcpy(&mesh.vertices_m[i * 3], &v.p_m, sizeof(float) * 3);
    std::memcpy(&mesh.normals[i * 3], &v.normal, sizeof(float) * 3);
  }
  mesh.triangles.resize(view.triangle_count * 3);
  if (view.triangle_count > 0) {
    std::memcpy(mesh.triangles.data(), view.triangles, sizeof(MeshTriangle) * view.triangle_count);
  }
  const output::ColourField colour = impl_->colour_field();
  if (!colour.empty()) {
    for (const Rgb8& c : output::vertex_colours(view.vertices, view.vertex_count, colour)) {
      mesh.colours.insert(mesh.colours.end(), {c.r, c.g, c.b});
    }
  }
  return mesh;
}

PointCloud Reconstruction::point_cloud() {
  impl_->drain();
  const DebugMaps maps = impl_->pipeline->backend().read_maps();
  PointCloud cloud;
  const auto& vertex = maps.ref_vertex;
  const auto& normal = maps.ref_normal;
  std::vector<MeshVertex> points;
  for (int y = 0; y < vertex.height(); ++y) {
    for (int x = 0; x < vertex.width(); ++x) {
      if (normal(x, y).x == kInvalidNormal) continue;  // no surface at this pixel
      const Vec3f p = vertex(x, y), n = normal(x, y);
      cloud.points_m.insert(cloud.points_m.end(), {p.x, p.y, p.z});
      cloud.normals.insert(cloud.normals.end(), {n.x, n.y, n.z});
      points.push_back(MeshVertex{p, n});
    }
  }
  const output::ColourField colour = impl_->colour_field();
  for (size_t i = 0; !colour.empty() && i < cloud.point_count(); ++i) {
    Vec3f rgb;
    const Vec3f p{cloud.points_m[3 * i], cloud.points_m[3 * i + 1], cloud.points_m[3 * i + 2]};
    if (!colour.sample(p, rgb)) rgb = Vec3f{128.0f, 128.0f, 128.0f};  // no colour there
    cloud.colours.insert(cloud.colours.end(),
                         {static_cast<uint8_t>(rgb.x + 0.5f), static_cast<uint8_t>(rgb.y + 0.5f),
                          static_cast<uint8_t>(rgb.z + 0.5f)});
  }
  return cloud;
}

RgbaImage Reconstruction::render(const Pose& T_world_cam) {
  const api::ViewImages view = impl_->view(api::to_mat4f(T_world_cam), false);
  RgbaImage image;
  image.width_px = view.shaded.width();
  image.height_px = view.shaded.height();
  image.rgba.resize(view.shaded.pixels().size() * 4);
  std::memcpy(image.rgba.data(), view.shaded.data(), image.rgba.size());
  return image;
}

FloatImage Reconstruction::render_depth(const Pose& T_world_cam) {
  const api::ViewImages view = impl_->view(api::to_mat4f(T_world_cam), true);
  FloatImage image;
  image.width_px = view.depth_m.width();
  image.height_px = view.depth_m.height();
  image.values = view.depth_m.pixels();
  return image;
}

void Reconstruction::save_trajectory(const std::string& path, const std::string& input) const {
  KFX_CHECK(impl_->pipeline->frames_in_flight() == 0,
            "save_trajectory(): collect the frames in flight first");
  std::vector<io::StampedPose> poses;
  poses.reserve(impl_->trajectory.size());
  for (const FrameResult& r : impl_->trajectory) {
    poses.push_back(io::to_stamped_pose(r.stamp_s, api::to_mat4f(r.T_world_cam)));
  }
  output::write_run_trajectory(path, poses, input.empty() ? impl_->input : input,
                               impl_->pipeline->initial_pose(),
                               impl_->pipeline->compute_intrinsics());
}

void Reconstruction::save_mesh(const std::string& path, const std::string& input) {
  output::mesh_format_of(path);  // an extension no writer serves fails before the meshing
  impl_->drain();
  MeshView mesh = impl_->pipeline->extract_mesh();
  const output::ColourField colour = impl_->colour_field();
  std::vector<Rgb8> colours;
  if (!colour.empty()) {
    colours = output::vertex_colours(mesh.vertices, mesh.vertex_count, colour);
    mesh.colours = colours.data();
  }
  output::write_mesh_file(path, mesh,
                          "kfx " + std::string(KFX_VERSION) + " mesh of " +
                              (input.empty() ? impl_->input : input) +
                              ", volume frame (as trajectory.txt), metres");
}

bool Reconstruction::map_saveable() const { return true; }  // both kinds

void Reconstruction::save_map(const std::string& path) {
  KFX_CHECK(map_saveable(), path << ": this map kind cannot be saved");
  if (impl_->config.volume.kind == MapKind::kBlocks) {  // map.kfxblocks
    impl_->drain();
    output::SavedBlockMap map;
    map.map = impl_->pipeline->read_map();
    map.camera = impl_->map_camera(pose());
    if (const Relocaliser* r = impl_->pipeline->relocaliser()) map.keyframes = r->keyframes();
    output::write_block_map_file(path, map);
    return;
  }
  output::SavedVolume volume = impl_->volume();
  volume.camera = impl_->map_camera(pose());
  if (const Relocaliser* r = impl_->pipeline->relocaliser()) volume.keyframes = r->keyframes();
  output::write_volume_file(path, volume);
}

LoadedMap Reconstruction::load_map(const std::string& path) {
  KFX_CHECK(map_saveable(), path << ": this map kind cannot be loaded");
  std::optional<output::MapCamera> camera;
  std::optional<KeyframeDatabase> keyframes;
  if (impl_->config.volume.kind == MapKind::kBlocks) {
    output::SavedBlockMap saved = output::read_block_map_file(path);
    const auto& vol = impl_->config.volume;
    KFX_CHECK(saved.map.grid_res == vol.grid_res() && saved.map.grid_size_m == vol.grid_size_m(),
              path << ": the saved map's voxels are " << saved.map.grid_size_m / saved.map.grid_res
                   << " m, this reconstruction's " << vol.grid_size_m() / vol.grid_res()
                   << " m (set voxel_size_m, or volume_size_m and volume_resolution, to match)");
    impl_->check_map_camera(saved.camera, path);
    impl_->drain();
    impl_->pipeline->load_map(saved.map);
    camera = saved.camera;
    keyframes = std::move(saved.keyframes);
  } else {
    camera = impl_->load_dense_map(path, keyframes);
  }
  impl_->pipeline->adopt_loaded_map(std::move(keyframes));
  LoadedMap loaded;
  if (const Relocaliser* r = impl_->pipeline->relocaliser(); r && !r->can_relocalise()) {
    loaded.note = path +
                  ": saved without a keyframe database (an older format, or relocalise was off, "
                  "or another compute size or fern count): this reconstruction cannot "
                  "relocalise in it; it starts from the saved camera, or give the pose with "
                  "set_pose(). ";
  }
  if (camera) {
    // The saved camera is where the camera was, not where it is: with relocalise on it is the
    // first candidate the relocaliser verifies before anything is integrated.
    const Pose saved = api::to_pose(camera->T_map_cam);
    impl_->pipeline->set_pose(api::to_mat4f(saved), /*trusted=*/false);
    impl_->placed_pose = saved;
    loaded.pose_restored = true;
  } else {
    loaded.note += path +
                   ": saved without the camera's pose (an older format): the camera "
                   "stays where it was; give the pose with set_pose() if you know it. "
                   "Nothing is integrated until a frame is tracked against the map.";
  }
  return loaded;
}

std::string Reconstruction::settings_dump() const { return impl_->pipeline->config().dump(); }
const Camera& Reconstruction::camera() const { return impl_->camera; }
int Reconstruction::compute_width_px() const {
  return impl_->camera.width_px / impl_->config.input.compute_size_ratio;
}
int Reconstruction::compute_height_px() const {
  return impl_->camera.height_px / impl_->config.input.compute_size_ratio;
}
std::string Reconstruction::backend_name() const { return impl_->pipeline->backend().name(); }
std::string Reconstruction::device_name() const { return impl_->pipeline->backend().device_name(); }

Reconstruction ReconstructionAccess::for_caller_closing_loops(const Settings& settings,
                                                              const Camera& camera) {
  return Reconstruction(
      std::make_unique<Reconstruction::Impl>(settings, camera, std::vector<std::string>{}, true));
}
Pipeline& ReconstructionAccess::pipeline(Reconstruction& r) { return *r.impl_->pipeline; }
const FrameReport& ReconstructionAccess::last_report(const Reconstruction& r) {
  return r.impl_->last_report;
}
void ReconstructionAccess::submit(Reconstruction& r, const io::Frame& frame) {
  r.impl_->submit(api::frame_view(frame), false);
}
void ReconstructionAccess::submit_at_pose(Reconstruction& r, const io::Frame& frame,
                                          const Mat4f& T_world_cam, bool raycast_view) {
  r.impl_->submit(api::frame_view(frame), false, &T_world_cam, raycast_view);
}
const FrameDiagnostics& ReconstructionAccess::diagnostics(const Reconstruction& r) {
  return *r.impl_->diagnostics;
}
void ReconstructionAccess::set_rendering(Reconstruction& r, bool on) {
  r.impl_->pipeline->set_rendering(on);
}

}  // namespace kfx
