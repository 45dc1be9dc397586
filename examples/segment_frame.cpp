// Segments one point cloud and prints the segments: an organized cloud into planes, cylinders
// and spheres, an unorganized one (height 1) into planes, on the pixel grid its points lie on
// when they are a depth camera's (e.g. after pcl::removeNaNFromPointCloud), else over
// k-nearest-neighbour rings; all with the outline of every plane.
//
//   rangeseg_example_segment_frame [frame.pcd|.ply|.xyz|...]
//
// Without an argument it renders the built-in demo scene with Kinect-like noise.
#include <cstdio>
#include <exception>

#include <rangeseg/io/cloud_file.hpp>
#include <rangeseg/pipeline.hpp>
#include <rangeseg/synth.hpp>

namespace {

void print_segment(const rangeseg::Segment& s) {
  std::printf("%3d %-8s %7d px %7.3f m^2  rms %5.1f mm", s.label, rangeseg::to_string(s.kind),
              s.pixel_count, s.area_m2, 1000 * s.surface_rms);
  switch (s.kind) {
    case rangeseg::SurfaceKind::cylinder:
      std::printf("  radius %.3f m, axis (%+.2f %+.2f %+.2f), length %.2f m\n", s.radius, s.axis[0],
                  s.axis[1], s.axis[2], s.extent);
      break;
    case rangeseg::SurfaceKind::sphere:
      std::printf("  radius %.3f m, centre (%.2f %.2f %.2f) m\n", s.radius, s.centre[0],
                  s.centre[1], s.centre[2]);
      break;
    default:  // planes: n . x + offset = 0 in the camera frame
      std::printf("  normal (%+.2f %+.2f %+.2f), offset %.3f m\n", s.normal[0], s.normal[1],
                  s.normal[2], s.offset);
  }
}

}  // namespace

int main(int argc, char** argv) try {
  const rangeseg::OrganizedCloud cloud =
      argc > 1 ? rangeseg::io::read_cloud(argv[1])
               : rangeseg::synth::render(rangeseg::synth::demo_scene(),
                                         {.noise = rangeseg::synth::Noise::kinect})
                     .cloud;

  rangeseg::PipelineSettings settings = rangeseg::pipeline_preset("kinect");
  // Planes, cylinders and spheres on a pixel grid; an unorganized cloud (height 1) into planes
  // (which the rings support as well as the grid).
  settings.segmentation.model =
      cloud.is_organized() ? rangeseg::RegionModel::automatic : rangeseg::RegionModel::plane;
  rangeseg::Pipeline pipeline(settings);
  pipeline.process(cloud);

  const rangeseg::Segmentation& segmentation = pipeline.segmentation();
  std::printf("%d x %d points: %zu segments\n", cloud.width(), cloud.height(),
              segmentation.segments.size());
  for (const rangeseg::Segment& s : segmentation.segments) print_segment(s);

  const rangeseg::PolygonSet& polygons = pipeline.polygons();
  for (const rangeseg::SegmentPolygons& p : polygons.segments) {
    std::printf("plane %3d: %d loop(s), polygon area %.3f m^2, hull area %.3f m^2\n", p.label,
                p.loop_count, p.area, p.hull_area);
  }
  const rangeseg::StageTimes& t = pipeline.times();
  if (cloud.is_organized()) {
    std::printf(
        "first frame %.1f ms (mesh %.2f, normals %.2f, smoothing %.2f, segmentation %.2f, "
        "polygons %.2f); later frames of this size allocate nothing\n",
        t.total, t.mesh, t.normals, t.smoothing, t.segmentation, t.polygons);
  } else if (pipeline.pixel_grid().found()) {
    const rangeseg::PixelGrid& grid = pipeline.pixel_grid();
    std::printf(
        "on its %d x %d pixel grid (fx %.1f, fy %.1f px): %.1f ms (grid found, points onto it "
        "and results back %.2f, mesh %.2f, normals %.2f, smoothing %.2f, segmentation %.2f, "
        "polygons %.2f)\n",
        grid.width, grid.height, grid.fx, grid.fy, t.total, t.input, t.mesh, t.normals, t.smoothing,
        t.segmentation, t.polygons);
  } else {
    std::printf(
        "over rings: %.1f ms (points into spatial order and results back %.2f, rings %.2f, "
        "normals %.2f, smoothing %.2f, segmentation %.2f, polygons %.2f)\n",
        t.total, t.input, t.mesh, t.normals, t.smoothing, t.segmentation, t.polygons);
  }
  return segmentation.segments.empty() ? 1 : 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "error: %s\n", e.what());
  return 2;
}
