// Stages 1 and 2 on horizontal bands of rows, for splitting one frame over threads.
//
// Usage (e.g. in the pipeline, with T threads):
//   detail::prepare_mesh(cloud, mesh_settings, mesh);              // once, on one thread
//   parallel for each band [v0, v1) of [0, height):
//     detail::build_mesh_rows(cloud, mesh_settings, mesh, v0, v1);
//   -- barrier: a band's normals read mesh rows up to one lattice row beyond the band --
//   detail::prepare_normals(cloud, mesh, normal_settings, normals);  // once, on one thread
//   parallel for each band [v0, v1):
//     detail::compute_normals_rows(cloud, mesh, normal_settings, normals, v0, v1);
// Bands that are disjoint and cover [0, height) give results bit-identical to build_mesh /
// compute_normals (those are exactly prepare + one band [0, height)). Any band boundaries work:
// a band computes the lattice rows v (v % pixel_stride == 0) with v0 <= v < v1 and writes only
// those rows of the output planes, so concurrent bands never write the same memory. Each band
// recomputes the one lattice row of cells above it that it needs (a band costs one extra row).
// Each call takes row buffers, which it sizes to the frame's width and reuses call after call:
// one pair per thread that runs bands at once (mesh and normals may share it).
#pragma once

#include "rangeseg/cloud.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"

namespace rangeseg::detail {

/// Validates the arguments as build_mesh does (throwing the same exceptions) and sizes
/// `mesh.faces` and `mesh.edges` to the cloud; off-lattice pixels are zeroed (stride > 1).
void prepare_mesh(const OrganizedCloud& cloud, const MeshSettings& settings, Mesh& mesh);

/// Lattice rows v with row_begin <= v < row_end of `mesh` (prepared with the same cloud and
/// settings). Reads cloud rows [row_begin - stride, row_end + 2 stride). Clamps the range to
/// [0, height); an empty range does nothing.
void build_mesh_rows(const OrganizedCloud& cloud, const MeshSettings& settings, Mesh& mesh,
                     int row_begin, int row_end, RowBuffers& rows);

/// Validates the arguments as compute_normals does and sizes the four planes of `out`
/// (off-lattice pixels NaN when stride > 1).
void prepare_normals(const OrganizedCloud& cloud, const Mesh& mesh, const NormalSettings& settings,
                     NormalMap& out);

/// Lattice rows v with row_begin <= v < row_end of `out` (prepared with the same arguments).
/// Reads mesh and cloud rows [row_begin - stride, row_end + stride), so all mesh rows a band
/// reads must be complete before it starts. Clamps the range to [0, height).
void compute_normals_rows(const OrganizedCloud& cloud, const Mesh& mesh,
                          const NormalSettings& settings, NormalMap& out, int row_begin,
                          int row_end, RowBuffers& rows);

}  // namespace rangeseg::detail
