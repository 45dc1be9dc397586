// A depth camera loop: 16-bit depth frames (millimetres) and the camera intrinsics in, planes
// out, one Pipeline reused for every frame (it owns all buffers: a frame allocates only when it
// needs more room than every frame before, and the stream settles), with segment tracks: a
// surface keeps its track id from frame to frame.
//
//   rangeseg_example_depth_stream [frames] [threads]
//
// The frames are rendered from the built-in demo scene with a new noise seed each, the view
// panning by 2 pixels per frame, standing in for a sensor driver. The results (segments,
// polygons) are the pipeline's and stay valid until the next process(): copy what a node keeps
// or publishes later.
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <set>

#include <rangeseg/camera.hpp>
#include <rangeseg/pipeline.hpp>
#include <rangeseg/polygons.hpp>
#include <rangeseg/synth.hpp>

namespace {

// A whole positive number, or the usage.
int count_argument(const char* text, const char* name) {
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (end == text || *end != '\0' || value < 1 || value > 1000000) {
    std::fprintf(stderr,
                 "usage: rangeseg_example_depth_stream [frames] [threads]: %s must be "
                 "a whole number >= 1, got '%s'\n",
                 name, text);
    std::exit(2);
  }
  return static_cast<int>(value);
}

}  // namespace

int main(int argc, char** argv) try {
  const int frames = argc > 1 ? count_argument(argv[1], "frames") : 10;
  const int threads = argc > 2 ? count_argument(argv[2], "threads") : 1;
  const rangeseg::synth::Scene scene = rangeseg::synth::demo_scene();
  const rangeseg::CameraIntrinsics camera{
      .fx = 525, .fy = 525, .cx = 319.5, .cy = 239.5, .width = 640, .height = 480};

  rangeseg::PipelineSettings settings = rangeseg::pipeline_preset("kinect");
  settings.threads = threads;  // row bands of one frame on a persistent thread pool
  settings.track = true;       // Segment::track_id persists across frames
  rangeseg::Pipeline pipeline(settings);
  std::set<std::uint32_t> tracks_before;

  for (int i = 0; i < frames; ++i) {
    // What a driver delivers: raw depth in millimetres, 0 = no measurement.
    rangeseg::CameraIntrinsics view = camera;
    view.cx += 2.0 * i;
    const rangeseg::DepthImage depth = rangeseg::cloud_to_depth(
        rangeseg::synth::render(scene, {.camera = view,
                                        .noise = rangeseg::synth::Noise::kinect,
                                        .seed = static_cast<std::uint64_t>(i + 1)})
            .cloud,
        0.001);
    // Depth to points into the pipeline's own buffer (a float image in metres works too).
    pipeline.process(depth.view(), camera, 0.001);
    const rangeseg::Segmentation& s = pipeline.segmentation();
    const rangeseg::Segment* largest = s.segments.empty() ? nullptr : &s.segments.front();
    std::set<std::uint32_t> tracks;
    int continued = 0;
    for (const rangeseg::Segment& segment : s.segments) {
      tracks.insert(segment.track_id);
      continued += tracks_before.contains(segment.track_id) ? 1 : 0;
    }
    tracks_before = tracks;
    std::printf("frame %2d: %2zu segments (%2d continue a track) in %5.2f ms", i, s.segments.size(),
                continued, pipeline.times().total);
    if (largest != nullptr) {
      std::printf(", largest: track %u, %.2f m^2, normal (%+.2f %+.2f %+.2f)", largest->track_id,
                  largest->area_m2, largest->normal[0], largest->normal[1], largest->normal[2]);
      // Its outline: the polygons name segments by label (the frame's), tracks by track_id.
      const rangeseg::PolygonSet& polygons = pipeline.polygons();
      for (const rangeseg::SegmentPolygons& p : polygons.segments) {
        if (p.label != largest->label) continue;
        const rangeseg::PolygonLoop& outer = polygons.loops[static_cast<std::size_t>(p.first_loop)];
        const std::array<float, 3>& v = polygons.points3d[static_cast<std::size_t>(outer.first)];
        std::printf(", outline %d vertices from (%+.2f %+.2f %+.2f) m", outer.count, v[0], v[1],
                    v[2]);
      }
    }
    std::printf("\n");
    if (s.segments.empty()) return 1;
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "error: %s\n", e.what());
  return 2;
}
