// Segment tracking over 640x480 Kinect frames (grabber_frame0 and 1), segmented once outside the
// loop; the tracker alternates between two frames as a stream would.
#include <benchmark/benchmark.h>

#include <array>
#include <string>

#include "bench_data.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/tracking.hpp"

namespace {

rangeseg::Segmentation segment_file(const std::string& path) {
  const rangeseg::OrganizedCloud cloud = rangeseg::io::read_pcd(path);
  const rangeseg::Mesh mesh = rangeseg::build_mesh(cloud);
  const rangeseg::NormalMap normals = rangeseg::compute_normals(cloud, mesh);
  rangeseg::Segmentation out;
  rangeseg::Segmenter().segment(cloud, mesh, normals, rangeseg::preset("kinect"), out);
  return out;
}

/// state.range(0) = 0: frame 0 and a copy of it in turn (a camera at rest); 1: frames 0 and 1
/// in turn, between which the image moves by 5 pixels (the hand-held camera pans), so that the
/// tracker counts the shared pixels a second time with the shift undone.
void BM_TrackSegments(benchmark::State& state) {
  const std::string dir = RANGESEG_SOURCE_DIR "/../shared/data/kinect/";
  if (!rangeseg::bench::have_shared_data(state, dir + "grabber_frame1.pcd")) return;
  const rangeseg::Segmentation first = segment_file(dir + "grabber_frame0.pcd");
  std::array<rangeseg::Segmentation, 2> frames{
      first, state.range(0) == 0 ? first : segment_file(dir + "grabber_frame1.pcd")};
  rangeseg::SegmentTracker tracker;
  std::size_t i = 0;
  for (auto _ : state) {
    tracker.update(frames[i++ % 2]);
    benchmark::DoNotOptimize(frames[0].segments.data());
  }
}

}  // namespace

BENCHMARK(BM_TrackSegments)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
