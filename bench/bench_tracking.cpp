// Segment tracking over pairs of 640x480 frames, segmented once outside the loop; the tracker
// alternates between the two as a stream would.
#include <benchmark/benchmark.h>

#include <array>
#include <string>

#include "bench_data.hpp"
#include "rangeseg/camera.hpp"
#include "rangeseg/io/camera_json.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/tracking.hpp"

namespace {

rangeseg::Segmentation segment_cloud(const rangeseg::OrganizedCloud& cloud) {
  const rangeseg::Mesh mesh = rangeseg::build_mesh(cloud);
  const rangeseg::NormalMap normals = rangeseg::compute_normals(cloud, mesh);
  rangeseg::Segmentation out;
  rangeseg::Segmenter().segment(cloud, mesh, normals, rangeseg::preset("kinect"), out);
  return out;
}

rangeseg::Segmentation segment_file(const std::string& path) {
  if (path.ends_with(".pcd")) return segment_cloud(rangeseg::io::read_pcd(path));
  const std::string dir = path.substr(0, path.rfind('/') + 1);
  return segment_cloud(rangeseg::depth_to_cloud(
      rangeseg::io::read_depth_png(path).view(),
      rangeseg::io::read_camera_json(dir + "camera_primesense.json"), 0.001));
}

/// state.range(0) = 0: grabber_frame0 and a copy of it in turn (a camera at rest); 1:
/// grabber_frame0 and 1 in turn, between which the image moves by 5 pixels (a hand-held camera),
/// so that the tracker counts the shared pixels a second time with the shift undone, for the
/// segments the first count did not match; 2: the PrimeSense frames 00000 and 00001 of
/// depth_png (hand-held, 34-36 segments a frame).
void BM_TrackSegments(benchmark::State& state) {
  const std::string data = RANGESEG_SOURCE_DIR "/../shared/data/";
  const std::array<std::array<std::string, 2>, 3> pairs{
      {{"kinect/grabber_frame0.pcd", "kinect/grabber_frame0.pcd"},
       {"kinect/grabber_frame0.pcd", "kinect/grabber_frame1.pcd"},
       {"depth_png/00000.png", "depth_png/00001.png"}}};
  const auto& files = pairs.at(static_cast<std::size_t>(state.range(0)));
  if (!rangeseg::bench::have_shared_data(state, data + files[1])) return;
  std::array<rangeseg::Segmentation, 2> frames{segment_file(data + files[0]),
                                               segment_file(data + files[1])};
  rangeseg::SegmentTracker tracker;
  std::size_t i = 0;
  for (auto _ : state) {
    tracker.update(frames[i++ % 2]);
    benchmark::DoNotOptimize(frames[0].segments.data());
  }
}

}  // namespace

BENCHMARK(BM_TrackSegments)->DenseRange(0, 2)->Unit(benchmark::kMillisecond);
