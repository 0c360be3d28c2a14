/// kfx._kfx: the public API (include/kfx/) for Python. A thin layer: numpy arrays in and out
/// (no copies where the layout allows), the GIL released while frames run, kfx::Error as
/// kfx.Error. No logic of its own beyond checking what numpy hands in.

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/array.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <cstring>
#include <kfx/kfx.hpp>
#include <sstream>

namespace nb = nanobind;
using namespace nb::literals;

namespace {

using AnyArray = nb::ndarray<nb::ro>;

/// A numpy array that owns `values` (moved to the heap, freed with the array).
template <class T>
nb::ndarray<nb::numpy, T> owned_array(std::vector<T>&& values,
                                      std::initializer_list<size_t> shape) {
  auto* heap = new std::vector<T>(std::move(values));
  nb::capsule owner(heap, [](void* p) noexcept { delete static_cast<std::vector<T>*>(p); });
  return nb::ndarray<nb::numpy, T>(heap->data(), shape.size(), shape.begin(), owner);
}

/// A new 4x4 float32 numpy array (an object, so that properties return it as it is).
nb::object pose_array(const kfx::Pose& pose) {
  std::vector<float> values(pose.begin(), pose.end());
  return nb::cast(owned_array(std::move(values), {4, 4}));
}

kfx::Pose pose_from(const AnyArray& a) {
  if (a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4) {
    throw nb::value_error("a pose must be a 4x4 array");
  }
  kfx::Pose pose;
  for (size_t r = 0; r < 4; ++r) {
    for (size_t c = 0; c < 4; ++c) {
      const int64_t offset = a.stride(0) * r + a.stride(1) * c;
      if (a.dtype() == nb::dtype<float>()) {
        pose[r * 4 + c] = static_cast<const float*>(a.data())[offset];
      } else if (a.dtype() == nb::dtype<double>()) {
        pose[r * 4 + c] = static_cast<float>(static_cast<const double*>(a.data())[offset]);
      } else {
        throw nb::type_error("a pose must be a float32 or float64 array");
      }
    }
  }
  return pose;
}

std::string shape_text(const AnyArray& a) {
  std::ostringstream s;
  s << "(";
  for (size_t i = 0; i < a.ndim(); ++i) s << (i ? ", " : "") << a.shape(i);
  s << (a.ndim() == 1 ? ",)" : ")");
  return s.str();
}

/// True when `a` is C-contiguous (strides in elements, as nanobind gives them).
bool c_contiguous(const AnyArray& a) {
  int64_t expected = 1;
  for (size_t i = a.ndim(); i-- > 0;) {
    if (a.shape(i) != 1 && a.stride(i) != expected) return false;
    expected *= static_cast<int64_t>(a.shape(i));
  }
  return true;
}

/// A FrameView over numpy arrays, checked: dtype, shape, layout (no copy is made).
kfx::FrameView frame_view(const AnyArray& depth, double stamp_s, std::optional<double> depth_scale,
                          const std::optional<AnyArray>& colour, std::optional<int> input_index) {
  kfx::FrameView v;
  if (input_index && *input_index < 0) {
    throw nb::value_error("input_index must be a frame number, 0 or more (None: not given)");
  }
  v.input_index = input_index.value_or(-1);
  if (depth.dtype() == nb::dtype<uint16_t>()) {
    v.depth.type = kfx::DepthType::kUint16;
    v.depth.units_per_m = depth_scale.value_or(1000.0);
  } else if (depth.dtype() == nb::dtype<float>()) {
    if (depth_scale) {
      throw nb::value_error("depth_scale applies to uint16 depth only (float32 depth is metres)");
    }
    v.depth.type = kfx::DepthType::kFloat32;
  } else {
    throw nb::type_error(
        "depth must be a uint16 (units, depth_scale to a metre; millimetres by default) or "
        "float32 (metres) array");
  }
  if (depth.ndim() != 2) {
    throw nb::value_error(
        ("depth must be a 2-D array (height, width), got shape " + shape_text(depth)).c_str());
  }
  if (!c_contiguous(depth)) {
    throw nb::value_error(
        "depth must be C-contiguous (numpy.ascontiguousarray(depth) makes a contiguous copy)");
  }
  v.depth.data = depth.data();
  v.depth.height_px = static_cast<int>(depth.shape(0));
  v.depth.width_px = static_cast<int>(depth.shape(1));
  if (colour) {
    const AnyArray& c = *colour;
    if (c.dtype() != nb::dtype<uint8_t>()) throw nb::type_error("colour must be a uint8 array");
    if (c.ndim() != 3 || c.shape(2) != 3) {
      throw nb::value_error(
          ("colour must be an array of shape (height, width, 3), got " + shape_text(c)).c_str());
    }
    if (c.shape(0) != depth.shape(0) || c.shape(1) != depth.shape(1)) {
      throw nb::value_error(
          ("colour of shape " + shape_text(c) + " does not match the depth's " + shape_text(depth))
              .c_str());
    }
    if (!c_contiguous(c)) {
      throw nb::value_error(
          "colour must be C-contiguous (numpy.ascontiguousarray(colour) makes a contiguous copy)");
    }
    v.colour.data = static_cast<const uint8_t*>(c.data());
    v.colour.width_px = v.depth.width_px;
    v.colour.height_px = v.depth.height_px;
  }
  v.stamp_s = stamp_s;
  return v;
}

/// An image's pixels as a numpy array: (height, width, 4) uint8 RGBA, or (height, width) float32.
nb::ndarray<nb::numpy, uint8_t> image_array(kfx::RgbaImage&& image) {
  const size_t h = image.height_px, w = image.width_px;
  return owned_array(std::move(image.rgba), {h, w, 4});
}
nb::ndarray<nb::numpy, float> image_array(kfx::FloatImage&& image) {
  const size_t h = image.height_px, w = image.width_px;
  return owned_array(std::move(image.values), {h, w});
}

/// `render(r, pose)` from `pose` (4x4; None: the current pose) with the GIL released, as a
/// numpy array (made with the GIL held).
template <class Render>
auto render_array(kfx::Reconstruction& r, const std::optional<AnyArray>& pose, Render render) {
  const kfx::Pose p = pose ? pose_from(*pose) : r.pose();
  decltype(render(r, p)) image;
  {
    nb::gil_scoped_release release;
    image = render(r, p);
  }
  return image_array(std::move(image));
}

/// The library's errors say what to do in `kfx run`'s words (its flags); Python users get the
/// keyword arguments and settings keys that do the same. Each pair: the command line's phrase,
/// Python's.
std::string python_advice(std::string message) {
  static const std::pair<const char*, const char*> kPhrases[] = {
      {"give -k fx,fy,cx,cy", "give camera=kfx.Camera(...) or the setting camera=(fx, fy, cx, cy)"},
      {"with -k fx,fy,cx,cy", "with camera=kfx.Camera(...) or the setting camera=(fx, fy, cx, cy)"},
      {"(-k / camera)", "(camera)"},
      {"use --backend cpu", "use backend=\"cpu\""},
      {"or --backend cpu", "or backend=\"cpu\""},
      {"use --no-mesh or a smaller -v", "use a smaller volume_resolution"},
      {"(-v / volume_resolution)", "(volume_resolution)"},
      {"is --depth-scale right?", "is depth_scale right?"},
      {"--skip-bad-frames", "skip_bad_frames=True"},
  };
  for (const auto& [cli, python] : kPhrases) {
    for (size_t at = message.find(cli); at != std::string::npos;
         at = message.find(cli, at + std::strlen(python))) {
      message.replace(at, std::strlen(cli), python);
    }
  }
  return message;
}

}  // namespace

NB_MODULE(_kfx, m) {
  m.doc() = "kfx: KinectFusion (dense RGB-D SLAM) for CPUs and NVIDIA GPUs (compiled part).";
  static nb::exception<kfx::Error> error_type(m, "Error", PyExc_RuntimeError);
  // Tried before the plain translation nb::exception registered (the latest comes first).
  nb::register_exception_translator(
      [](const std::exception_ptr& p, void* type) {
        try {
          std::rethrow_exception(p);
        } catch (const kfx::Error& e) {
          PyErr_SetString(static_cast<PyObject*>(type), python_advice(e.what()).c_str());
        }
      },
      error_type.ptr());
  m.def("_python_advice", &python_advice,
        "A library message with the command line's advice in Python's words (for tests).");

  m.def("version", &kfx::version, "kfx's version.");
  m.def(
      "has_cuda",
      [] {
        std::string why;
        const bool ok = kfx::has_cuda(&why);
        return std::make_pair(ok, why);
      },
      "(True, '') when this build has the CUDA backend and a GPU is present, else (False, why).");
  m.def("has_openni2", &kfx::has_openni2,
        "True when this kfx was built with OpenNI2, which reads .oni recordings and OpenNI2 "
        "devices (openni2: inputs, kfx live --openni).");
  m.def("presets", &kfx::Settings::presets, "Names of the presets.");
  m.def(
      "settings_table",
      [] {
        std::vector<std::tuple<std::string, std::string, std::string, std::string>> rows;
        for (const auto& s : kfx::Settings::table())
          rows.emplace_back(s.key, s.section, s.help, s.default_value);
        return rows;
      },
      "Every setting as (key, section, help, default in the exact preset), in table order.");

  nb::class_<kfx::Settings>(m, "Settings",
                            "A preset plus key=value overrides, checked by the one settings "
                            "table (`kfx settings` lists it), and the backend to run on.")
      .def(nb::init<const std::string&>(), "preset"_a = "exact")
      .def("set", nb::overload_cast<const std::string&, const std::string&>(&kfx::Settings::set),
           "key"_a, "value"_a, nb::rv_policy::reference_internal,
           "Overrides one setting; raises kfx.Error on an unknown key or a malformed value.")
      .def_prop_ro("preset", &kfx::Settings::preset)
      .def_prop_ro("overrides", &kfx::Settings::overrides)
      .def("get", &kfx::Settings::get, "key"_a, "The value `key` has, as text.")
      .def("validate", &kfx::Settings::validate, "Checks the whole combination.")
      .def("dump", &kfx::Settings::dump, "`key = value` lines for every setting.")
      .def("__copy__", [](const kfx::Settings& s) { return kfx::Settings(s); })
      .def_prop_rw(
          "backend", [](const kfx::Settings& s) { return s.backend(); },
          [](kfx::Settings& s, const std::string& b) { s.backend(b); }, "'cpu', 'cuda' or 'auto'.")
      .def_prop_rw(
          "cuda_device", [](const kfx::Settings& s) { return s.cuda_device(); },
          [](kfx::Settings& s, int i) { s.cuda_device(i); },
          "CUDA device index (-1: the current one).");

  nb::class_<kfx::Camera>(m, "Camera", "A pinhole depth camera at input resolution.")
      .def(
          "__init__",
          [](kfx::Camera* c, int width, int height, float fx, float fy, float cx, float cy,
             std::array<float, 5> distortion) {
            new (c) kfx::Camera{width, height, fx, fy, cx, cy, distortion};
          },
          "width"_a, "height"_a, "fx"_a, "fy"_a, "cx"_a, "cy"_a,
          "distortion"_a = std::array<float, 5>{},
          "Size in pixels, focal lengths and principal point in pixels, and the lens's k1, k2, "
          "p1, p2, k3 (used only with depth_undistortion).")
      .def_rw("width", &kfx::Camera::width_px)
      .def_rw("height", &kfx::Camera::height_px)
      .def_rw("fx", &kfx::Camera::fx_px)
      .def_rw("fy", &kfx::Camera::fy_px)
      .def_rw("cx", &kfx::Camera::cx_px)
      .def_rw("cy", &kfx::Camera::cy_px)
      .def_rw("distortion", &kfx::Camera::distortion)
      .def("__repr__", [](const kfx::Camera& c) {
        std::ostringstream s;
        s << "Camera(width=" << c.width_px << ", height=" << c.height_px << ", fx=" << c.fx_px
          << ", fy=" << c.fy_px << ", cx=" << c.cx_px << ", cy=" << c.cy_px << ")";
        return s.str();
      });

  nb::class_<kfx::SequenceFrame>(m, "Frame", "One frame a Sequence read.")
      .def_ro("index", &kfx::SequenceFrame::index, "Position in the sequence, from 0.")
      .def_ro("stamp", &kfx::SequenceFrame::stamp_s, "The dataset's time stamp, seconds.")
      .def_ro("source", &kfx::SequenceFrame::source, "The file (and frame) it came from.")
      .def_prop_ro(
          "depth",
          [](kfx::SequenceFrame& f) {
            const size_t shape[2] = {static_cast<size_t>(f.height_px),
                                     static_cast<size_t>(f.width_px)};
            return nb::ndarray<nb::numpy, uint16_t, nb::ndim<2>, nb::ro>(f.depth_mm.data(), 2,
                                                                         shape, nb::handle());
          },
          nb::rv_policy::reference_internal,
          "Depth in millimetres, uint16 (height, width), 0 = no measurement (a read-only view).")
      .def_prop_ro(
          "colour",
          [](kfx::SequenceFrame& f) -> std::optional<nb::ndarray<nb::numpy, uint8_t, nb::ro>> {
            if (f.colour.empty()) return std::nullopt;
            const size_t shape[3] = {static_cast<size_t>(f.height_px),
                                     static_cast<size_t>(f.width_px), 3};
            return nb::ndarray<nb::numpy, uint8_t, nb::ro>(f.colour.data(), 3, shape, nb::handle());
          },
          nb::rv_policy::reference_internal, "Colour, uint8 (height, width, 3), or None.");

  nb::enum_<kfx::ReadStatus>(m, "ReadStatus")
      .value("OK", kfx::ReadStatus::kOk)
      .value("END", kfx::ReadStatus::kEnd)
      .value("BAD_FRAME", kfx::ReadStatus::kBadFrame);

  nb::class_<kfx::Sequence>(m, "Sequence",
                            "Frames of a TUM RGB-D or ICL-NUIM folder, a SLAMBench .raw or "
                            "synthetic[:key=value,...], read in order.")
      .def(nb::init<const std::string&, double, const std::string&>(), "input"_a,
           "depth_scale"_a = 0.0, "ground_truth"_a = "",
           "Opens `input`; depth_scale: PNG units per metre (0: the format's); ground_truth: a "
           "TUM trajectory to use instead of the one found beside the input.")
      .def(
          "read",
          [](kfx::Sequence& s) {
            auto frame = std::make_unique<kfx::SequenceFrame>();
            kfx::ReadStatus status;
            {
              nb::gil_scoped_release release;
              status = s.next(*frame);
            }
            return std::make_pair(status,
                                  status == kfx::ReadStatus::kOk
                                      ? nb::cast(frame.release(), nb::rv_policy::take_ownership)
                                      : nb::none());
          },
          "Reads the next frame: (ReadStatus.OK, Frame), (ReadStatus.END, None) or "
          "(ReadStatus.BAD_FRAME, None) with `message` saying why.")
      .def(
          "_reopen",
          [](kfx::Sequence& s, double depth_scale, const std::string& ground_truth) {
            s = kfx::Sequence(s.input(), depth_scale, ground_truth);
          },
          "depth_scale"_a, "ground_truth"_a,
          "Opens the input again (as constructed), so that reading starts from its first frame.")
      .def_prop_ro("message", &kfx::Sequence::message, "The problem of the last bad frame.")
      .def_prop_ro("input", &kfx::Sequence::input)
      .def_prop_ro("width", &kfx::Sequence::width_px)
      .def_prop_ro("height", &kfx::Sequence::height_px)
      .def_prop_ro("frame_count", &kfx::Sequence::frame_count, "Frames, or -1 when unknown.")
      .def_prop_ro("has_colour", &kfx::Sequence::has_colour,
                   "True when the frames carry a colour image (registered to the depth).")
      .def_prop_ro("camera", &kfx::Sequence::camera, "The format's camera, or None.")
      .def_prop_ro("camera_source",
                   [](const kfx::Sequence& s) { return python_advice(s.camera_source()); })
      .def_prop_ro("description",
                   [](const kfx::Sequence& s) { return python_advice(s.description()); })
      .def_prop_ro("recommended_settings", &kfx::Sequence::recommended_settings)
      .def(
          "ground_truth",
          [](const kfx::Sequence& s) {
            const auto poses = s.ground_truth();
            std::vector<double> values;
            values.reserve(poses.size() * 8);
            for (const auto& p : poses) {
              values.push_back(p.stamp_s);
              values.insert(values.end(), p.t.begin(), p.t.end());
              values.insert(values.end(), p.q.begin(), p.q.end());
            }
            return owned_array(std::move(values), {poses.size(), 8});
          },
          "Ground truth, (N, 8) float64: stamp tx ty tz qx qy qz qw (camera to world).");

  nb::class_<kfx::FrameResult>(m, "FrameResult", "What happened to one frame.")
      .def_ro("index", &kfx::FrameResult::index,
              "Frame number, from 0 since the start or the last reset.")
      .def_ro("input_index", &kfx::FrameResult::input_index,
              "The frame's number in its input (a Sequence's Frame.index, or the input_index "
              "given with an array), else `index`; warnings name it.")
      .def_ro("stamp", &kfx::FrameResult::stamp_s)
      .def_ro("tracking_ran", &kfx::FrameResult::tracking_ran)
      .def_ro("tracked", &kfx::FrameResult::tracked, "Tracking held.")
      .def_prop_ro(
          "lost", [](const kfx::FrameResult& r) { return r.tracking_ran && !r.tracked; },
          "Tracking ran and failed (the pose was kept, the frame not integrated).")
      .def_ro("integrated", &kfx::FrameResult::integrated)
      .def_prop_ro(
          "tracking_state",
          [](const kfx::FrameResult& r) { return kfx::tracking_quality_name(r.tracking_quality); },
          "'good', 'poor' (tracked, but the view lets the pose slide) or 'lost' (tracking "
          "failed, or not yet located in a loaded map); docs/tracking.md.")
      .def_ro("relocalised", &kfx::FrameResult::relocalised,
              "Setting relocalise: the lost camera was found again at this frame (integration "
              "resumes from the next).")
      .def_ro("computation_ms", &kfx::FrameResult::computation_ms)
      .def_ro("icp_iterations", &kfx::FrameResult::icp_iterations)
      .def_ro("tracking_constraint", &kfx::FrameResult::tracking_constraint,
              "How well the ICP pinned the pose: the smallest eigenvalue of its normal matrix "
              "about the camera, per inlier (0 when tracking did not run; near 0: the pose can "
              "slide along the weakest direction unnoticed).")
      .def_ro("weakest_direction", &kfx::FrameResult::weakest_direction,
              "The weakest direction, (tx, ty, tz, wx, wy, wz) in the camera's axes.")
      .def_prop_ro(
          "warnings",
          [](const kfx::FrameResult& r) {
            std::vector<std::string> lines;
            for (const auto& line : r.warnings) lines.push_back(python_advice(line));
            return lines;
          },
          "Warnings that begin at this frame (camera or depth outside the volume, depth "
          "implausible for the depth scale, tracking poorly constrained); usually empty.")
      .def_prop_ro(
          "pose", [](const kfx::FrameResult& r) { return pose_array(r.T_world_cam); },
          "The camera's pose after the frame, 4x4 float32 (camera to map frame, metres).")
      .def("__repr__", [](const kfx::FrameResult& r) {
        std::ostringstream s;
        s << "FrameResult(index=" << r.index << ", input_index=" << r.input_index
          << ", stamp=" << r.stamp_s << ", tracked=" << (r.tracked ? "True" : "False")
          << ", integrated=" << (r.integrated ? "True" : "False") << ")";
        return s.str();
      });

  nb::class_<kfx::Reconstruction>(m, "_Reconstruction")
      .def(nb::init<const kfx::Settings&, const kfx::Camera&>(), "settings"_a, "camera"_a)
      .def(nb::init<const kfx::Settings&, const kfx::Sequence&>(), "settings"_a, "sequence"_a)
      .def(
          "process_frame",
          [](kfx::Reconstruction& r, const kfx::SequenceFrame& f) { return r.process(f); },
          "frame"_a, nb::call_guard<nb::gil_scoped_release>())
      .def(
          "submit_frame", [](kfx::Reconstruction& r, const kfx::SequenceFrame& f) { r.submit(f); },
          "frame"_a, nb::call_guard<nb::gil_scoped_release>())
      .def(
          "process_array",
          [](kfx::Reconstruction& r, const AnyArray& depth, double stamp,
             std::optional<double> depth_scale, std::optional<AnyArray> colour,
             std::optional<int> input_index) {
            const kfx::FrameView v = frame_view(depth, stamp, depth_scale, colour, input_index);
            nb::gil_scoped_release release;
            return r.process(v);
          },
          "depth"_a, "stamp"_a = 0.0, "depth_scale"_a = nb::none(), "colour"_a = nb::none(),
          "input_index"_a = nb::none())
      .def(
          "submit_array",
          [](kfx::Reconstruction& r, const AnyArray& depth, double stamp,
             std::optional<double> depth_scale, std::optional<AnyArray> colour,
             std::optional<int> input_index) {
            const kfx::FrameView v = frame_view(depth, stamp, depth_scale, colour, input_index);
            nb::gil_scoped_release release;
            r.submit(v);
          },
          "depth"_a, "stamp"_a = 0.0, "depth_scale"_a = nb::none(), "colour"_a = nb::none(),
          "input_index"_a = nb::none())
      .def(
          "integrate_frame_at",
          [](kfx::Reconstruction& r, const kfx::SequenceFrame& f, const AnyArray& pose) {
            const kfx::Pose p = pose_from(pose);
            nb::gil_scoped_release release;
            return r.integrate_at(f, p);
          },
          "frame"_a, "pose"_a)
      .def(
          "integrate_array_at",
          [](kfx::Reconstruction& r, const AnyArray& depth, const AnyArray& pose, double stamp,
             std::optional<double> depth_scale, std::optional<AnyArray> colour,
             std::optional<int> input_index) {
            const kfx::FrameView v = frame_view(depth, stamp, depth_scale, colour, input_index);
            const kfx::Pose p = pose_from(pose);
            nb::gil_scoped_release release;
            return r.integrate_at(v, p);
          },
          "depth"_a, "pose"_a, "stamp"_a = 0.0, "depth_scale"_a = nb::none(),
          "colour"_a = nb::none(), "input_index"_a = nb::none())
      .def(
          "localise_frame",
          [](kfx::Reconstruction& r, const kfx::SequenceFrame& f) -> std::optional<nb::object> {
            kfx::Located where;
            {
              nb::gil_scoped_release release;
              where = r.localise(f);
            }
            if (!where.found) return std::nullopt;
            return pose_array(where.T_world_cam);
          },
          "frame"_a)
      .def(
          "localise_array",
          [](kfx::Reconstruction& r, const AnyArray& depth, std::optional<double> depth_scale,
             std::optional<AnyArray> colour) -> std::optional<nb::object> {
            const kfx::FrameView v = frame_view(depth, 0.0, depth_scale, colour, std::nullopt);
            kfx::Located where;
            {
              nb::gil_scoped_release release;
              where = r.localise(v);
            }
            if (!where.found) return std::nullopt;
            return pose_array(where.T_world_cam);
          },
          "depth"_a, "depth_scale"_a = nb::none(), "colour"_a = nb::none())
      .def("collect", &kfx::Reconstruction::collect, nb::call_guard<nb::gil_scoped_release>(),
           "Waits for the oldest submitted frame and returns its FrameResult.")
      .def_prop_ro("frames_in_flight", &kfx::Reconstruction::frames_in_flight,
                   "Frames submitted and not yet collected.")
      .def("reset", &kfx::Reconstruction::reset, nb::call_guard<nb::gil_scoped_release>(),
           "Starts over: empty map, initial pose, frame 0, results cleared.")
      .def_prop_ro(
          "pose", [](const kfx::Reconstruction& r) { return pose_array(r.pose()); },
          "The pose after the last collected frame, 4x4 float32 (camera to map frame).")
      .def_prop_ro("initial_pose",
                   [](const kfx::Reconstruction& r) { return pose_array(r.initial_pose()); })
      .def_prop_ro("frame_count", &kfx::Reconstruction::frame_count)
      .def(
          "results", [](const kfx::Reconstruction& r) { return r.trajectory(); },
          "Every collected frame's FrameResult since the start or the last reset.")
      .def(
          "poses",
          [](const kfx::Reconstruction& r) {
            const auto& t = r.trajectory();
            std::vector<float> values;
            values.reserve(t.size() * 16);
            for (const auto& f : t)
              values.insert(values.end(), f.T_world_cam.begin(), f.T_world_cam.end());
            return owned_array(std::move(values), {t.size(), 4, 4});
          },
          "Every collected frame's pose, (N, 4, 4) float32.")
      .def(
          "stamps",
          [](const kfx::Reconstruction& r) {
            std::vector<double> values;
            for (const auto& f : r.trajectory()) values.push_back(f.stamp_s);
            const size_t n = values.size();
            return owned_array(std::move(values), {n});
          },
          "Every collected frame's stamp, (N,) float64.")
      .def(
          "mesh_arrays",
          [](kfx::Reconstruction& r) {
            kfx::TriangleMesh mesh;
            {
              nb::gil_scoped_release release;
              mesh = r.mesh();
            }
            const size_t nv = mesh.vertex_count(), nt = mesh.triangle_count();
            nb::object colours = nb::none();
            if (!mesh.colours.empty())
              colours = nb::cast(owned_array(std::move(mesh.colours), {nv, 3}));
            return nb::make_tuple(owned_array(std::move(mesh.vertices_m), {nv, 3}),
                                  owned_array(std::move(mesh.normals), {nv, 3}),
                                  owned_array(std::move(mesh.triangles), {nt, 3}), colours);
          },
          "(vertices, normals, triangles, colours or None) of the map's mesh.")
      .def(
          "cloud_arrays",
          [](kfx::Reconstruction& r) {
            kfx::PointCloud cloud;
            {
              nb::gil_scoped_release release;
              cloud = r.point_cloud();
            }
            const size_t n = cloud.point_count();
            nb::object colours = nb::none();
            if (!cloud.colours.empty())
              colours = nb::cast(owned_array(std::move(cloud.colours), {n, 3}));
            return nb::make_tuple(owned_array(std::move(cloud.points_m), {n, 3}),
                                  owned_array(std::move(cloud.normals), {n, 3}), colours);
          },
          "(points, normals, colours or None) of the last raycast.")
      .def(
          "render",
          [](kfx::Reconstruction& r, std::optional<AnyArray> pose) {
            return render_array(
                r, pose, [](kfx::Reconstruction& r, const kfx::Pose& p) { return r.render(p); });
          },
          "pose"_a = nb::none(),
          "The map shaded (SLAMBench's renderVolume) from `pose` (4x4; None: the current one), "
          "(H, W, 4) uint8 at compute size.")
      .def(
          "render_depth",
          [](kfx::Reconstruction& r, std::optional<AnyArray> pose) {
            return render_array(r, pose, [](kfx::Reconstruction& r, const kfx::Pose& p) {
              return r.render_depth(p);
            });
          },
          "pose"_a = nb::none(),
          "Depth of the map (metres along the optical axis, 0: nothing) seen from `pose` (4x4; "
          "None: the current one), (H, W) float32 at compute size.")
      .def("save_trajectory", &kfx::Reconstruction::save_trajectory, "path"_a, "input"_a = "",
           "Writes the trajectory in TUM format, byte for byte as `kfx run`'s trajectory.txt "
           "(`input` names the source in its header).")
      .def("save_mesh", &kfx::Reconstruction::save_mesh, "path"_a, "input"_a = "",
           nb::call_guard<nb::gil_scoped_release>(),
           "Writes the mesh in the format its extension names: .ply (binary, as `kfx run`'s "
           "mesh.ply), .obj or .glb; any other extension is an error before anything is written.")
      .def_prop_ro("map_saveable", &kfx::Reconstruction::map_saveable)
      .def("save_map", &kfx::Reconstruction::save_map, "path"_a,
           nb::call_guard<nb::gil_scoped_release>(),
           "Writes the map (volume.kfxtsdf) where the map kind can be saved.")
      .def(
          "load_map",
          [](kfx::Reconstruction& r, const std::string& path) { return r.load_map(path).note; },
          "path"_a, nb::call_guard<nb::gil_scoped_release>(),
          "Replaces the map by one save_map() wrote (same resolution, size and camera) and puts "
          "the camera at the pose saved with it; nothing is integrated until a frame is tracked "
          "against the map (tracking_state 'lost' until then). Returns what the file lacks "
          "('' when nothing; older files hold no camera pose).")
      .def(
          "set_pose",
          [](kfx::Reconstruction& r, const AnyArray& pose) { r.set_pose(pose_from(pose)); },
          "pose"_a,
          "Puts the camera at `pose` (4x4, camera to map frame, metres) before the next frame: "
          "the first pose of a new map, or where to track from in a loaded one.")
      .def("settings_dump", &kfx::Reconstruction::settings_dump,
           "The settings in force, `key = value` lines.")
      .def_prop_ro("camera", &kfx::Reconstruction::camera)
      .def_prop_ro("compute_size",
                   [](const kfx::Reconstruction& r) {
                     return std::make_pair(r.compute_width_px(), r.compute_height_px());
                   })
      .def_prop_ro("backend", &kfx::Reconstruction::backend_name)
      .def_prop_ro("device", &kfx::Reconstruction::device_name);
}
