// rangeseg.Pipeline and its results.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "arrays.hpp"
#include "bindings.hpp"
#include "rangeseg/io/settings_json.hpp"
#include "rangeseg/pipeline.hpp"
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

PipelineSettings settings_from(const std::string& preset, const std::optional<std::string>& model,
                               std::optional<bool> smooth, int threads, const py::handle& config) {
  PipelineSettings s = pipeline_preset(preset);
  if (model) s.segmentation.model = region_model_from_string(*model);
  if (py::isinstance<py::str>(config)) {
    io::apply_settings_file(config.cast<std::string>(), s);
  } else if (py::isinstance<py::dict>(config)) {
    const auto text = py::module_::import("json").attr("dumps")(config).cast<std::string>();
    io::apply_settings_json(text, "config", s);
  } else if (!config.is_none()) {
    throw std::invalid_argument("config must be a dict or the path of a JSON file, got " +
                                std::string(py::str(py::type::of(config).attr("__name__"))));
  }
  if (smooth) s.smooth = *smooth;
  s.threads = threads;
  validate(s);
  return s;
}

class PyPipeline {
 public:
  explicit PyPipeline(const PipelineSettings& settings) : pipeline_(settings) {}

  Result process(const OrganizedCloud& cloud) {
    const std::lock_guard lock(mutex_);
    {
      const py::gil_scoped_release release;
      pipeline_.process(cloud);
    }
    return result(cloud.is_organized());
  }

  Result process_depth(const py::handle& depth, const CameraIntrinsics& camera,
                       std::optional<double> depth_scale) {
    const py::array a = py::array::ensure(depth);
    if (!a || a.ndim() != 2) {
      throw std::invalid_argument("depth must be a 2D array (H, W), got " +
                                  (a ? std::to_string(a.ndim()) + " dimensions" : "no array"));
    }
    const char kind = a.dtype().kind();
    if (kind != 'u' && kind != 'i' && kind != 'f') {
      throw std::invalid_argument("depth must hold numbers, got dtype '" +
                                  std::string(py::str(a.dtype())) + "'");
    }
    if (depth_scale && !(*depth_scale > 0 && std::isfinite(*depth_scale))) {
      throw std::invalid_argument("depth_scale must be > 0 metres per unit, got " +
                                  std::to_string(*depth_scale));
    }
    const std::lock_guard lock(mutex_);
    if (a.dtype().is(py::dtype::of<std::uint16_t>())) {
      const auto d = py::array_t<std::uint16_t, py::array::c_style>::ensure(a);
      const View<const std::uint16_t> view{d.data(), static_cast<int>(d.shape(1)),
                                           static_cast<int>(d.shape(0)), d.shape(1)};
      const py::gil_scoped_release release;
      pipeline_.process(view, camera, depth_scale.value_or(0.001));
    } else {
      // Other integers in raw units (default millimetres), floats in metres: as metres.
      const double scale = depth_scale.value_or(kind == 'f' ? 1.0 : 0.001);
      auto d = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(
          kind == 'f' && scale == 1.0 ? py::object(a) : a.attr("__mul__")(scale));
      const View<const float> view{d.data(), static_cast<int>(d.shape(1)),
                                   static_cast<int>(d.shape(0)), d.shape(1)};
      const py::gil_scoped_release release;
      pipeline_.process(view, camera);
    }
    return result(true);
  }

  const PipelineSettings& settings() const { return pipeline_.settings(); }

 private:
  Result result(bool organized) const {
    Result r;
    const Segmentation& seg = pipeline_.segmentation();
    const NormalMap& normals = pipeline_.normals();
    r.organized = organized;
    r.width = normals.width();
    r.height = normals.height();
    r.points = points_array(pipeline_.cloud());
    r.normals = normals_array(normals, organized);
    r.raw_normals = normals_array(pipeline_.raw_normals(), organized);
    r.curvature = plane_array(normals.curvature, organized);
    const bool segmented = pipeline_.settings().segment;
    r.labels = segmented ? py::object(plane_array(seg.labels, organized)) : py::none();
    const bool polygons = segmented && pipeline_.settings().polygons;
    r.segments = segments_list(seg, polygons ? &pipeline_.polygons() : nullptr);
    const StageTimes& t = pipeline_.times();
    r.times = py::dict("input"_a = t.input, "mesh"_a = t.mesh, "normals"_a = t.normals,
                       "smoothing"_a = t.smoothing, "segmentation"_a = t.segmentation,
                       "polygons"_a = t.polygons, "total"_a = t.total);
    return r;
  }

  Pipeline pipeline_;
  std::mutex mutex_;  ///< one frame at a time when Python threads share a pipeline
};

}  // namespace

void bind_pipeline(py::module_& m) {
  py::class_<Result>(m, "Result",
                     "One frame's results (copies: they stay valid after the next frame).")
      .def_readonly("labels", &Result::labels,
                    "int32 segment label per point, (H, W) or (N,): 0 = no segment, label i is "
                    "segments[i - 1]; None when the pipeline does not segment")
      .def_readonly("points", &Result::points,
                    "float32 (H, W, 3) or (N, 3): the smoothed points [m] (the input's without "
                    "smoothing), NaN where there is none")
      .def_readonly("normals", &Result::normals,
                    "float32 unit normals facing the sensor, as `points` (smoothed when smoothing "
                    "is on); NaN where a point has no mesh face")
      .def_readonly("raw_normals", &Result::raw_normals, "float32 normals before smoothing")
      .def_readonly("curvature", &Result::curvature, "float32 curvature [1/m], (H, W) or (N,)")
      .def_readonly("segments", &Result::segments,
                    "list of dicts, one per segment by pixel count descending, with the keys of "
                    "segments.json: id, model, pixel_count, area_m2, centroid, normal, offset "
                    "(normal . x + offset = 0, metres), rms_residual, grazing, surface, and "
                    "polygon for plane segments (point lists as NumPy arrays)")
      .def_readonly("times", &Result::times, "milliseconds per stage of this frame")
      .def_readonly("width", &Result::width)
      .def_readonly("height", &Result::height)
      .def_readonly("organized", &Result::organized)
      .def("__repr__", [](const Result& r) {
        return "<rangeseg.Result " + std::to_string(r.width) + " x " + std::to_string(r.height) +
               ": " + std::to_string(py::len(r.segments)) + " segments>";
      });

  py::class_<PyPipeline>(
      m, "Pipeline", R"(Mesh, normals, smoothing, segmentation and polygons of frame after frame.

The pipeline keeps its buffers between frames, so a stream of frames of one size
allocates nothing in the library after the first (the returned arrays are new).

preset: sensor settings: "kinect" (structured light, also PrimeSense and RealSense
        depth), "abw", "laser", "perceptron" or "ideal" (noise-free or simulated depth).
model:  region model: "plane", "smooth", "incremental_plane" or "auto" (planes,
        cylinders and spheres); default the preset's ("plane").
smooth: run the bilateral filter (default the preset's: on, but for abw and ideal).
threads: threads inside a frame (1..256).
config: settings on top of the preset, a dict or the path of a JSON file with the
        keys of `rangeseg segment --config` (metres, radians), e.g.
        {"segmentation": {"min_region_size": 200}}.)")
      .def(py::init([](const std::string& preset, const std::optional<std::string>& model,
                       std::optional<bool> smooth, int threads, const py::object& config) {
             return std::make_unique<PyPipeline>(
                 settings_from(preset, model, smooth, threads, config));
           }),
           "preset"_a = "kinect", "model"_a = py::none(), "smooth"_a = py::none(), "threads"_a = 1,
           "config"_a = py::none())
      .def(
          "process",
          [](PyPipeline& p, const py::object& points, const py::object& intensity,
             const py::object& colors) {
            if (py::isinstance<OrganizedCloud>(points)) {
              if (!intensity.is_none() || !colors.is_none()) {
                throw std::invalid_argument("intensity and colors are taken from the Cloud");
              }
              return p.process(points.cast<const OrganizedCloud&>());
            }
            const OrganizedCloud cloud = cloud_from_arrays(points, intensity, colors, py::none());
            return p.process(cloud);
          },
          "points"_a, "intensity"_a = py::none(), "colors"_a = py::none(),
          R"(Processes one cloud: a rangeseg.Cloud, or points as an array (H, W, 3) of an
organized cloud (a depth camera's grid) or (N, 3) of an unorganized one, in metres in
the sensor's frame (z along the view), NaN where there is no point. intensity (H, W)
or (N,) and colors (uint8 0..255 or floats 0..1, the points' shape) feed the
smoothing's intensity term. Returns a Result.)")
      .def(
          "process_depth",
          [](PyPipeline& p, const py::object& depth, double fx, double fy, double cx, double cy,
             std::optional<double> depth_scale) {
            const CameraIntrinsics camera{.fx = fx, .fy = fy, .cx = cx, .cy = cy};
            return p.process_depth(depth, camera, depth_scale);
          },
          "depth"_a, py::kw_only(), "fx"_a, "fy"_a, "cx"_a, "cy"_a, "depth_scale"_a = py::none(),
          R"(Processes a depth image (H, W) seen by a pinhole camera (fx, fy, cx, cy in
pixels): integers in raw units (0 = no measurement, depth_scale metres per unit,
default 0.001), or floats in metres (NaN or <= 0 = no measurement; depth_scale
default 1). Returns a Result.)")
      .def_property_readonly("threads", [](const PyPipeline& p) { return p.settings().threads; })
      .def_property_readonly("model",
                             [](const PyPipeline& p) {
                               return std::string(to_string(p.settings().segmentation.model));
                             })
      .def_property_readonly("smooth", [](const PyPipeline& p) { return p.settings().smooth; });
}

}  // namespace rangeseg::python
