// Test helper: a cloud with its mesh, normals and labels, seen as the segmentation's flat frame,
// for the tests that call the segmentation's internals (src/segmentation/internal.hpp).
#pragma once

#include <cstdint>
#include <utility>

#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/segmentation.hpp"
#include "segmentation/internal.hpp"

namespace rangeseg::test {

/// A cloud with its mesh, normals, an empty label image and the segmentation's flat view of them.
struct FrameOf {
  explicit FrameOf(OrganizedCloud c)
      : cloud(std::move(c)), mesh(build_mesh(cloud)), normals(compute_normals(cloud, mesh)) {
    out.labels.resize(cloud.width(), cloud.height(), 0);
    f = seg::make_frame(cloud, mesh, normals, out.labels);
  }
  std::int32_t at(int u, int v) const { return static_cast<std::int32_t>(v * f.stride + u); }

  OrganizedCloud cloud;
  Mesh mesh;
  NormalMap normals;
  Segmentation out;
  seg::Frame f;
};

}  // namespace rangeseg::test
