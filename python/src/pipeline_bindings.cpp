// rangeseg.Pipeline and its results.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <initializer_list>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "arrays.hpp"
#include "bindings.hpp"
#include "rangeseg/camera.hpp"
#include "rangeseg/io/settings_json.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/thread_pool.hpp"
#include "results.hpp"

namespace rangeseg::python {
namespace {

using namespace pybind11::literals;

/// One frame's results, copied out of the pipeline (valid after the next frame).
struct Result {
  int width = 0, height = 0;
  bool organized = true;
  py::object labels, points, normals, raw_normals, curvature;
  py::list segments;
  py::dict times;
};

/// The key ("section.key") of the first NaN or infinite number of a config dict, or "".
std::string non_finite_key(const py::dict& config, const std::string& prefix) {
  for (const auto& [key, value] : config) {
    std::string name = prefix + std::string(py::str(key));
    if (py::isinstance<py::dict>(value)) {
      std::string inner = non_finite_key(value.cast<py::dict>(), name + ".");
      if (!inner.empty()) return inner;
      continue;
    }
    const py::object plain = py::hasattr(value, "item") ? value.attr("item")()
                                                        : py::reinterpret_borrow<py::object>(value);
    if (py::isinstance<py::float_>(plain) && !std::isfinite(plain.cast<double>())) return name;
  }
  return "";
}

/// A config dict as JSON text: NumPy scalars as their values; NaN and infinity are errors.
std::string config_json(const py::dict& config) {
  const py::cpp_function plain([](const py::object& value) -> py::object {
    if (py::hasattr(value, "item")) return value.attr("item")();  // np.int64, np.float32, ...
    throw py::type_error("values must be numbers, booleans, strings or dicts, got " +
                         std::string(py::str(py::type::of(value).attr("__name__"))));
  });
  try {
    return py::module_::import("json")
        .attr("dumps")(config, "allow_nan"_a = false, "default"_a = plain)
        .cast<std::string>();
  } catch (const py::error_already_set& e) {
    if (e.matches(PyExc_TypeError)) {
      throw std::invalid_argument("config: " + std::string(py::str(e.value())));
    }
    if (!e.matches(PyExc_ValueError)) throw;
    const std::string key = non_finite_key(config, "");
    if (!key.empty()) {
      throw std::invalid_argument("config: key '" + key + "' must be a finite number");
    }
    throw std::invalid_argument("config: values must be finite numbers (" +
                                std::string(py::str(e.value())) + ")");
  }
}

/// Every setting as a dict with the keys of a config (`settings`, and what a pickle keeps).
py::object settings_dict(const PipelineSettings& settings) {
  return py::module_::import("json").attr("loads")(io::settings_to_json(settings));
}

PipelineSettings settings_from(const std::string& preset, const std::optional<std::string>& model,
                               std::optional<bool> smooth, std::optional<bool> track, int threads,
                               const py::handle& config) {
  PipelineSettings s = pipeline_preset(preset);
  if (py::isinstance<py::dict>(config)) {
    try {
      io::apply_settings_json(config_json(config.cast<py::dict>()), "config", s);
    } catch (const std::runtime_error& e) {
      throw std::invalid_argument(e.what());  // a bad value, as for the other arguments
    }
  } else if (!config.is_none()) {
    io::apply_settings_file(path_of(config, "config (a dict or the path of a JSON file)"), s);
  }
  // The keywords, when given, win over the config (unlike the command line's --model, which
  // has a default and so gives way to a config's model).
  if (model) s.segmentation.model = region_model_from_string(*model);
  if (smooth) s.smooth = *smooth;
  if (track) s.track = *track;
  if (threads < 1 || threads > 256) {
    throw std::invalid_argument("threads must be 1..256, got " + std::to_string(threads));
  }
  s.threads = threads;
  validate(s);
  if (const int cores = usable_cores(); threads > cores) {
    user_warning("threads=" + std::to_string(threads) + " on " + std::to_string(cores) +
                 " cores this process may use: the threads take turns and a frame runs slower "
                 "than on fewer");
  }
  return s;
}

/// The depth image's size, checked: (H, W) with H >= 2 and W >= 1 rows and columns.
void check_depth_shape(const py::array& a) {
  if (a.ndim() != 2 || a.shape(0) < 2 || a.shape(1) < 1 || a.shape(0) > INT_MAX ||
      a.shape(1) > INT_MAX) {
    throw std::invalid_argument(
        "depth must be a 2D array (H, W) with at least 2 rows and 1 column, got shape " +
        shape_text(a));
  }
}

void check_fx(double fx) {
  if (!(fx >= 0) || !std::isfinite(fx)) {
    throw std::invalid_argument("fx must be >= 0 pixels and finite (0 = unknown), got " +
                                number_text(fx));
  }
}

/// The median of the valid (finite, > 0) values of every 8th row and column, NaN without any.
template <class T>
double sampled_median(const View<const T>& depth) {
  std::vector<T> sample;
  for (int v = 0; v < depth.height; v += 8) {
    const T* row = depth.row(v);
    for (int u = 0; u < depth.width; u += 8) {
      if (std::isfinite(row[u]) && row[u] > 0) sample.push_back(row[u]);
    }
  }
  if (sample.empty()) return std::nan("");
  const auto middle = sample.begin() + static_cast<std::ptrdiff_t>(sample.size() / 2);
  std::nth_element(sample.begin(), middle, sample.end());
  return static_cast<double>(*middle);
}

/// A field of a Result given to its constructor: a NumPy array of `dtype`, (H, W[, channels])
/// of an organized result or (W[, channels]) of a per-point one.
struct ResultField {
  const char* name;
  const py::object& value;
  py::dtype dtype;
  int channels;  ///< 0: none
};

/// A Result's constructor (pickle's) takes what Pipeline.process makes, nothing else.
void require_result_fields(int width, int height, bool organized,
                           std::initializer_list<ResultField> fields) {
  if (width < 0 || height < 1 || organized != (height > 1)) {
    throw std::invalid_argument("Result: width " + std::to_string(width) + ", height " +
                                std::to_string(height) + ", organized " +
                                (organized ? "True" : "False") +
                                " (need width >= 0, height >= 1, organized exactly when height "
                                "> 1)");
  }
  for (const ResultField& f : fields) {
    std::vector<py::ssize_t> shape;
    if (organized) shape.push_back(height);
    shape.push_back(width);
    if (f.channels > 0) shape.push_back(f.channels);
    const bool is_array = py::isinstance<py::array>(f.value);
    const auto a = is_array ? py::reinterpret_borrow<py::array>(f.value) : py::array();
    const bool ok = is_array && a.dtype().equal(f.dtype) &&
                    std::equal(shape.begin(), shape.end(), a.shape(), a.shape() + a.ndim()) &&
                    static_cast<std::size_t>(a.ndim()) == shape.size();
    if (ok) continue;
    std::string want = "(";
    for (std::size_t k = 0; k < shape.size(); ++k) {
      want += (k > 0 ? ", " : "") + std::to_string(shape[k]);
    }
    want += shape.size() == 1 ? ",)" : ")";
    std::string message = "Result: ";
    message.append(f.name).append(" must be a ");
    message.append(py::str(py::object(f.dtype)).cast<std::string>());
    message.append(" array of shape ").append(want).append(", got a ");
    if (is_array) {
      message.append(py::str(py::object(a.dtype())).cast<std::string>());
      message.append(" array of shape ").append(shape_text(a));
    } else {
      message.append(py::str(py::type::of(f.value).attr("__name__")).cast<std::string>());
    }
    throw std::invalid_argument(message);
  }
}

/// Depth beyond this median lies beyond any depth sensor's range [m]: ten times a depth camera's
/// 20 m, as the command line's check.
constexpr double kFarthestMedian = 200.0;

/// Float depth is taken as metres: a UserWarning when its sampled median lies beyond any depth
/// sensor's range (millimetres given without depth_scale).
void warn_if_not_metres(const View<const float>& depth) {
  const double median = sampled_median(depth);
  if (!(median > kFarthestMedian)) return;
  user_warning("depth: floats are taken as metres, and their median is " + number_text(median) +
               " m; for millimetres pass depth_scale=0.001");
}

/// Depth under a given (or an integer's default) scale: a UserWarning when the sampled median
/// in metres lies outside 0.02-200 m (a depth_scale of 1 given for millimetres, or of 1e-6).
void warn_if_scale_implausible(double median, double scale) {
  constexpr double kNearestMedian = 0.02;  // [m]
  if (std::isnan(median) || (median >= kNearestMedian && median <= kFarthestMedian)) return;
  user_warning("depth: the median depth is " + number_text(median) +
               " m with depth_scale=" + number_text(scale) +
               " m per unit; is the scale right? (0.001 for millimetres, as a RealSense D400's "
               "default; 0.0001 for a D405's 0.1 mm units)");
}

class PyPipeline {
 public:
  /// `laser`: for the default preset ("auto"), the settings the pipeline takes instead of
  /// `settings` (kinect's) when its first frame is a scan round its sensor; empty for a preset
  /// the caller chose.
  PyPipeline(const PipelineSettings& settings, const std::optional<PipelineSettings>& laser)
      : pipeline_(settings), laser_(laser), grid_checked_(!laser_) {}

  /// Makes the pipeline decide on its first frame between its settings and `laser`, as the
  /// default preset does (an undecided pipeline unpickled). Before any frame only.
  void wait_for_the_first_frame(const PipelineSettings& laser) {
    const py::gil_scoped_release release;
    const std::lock_guard lock(mutex_);
    laser_ = laser;
    grid_checked_ = false;
  }

  /// The pipeline's settings and, while the default preset waits for the first frame, its
  /// laser settings (the others are kinect's), read together under the mutex, as settings():
  /// what a copy needs to decide alike.
  std::pair<PipelineSettings, std::optional<PipelineSettings>> state() const {
    const py::gil_scoped_release release;
    const std::lock_guard lock(mutex_);
    return {pipeline_.settings(), laser_};
  }

  Result process(const OrganizedCloud& cloud, double fx) {
    check_fx(fx);
    bool scanner = false;
    std::string scale;
    Result result = run(nullptr, [&] {
      choose_preset(&cloud);
      scale = first_cloud_scale_problem(cloud);
      pipeline_.process(cloud, fx);
      scanner = first_grid_is_a_scanners(cloud, fx);
    });
    if (!scale.empty()) user_warning("points: " + scale);
    if (scanner) warn_scanner_grid();
    if (fx > 0 && !cloud.is_organized()) warn_fx_unused();
    return result;
  }

  /// NumPy points into the pipeline's own input cloud, which keeps its memory between frames;
  /// filled under the mutex, as another thread's frame may be reading it.
  Result process(const py::handle& points, const py::handle& intensity, const py::handle& colors,
                 double fx) {
    check_fx(fx);
    // NumPy reads array-likes (their __array__ may run any Python code, even this pipeline)
    // before the mutex is taken; under it only the copy into the input buffer remains.
    const auto array_or_none = [](const py::handle& h, const char* name) -> py::object {
      if (h.is_none()) return py::none();
      return numeric_array(h, name);
    };
    const py::object p = numeric_array(points, "points");
    const py::object i = array_or_none(intensity, "intensity");
    const py::object c = array_or_none(colors, "colors");
    bool scanner = false, organized = true;
    std::string scale;
    Result result = run([&] { cloud_from_arrays(p, i, c, py::none(), input_); },
                        [&] {
                          choose_preset(&input_);
                          scale = first_cloud_scale_problem(input_);
                          pipeline_.process(input_, fx);
                          scanner = first_grid_is_a_scanners(input_, fx);
                          organized = input_.is_organized();
                        });
    if (!scale.empty()) user_warning("points: " + scale);
    if (scanner) warn_scanner_grid();
    if (fx > 0 && !organized) warn_fx_unused();
    return result;
  }

  Result process_depth(const py::handle& depth, const CameraIntrinsics& camera,
                       std::optional<double> depth_scale) {
    const py::array a = numeric_array(depth, "depth");
    check_depth_shape(a);
    if (depth_scale && !(*depth_scale > 0 && std::isfinite(*depth_scale))) {
      throw std::invalid_argument("depth_scale must be > 0 metres per unit, got " +
                                  number_text(*depth_scale));
    }
    const char kind = a.dtype().kind();
    // Integers of any dtype in 0..65535 take the uint16 path, so that they give its result.
    py::array raw = a;
    if (kind != 'f' && !a.dtype().is(py::dtype::of<std::uint16_t>())) {
      // Compared in NumPy: a uint64 beyond 2^63 does not fit a C++ long long.
      const bool fits = !py::bool_(a.attr("__lt__")(0).attr("any")()) &&
                        !py::bool_(a.attr("__gt__")(65535).attr("any")());
      if (fits) raw = a.attr("astype")(py::dtype::of<std::uint16_t>());
    }
    if (raw.dtype().is(py::dtype::of<std::uint16_t>())) {
      const auto d =
          py::array_t<std::uint16_t, py::array::c_style | py::array::forcecast>::ensure(raw);
      const View<const std::uint16_t> view{d.data(), static_cast<int>(d.shape(1)),
                                           static_cast<int>(d.shape(0)), d.shape(1)};
      const double scale = depth_scale.value_or(0.001);
      warn_if_scale_implausible(sampled_median(view) * scale, scale);
      return run(nullptr, [&] {
        choose_preset(nullptr);
        pipeline_.process(view, camera, scale);
      });
    }
    // Floats in metres (times depth_scale), other integers (negative: no measurement) in raw
    // units.
    const double scale = depth_scale.value_or(kind == 'f' ? 1.0 : 0.001);
    const auto d = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(
        kind == 'f' && scale == 1.0 ? py::object(a) : a.attr("__mul__")(scale));
    const View<const float> view{d.data(), static_cast<int>(d.shape(1)),
                                 static_cast<int>(d.shape(0)), d.shape(1)};
    if (kind == 'f' && !depth_scale) {
      warn_if_not_metres(view);
    } else {
      warn_if_scale_implausible(sampled_median(view), scale);  // the view is in metres
    }
    return run(nullptr, [&] {
      choose_preset(nullptr);
      pipeline_.process(view, camera);
    });
  }

  /// A copy, taken under the mutex (an auto preset's first frame may replace the pipeline).
  PipelineSettings settings() const {
    const py::gil_scoped_release release;  // as run(): the GIL is not held while waiting
    const std::lock_guard lock(mutex_);
    return pipeline_.settings();
  }
  void reset_tracks() {
    const py::gil_scoped_release release;  // as run(): the GIL is not held while waiting
    const std::lock_guard lock(mutex_);
    pipeline_.reset_tracks();
  }

 private:
  /// Runs a frame without the GIL (other Python threads go on), one at a time: `prepare` (with
  /// the GIL, e.g. to copy NumPy arrays into the pipeline's buffers; nullptr for none), `frame`,
  /// and the copies of its results, all before the next frame may start. The GIL is released before
  /// the mutex is taken: a thread that waits for the mutex must not hold the GIL that its holder
  /// needs.
  template <class Prepare, class Frame>
  Result run(Prepare&& prepare, Frame&& frame) {
    std::optional<Result> out;
    std::string why_no_segments;  // once per pipeline
    {
      const py::gil_scoped_release release;
      const std::lock_guard lock(mutex_);
      // Without a `prepare` the GIL is not taken back here: with a busy Python thread beside,
      // each acquisition may wait for its switch interval (5 ms).
      if constexpr (!std::is_null_pointer_v<std::decay_t<Prepare>>) {
        const py::gil_scoped_acquire acquire;
        prepare();
      }
      frame();
      if (!warned_no_segments_) why_no_segments = pipeline_.why_no_segments();
      if (!why_no_segments.empty()) warned_no_segments_ = true;
      const py::gil_scoped_acquire acquire;
      out.emplace(result());
    }
    if (!why_no_segments.empty()) user_warning("no segments: " + why_no_segments);
    return std::move(*out);
  }

  Result result() const {
    Result r;
    const Segmentation& seg = pipeline_.segmentation();
    const NormalMap& normals = pipeline_.normals();
    const bool organized = normals.height() > 1;  // an unorganized cloud's results are per point
    r.organized = organized;
    r.width = normals.width();
    r.height = normals.height();
    ArrayPool* const pool = arrays_.get();
    r.points = points_array(pipeline_.cloud(), pool);
    r.normals = normals_array(normals, organized, pool);
    r.raw_normals = normals_array(pipeline_.raw_normals(), organized, pool);
    r.curvature = plane_array(normals.curvature, organized, pool);
    r.labels = plane_array(seg.labels, organized, pool);
    r.segments = segments_list(seg, &pipeline_.polygons(), pipeline_.settings().segmentation);
    const StageTimes& t = pipeline_.times();
    r.times = py::dict("input"_a = t.input, "normals"_a = t.normals, "smoothing"_a = t.smoothing,
                       "segmentation"_a = t.segmentation, "polygons"_a = t.polygons,
                       "tracking"_a = t.tracking, "total"_a = t.total);
    // As the command line names them: an unorganized cloud off any pixel grid has rings; an
    // unorganized cloud's `input` is the moves onto its grid or into spatial order, and back.
    const bool over_rings = !organized && !pipeline_.pixel_grid().found();
    r.times[over_rings ? "rings" : "mesh"] = t.mesh;
    if (!organized) r.times["order"] = r.times.attr("pop")("input");
    return r;
  }

  /// The default preset decides on the first frame (under the mutex): an unorganized cloud
  /// whose points surround the sensor (a spinning lidar's scan) takes `laser_`, as the command
  /// line's --preset auto does; anything else keeps kinect. `cloud`: nullptr for a depth image.
  void choose_preset(const OrganizedCloud* cloud) {
    if (!laser_) return;
    if (cloud != nullptr && !cloud->is_organized() && surrounds_its_sensor(*cloud)) {
      pipeline_ = Pipeline(*laser_);
      grid_checked_ = true;  // a scanner's preset: its grids need no warning
    }
    laser_.reset();
  }

  Pipeline pipeline_;
  std::optional<PipelineSettings> laser_;
  /// For a pipeline made with the default preset, once (under the mutex, without the GIL):
  /// whether its first organized grid is one no pinhole camera explains, a scanner's (a spinning
  /// lidar's, a tilting laser's), for which the kinect preset's noise model, a function of z, is
  /// wrong. The command line's --preset auto notes it alike.
  bool first_grid_is_a_scanners(const OrganizedCloud& cloud, double fx) {
    // A grid without points tells nothing (why_no_segments says what is wrong with it).
    if (grid_checked_ || fx > 0 || !cloud.is_organized() || cloud.count_valid() == 0) {
      return false;
    }
    grid_checked_ = true;
    CameraIntrinsics camera;
    return !fit_intrinsics(cloud, camera);
  }
  /// The first cloud's cloud_scale_problem, else its noise_scale_problem under the pipeline's
  /// noise model (under the mutex, without the GIL): points in millimetres, in map coordinates
  /// or far from the origin give wrong segments without an error.
  std::string first_cloud_scale_problem(const OrganizedCloud& cloud) {
    if (scale_checked_ || cloud.count_valid() == 0) return {};
    scale_checked_ = true;
    std::string problem = cloud_scale_problem(cloud);
    if (problem.empty()) {
      problem = noise_scale_problem(cloud, pipeline_.settings().segmentation.noise);
    }
    return problem;
  }
  /// fx names the camera of organized points; an unorganized cloud's comes from its pixel grid
  /// when its points lie on one (and is not needed over rings).
  static void warn_fx_unused() {
    user_warning(
        "fx is not used for unorganized points (N, 3): their camera is found from the points "
        "when they lie on its pixel grid, and rings need none. Give (H, W, 3) points, or "
        "process_depth, for fx to apply");
  }

  static void warn_scanner_grid() {
    user_warning(
        "no pinhole camera explains this grid (a scanner's, or points moved out of the camera's "
        "frame); the default preset is a depth camera's (kinect). For a laser scanner or a "
        "spinning lidar give preset=\"laser\": its range noise is not a function of z.");
  }

  OrganizedCloud input_;  ///< the last NumPy points (Pipeline::cloud() may refer to it)
  /// The memory of the result arrays, reused once a frame's result is dropped (GIL held).
  std::shared_ptr<ArrayPool> arrays_ = std::make_shared<ArrayPool>();
  bool grid_checked_ = false;
  bool scale_checked_ = false;
  bool warned_no_segments_ = false;  ///< under the mutex
  mutable std::mutex mutex_;         ///< one frame at a time when Python threads share a pipeline
};

}  // namespace

void bind_pipeline(py::module_& m) {
  py::class_<Result>(m, "Result",
                     "One frame's results (copies: they stay valid after the next frame).")
      .def_readonly("labels", &Result::labels,
                    "int32 segment label per point, (H, W) or (N,): 0 = no segment, label i is "
                    "segments[i - 1]")
      .def_readonly("points", &Result::points,
                    "float32 (H, W, 3) or (N, 3): the smoothed points [m] (the input's without "
                    "smoothing), NaN where there is none")
      .def_readonly("normals", &Result::normals,
                    "float32 unit normals facing the sensor, as `points` (smoothed when smoothing "
                    "is on); NaN where a point has no mesh face, but a point of a plane found "
                    "seen at grazing incidence (segment 'grazing') has its plane's normal")
      .def_readonly("raw_normals", &Result::raw_normals, "float32 normals before smoothing")
      .def_readonly("curvature", &Result::curvature, "float32 curvature [1/m], (H, W) or (N,)")
      .def_readonly("segments", &Result::segments,
                    "list of dicts, one per segment by pixel count descending, with the keys of "
                    "segments.json: id, model, pixel_count, area_m2, centroid, normal, offset "
                    "(normal . x + offset = 0, metres), rms_residual, grazing, surface, "
                    "polygon for plane segments (point lists as NumPy arrays), and track_id "
                    "when the pipeline tracks segments")
      .def_readonly("times", &Result::times,
                    "milliseconds per stage of this frame: input, mesh, normals, smoothing, "
                    "segmentation, polygons, tracking, total; for an unorganized cloud over "
                    "rings order and rings in place of input and mesh, as the command line "
                    "prints them")
      .def_readonly("width", &Result::width,
                    "columns of the frame (points of an unorganized cloud)")
      .def_readonly("height", &Result::height, "rows of the frame (1 for an unorganized cloud)")
      .def_readonly("organized", &Result::organized,
                    "True for a grid's results (H, W, ...), False for per-point ones (N, ...)")
      // Pickled as these fields (for multiprocessing, joblib, dask), with any pickle protocol.
      .def(py::init([](int width, int height, bool organized, const py::object& labels,
                       const py::object& points, const py::object& normals,
                       const py::object& raw_normals, const py::object& curvature,
                       const py::list& segments, const py::dict& times) {
             require_result_fields(width, height, organized,
                                   {{"labels", labels, py::dtype::of<std::int32_t>(), 0},
                                    {"points", points, py::dtype::of<float>(), 3},
                                    {"normals", normals, py::dtype::of<float>(), 3},
                                    {"raw_normals", raw_normals, py::dtype::of<float>(), 3},
                                    {"curvature", curvature, py::dtype::of<float>(), 0}});
             return Result{.width = width,
                           .height = height,
                           .organized = organized,
                           .labels = labels,
                           .points = points,
                           .normals = normals,
                           .raw_normals = raw_normals,
                           .curvature = curvature,
                           .segments = segments,
                           .times = times};
           }),
           "width"_a, "height"_a, "organized"_a, "labels"_a, "points"_a, "normals"_a,
           "raw_normals"_a, "curvature"_a, "segments"_a, "times"_a,
           "A result from its fields, as pickle rebuilds one (Pipeline.process makes them).")
      .def("__reduce__",
           [](const py::object& self) {
             const auto& r = self.cast<const Result&>();
             return py::make_tuple(
                 self.attr("__class__"),
                 py::make_tuple(r.width, r.height, r.organized, r.labels, r.points, r.normals,
                                r.raw_normals, r.curvature, r.segments, r.times));
           })
      .def("__repr__", [](const Result& r) {
        // The arrays' shape, as NumPy prints it: (H, W) of a grid, (N,) of points.
        const std::string shape =
            r.organized ? "(" + std::to_string(r.height) + ", " + std::to_string(r.width) + ")"
                        : "(" + std::to_string(r.width) + ",)";
        return "<rangeseg.Result " + shape + ": " + std::to_string(py::len(r.segments)) +
               " segments>";
      });

  py::class_<PyPipeline>(
      m, "Pipeline", R"(Mesh, normals, smoothing, segmentation and polygons of frame after frame.

The pipeline keeps its buffers between frames, so a stream of frames of one size
allocates nothing in the library after the first (the returned arrays are new).

preset: sensor settings: "kinect" (structured light, also PrimeSense and RealSense
        depth), "abw", "laser" (also spinning lidars), "perceptron" or "ideal"
        (noise-free or simulated depth). Default None or "auto", decided on the first
        frame: laser when it is an unorganized cloud whose points surround the sensor
        (a spinning lidar's scan, as the command line decides), else kinect, with a
        UserWarning when it is a grid that no pinhole camera explains (a scanner's:
        give "laser"). `settings` tells the choice after the first frame.
model:  region model: "plane", "smooth", "incremental_plane" or "auto" (planes,
        cylinders and spheres); default the preset's ("plane").
smooth: run the bilateral filter (default the preset's: on, but for abw and ideal).
track:  give the segments of consecutive frames track ids (segments' "track_id"): the
        same id while a surface stays in view, for frames of one camera in order
        (default False; 0.2-0.6 ms per 640x480 frame).
threads: threads inside a frame (1..256).
config: settings on top of the preset, a dict or the path of a JSON file with the
        keys of `rangeseg segment --config` (metres, radians), e.g.
        {"segmentation": {"min_region_size": 200}}.

A frame that gives no segment for a reason of its input (no valid point; a grid
whose mesh joins hardly any of its points: points on every k-th row or column only,
or a camera too coarse for the mesh's edge bound) gives a UserWarning, once per
pipeline, that says so and, where one helps, what to change.)")
      .def(py::init([](const std::optional<std::string>& preset,
                       const std::optional<std::string>& model, std::optional<bool> smooth,
                       std::optional<bool> track, int threads, const py::object& config) {
             // None and "auto" (the command line's default) are the kinect preset, with a
             // warning for a grid that no pinhole camera explains, or laser when the first
             // frame is an unorganized scan round its sensor.
             const bool chosen = preset && *preset != "auto";
             std::optional<PipelineSettings> laser;
             if (!chosen) laser = settings_from("laser", model, smooth, track, threads, config);
             return std::make_unique<PyPipeline>(
                 settings_from(chosen ? *preset : "kinect", model, smooth, track, threads, config),
                 laser);
           }),
           "preset"_a = py::none(), "model"_a = py::none(), "smooth"_a = py::none(),
           "track"_a = py::none(), "threads"_a = 1, "config"_a = py::none())
      .def(
          "process",
          [](PyPipeline& p, const py::object& points, const py::object& intensity,
             const py::object& colors, double fx) {
            if (py::isinstance<OrganizedCloud>(points)) {
              if (!intensity.is_none() || !colors.is_none()) {
                throw std::invalid_argument("intensity and colors are taken from the Cloud");
              }
              return p.process(points.cast<const OrganizedCloud&>(), fx);
            }
            return p.process(points, intensity, colors, fx);
          },
          "points"_a, "intensity"_a = py::none(), "colors"_a = py::none(), py::kw_only(),
          "fx"_a = 0.0,
          R"(Processes one cloud: a rangeseg.Cloud, or points as an array (H, W, 3) of an
organized cloud (a depth camera's grid) or (N, 3) of an unorganized one, in metres in
the sensor's frame (z along the view), NaN where there is no point (inf, and the
point (0, 0, 0) that RealSense's SDK and many drivers write for a pixel without depth,
count as none too); an organized cloud has at least 2 rows. intensity (H, W) or (N,), or else the brightness
of colors (uint8 0..255 or floats 0..1, the points' shape), feeds the smoothing's
intensity term. fx [pixel]: the focal length of the camera of organized points, when known,
for the smoothing's pixel angle 1 / fx (unless the settings give smoothing.pixel_angle) and
the smallest segment (segmentation.min_region_size pixels at min_region_fx, the same solid
angle for a coarser camera); 0 = unknown: the pinhole camera fitted to the points, else
1 / 525 (a Kinect at 640 x 480) and min_region_size as given. Unorganized points (N, 3) do
not use fx (a UserWarning says so): their camera comes from their pixel grid. Returns a
Result.)")
      .def(
          "process_depth",
          [](PyPipeline& p, const py::object& depth, double fx, double fy, double cx, double cy,
             std::optional<double> depth_scale, int width, int height) {
            const CameraIntrinsics camera{
                .fx = fx, .fy = fy, .cx = cx, .cy = cy, .width = width, .height = height};
            return p.process_depth(depth, camera, depth_scale);
          },
          "depth"_a, py::kw_only(), "fx"_a, "fy"_a, "cx"_a, "cy"_a, "depth_scale"_a = py::none(),
          "width"_a = 0, "height"_a = 0,
          R"(Processes a depth image (H, W) seen by a pinhole camera (fx, fy, cx, cy in
pixels): integers in raw units (0 or negative = no measurement, depth_scale metres
per unit, default 0.001), or floats in metres (NaN or <= 0 = no measurement;
depth_scale default 1; without depth_scale, a UserWarning when their median is beyond
200 m: millimetres, most likely). width and height, when not 0, must be the image's (as in
read_camera's dict: process_depth(depth, **camera)). fx also sets the smallest segment, as
for process. Returns a Result.)")
      .def_property_readonly(
          "threads", [](const PyPipeline& p) { return p.settings().threads; },
          "threads inside a frame")
      .def_property_readonly(
          "model",
          [](const PyPipeline& p) {
            return std::string(to_string(p.settings().segmentation.model));
          },
          "the region model: plane, smooth, incremental_plane or auto")
      .def_property_readonly(
          "smooth", [](const PyPipeline& p) { return p.settings().smooth; },
          "whether the bilateral filter runs")
      .def_property_readonly(
          "track", [](const PyPipeline& p) { return p.settings().track; },
          "whether segments get track ids across frames")
      .def("reset_tracks", &PyPipeline::reset_tracks,
           "forget the previous frame's segments: the next frame starts new tracks (e.g. at a "
           "cut in a sequence)")
      .def_property_readonly(
          "settings", [](const PyPipeline& p) { return settings_dict(p.settings()); },
          "every setting as a dict with the keys of `config` (metres, radians): the preset's "
          "values with the config and keywords applied; a valid config itself")
      // Pickled as the constructor's arguments, its settings as the config (for
      // multiprocessing, joblib, dask), with any pickle protocol: the copy starts with empty
      // buffers and no tracks.
      .def("__reduce__",
           [](const py::object& self) {
             const auto& p = self.cast<const PyPipeline&>();
             // Undecided, the copy decides on its own first frame between the same settings:
             // made with the kinect ones, it is given the laser ones as the state pickle sets
             // by attribute (pybind11 takes a method named __setstate__ for a constructor).
             const auto [settings, laser] = p.state();
             const py::object none = py::none();
             return py::make_tuple(
                 self.attr("__class__"),
                 py::make_tuple("kinect", none, none, none, settings.threads,
                                settings_dict(settings)),
                 laser ? py::object(py::make_tuple(
                             none, py::dict("_undecided_laser"_a = settings_dict(*laser))))
                       : none);
           })
      .def_property(
          "_undecided_laser",
          [](const PyPipeline& p) -> py::object {
            const std::optional<PipelineSettings> laser = p.state().second;
            return laser ? py::object(settings_dict(*laser)) : py::object(py::none());
          },
          [](PyPipeline& p, const py::dict& laser) {
            const std::optional<std::string> no_model;
            const std::optional<bool> no_flag;
            p.wait_for_the_first_frame(
                settings_from("laser", no_model, no_flag, no_flag, p.settings().threads, laser));
          },
          "for pickling: the settings an undecided default preset takes for a scan round its "
          "sensor")
      .def("__repr__", [](const PyPipeline& p) {
        const PipelineSettings& s = p.settings();
        return "<rangeseg.Pipeline model='" + std::string(to_string(s.segmentation.model)) +
               "' smooth=" + (s.smooth ? "True" : "False") +
               " track=" + (s.track ? "True" : "False") + " threads=" + std::to_string(s.threads) +
               ">";
      });
}

}  // namespace rangeseg::python
