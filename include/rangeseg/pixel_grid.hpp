// The pixel grid of an unorganized cloud that is a depth camera's image without its invalid
// pixels (e.g. after pcl::removeNaNFromPointCloud, or a PCD saved as "valid points only"),
// in any order: the grid stages then apply to it again.
#pragma once

#include <cstdint>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/unorganized.hpp"

namespace rangeseg {

/// Where the points of an unorganized cloud lie on a pinhole camera's pixel grid. A pixel
/// (u, v) of the grid holds the point with x / z = (u - cx) / fx and y / z = (v - cy) / fy; the
/// grid is the bounding box of the points' pixels, so (cx, cy) is in its coordinates.
struct PixelGrid {
  int width = 0, height = 0;  ///< size of the grid [pixels]; 0 when none was found
  double fx = 0, fy = 0;      ///< focal lengths [pixels]
  double cx = 0, cy = 0;      ///< principal point [pixels], grid coordinates
  /// Per point of the cloud (index u + width_of_cloud * v): its pixel v * width + u in the
  /// grid, or -1 for an invalid point (NaN or infinite coordinates).
  std::vector<std::int32_t> pixel;

  bool found() const { return width > 0; }
  /// Not found; keeps the buffer of `pixel`.
  void clear() {
    width = height = 0;
    fx = fy = cx = cy = 0;
    pixel.clear();
  }
};

/// Finds the pixel grid of a cloud whose valid points are the pixels of one pinhole camera in
/// its own frame (z forward): every x / z lies within 0.05 pixel of a lattice of spacing 1 / fx,
/// every y / z of one of spacing 1 / fy (a depth camera's points computed from its pixels are
/// exact to float rounding). Returns false, with `grid` emptied, when they do not (a lidar
/// scan, a stereo camera's sub-pixel points, a transformed, merged or voxel-filtered cloud), when
/// two points fall on one pixel, when there are fewer than 16 valid points or a point has z <= 0,
/// when the grid would exceed 16384 pixels a side or 16 pixels per point, or when the points
/// have fewer than 3 of their 4 pixel neighbours on average (a randomly thinned image, whose mesh
/// would have few edges; its k-nearest-neighbour rings serve it better). Lattice spacings of
/// 2e-5 or more (fx, fy up to 50000 pixels) are found.
bool find_pixel_grid(const OrganizedCloud& cloud, PixelGrid& grid);
/// The same with scratch buffers kept from call to call (no allocation once they fit).
bool find_pixel_grid(const OrganizedCloud& cloud, PixelGrid& grid, RingBuffers& buffers);

/// The points of `cloud` on the grid `grid` found for it: `out` is grid.width x grid.height, NaN
/// where no point lies, with the optional planes `cloud` has. Keeps its buffers when they fit.
/// Throws std::invalid_argument if `grid` was not found for a cloud of this size.
void scatter_to_grid(const OrganizedCloud& cloud, const PixelGrid& grid, OrganizedCloud& out);

}  // namespace rangeseg
