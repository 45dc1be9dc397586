// Stage 2: vertex normals (paper, eq. 2) and curvature from the implicit mesh.
//
// One sweep over the lattice rows with small padded row buffers, two passes per row on whole
// vectors (detail/simd.hpp; compiled for SSE2 and AVX2, picked at run time):
//  1. cells and normals: the unnormalised face normals of each cell (cross products, twice the
//     face area times the unit normal), computed once and added to the cell's corners (the
//     left/right neighbours through a one-lane shift in registers), summed per vertex with the
//     row above's share, normalised and oriented towards the viewpoint;
//  2. curvature from the 1-ring given by Mesh::edges and the normals of pass 1.
// Both write straight to the output planes.
// The arithmetic is the same sequence of IEEE operations in every instruction set, and
// contraction into fused multiply-adds is off in this file, so the results do not depend on the
// CPU or the build flags.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

#include "rangeseg/normals.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "detail/number_text.hpp"
#include "detail/row_bands.hpp"
#include "detail/simd.hpp"

namespace rangeseg {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// One lattice row of points (x, y, z planes), padded: readable from index -1 to the end of
// the last vector + 1.
struct PointRow {
  const float* x;
  const float* y;
  const float* z;
};

// Three float row buffers (x, y, z).
struct Vec3Row {
  float* x;
  float* y;
  float* z;
};

#define RANGESEG_SIMD_KERNEL_FILE "detail/normals_simd_kernels.hpp"
#include "detail/simd_instances.hpp"
#undef RANGESEG_SIMD_KERNEL_FILE

// The kernels of one instruction set.
struct Kernels {
  int lanes;
  std::array<void (*)(PointRow, PointRow, const std::uint8_t*, const Vec3Row&, const Vec3Row&,
                      const float*, int, float*, float*, float*),
             2>
      normals;  // [quad]
  void (*curvature)(PointRow, PointRow, PointRow, const std::uint8_t*, const float*, const float*,
                    const float*, int, float*);
};

#define RANGESEG_NORMAL_KERNELS(ns)                                                           \
  Kernels {                                                                                   \
    ns::kLanes, {&ns::cell_normal_row<false>, &ns::cell_normal_row<true>}, &ns::curvature_row \
  }

const Kernels& kernels() { RANGESEG_SIMD_PICK(Kernels, RANGESEG_NORMAL_KERNELS); }
#undef RANGESEG_NORMAL_KERNELS

}  // namespace

namespace detail {

void prepare_normals(const OrganizedCloud& cloud, const Mesh& mesh, const NormalSettings& settings,
                     NormalMap& out) {
  require_organized(cloud, "compute_normals");
  const int width = cloud.width(), height = cloud.height(), s = mesh.pixel_stride;
  if (mesh.width() != width || mesh.height() != height || mesh.faces.width() != width ||
      mesh.faces.height() != height || s < 1) {
    throw std::invalid_argument("compute_normals: mesh " + std::to_string(mesh.width()) + "x" +
                                std::to_string(mesh.height()) + " (stride " + std::to_string(s) +
                                ") does not fit the cloud " + std::to_string(width) + "x" +
                                std::to_string(height));
  }
  validate(settings);
  // At stride 1 the sweep writes every pixel, so planes of the right size are not refilled;
  // otherwise the off-lattice pixels are NaN (no face).
  for (FloatPlane* plane : {&out.nx, &out.ny, &out.nz, &out.curvature}) {
    if (s != 1 || plane->width() != width || plane->height() != height) {
      plane->resize(width, height, kNaN);
    }
  }
}

void compute_normals_rows(const OrganizedCloud& cloud, const Mesh& mesh,
                          const NormalSettings& settings, NormalMap& out, int row_begin,
                          int row_end, RowBuffers& buffers) {
  CacheLineVector<float>& float_buffer = buffers.floats;
  CacheLineVector<std::uint8_t>& byte_buffer = buffers.bytes;
  const int width = cloud.width(), height = cloud.height(), s = mesh.pixel_stride;
  assert(out.nz.width() == width && out.nz.height() == height && s >= 1);
  const int n = (width - 1) / s + 1, m = (height - 1) / s + 1;
  row_begin = std::max(row_begin, 0);
  row_end = std::min(row_end, height);
  if (row_begin >= row_end) return;
  const int j_begin = (row_begin + s - 1) / s, j_end = std::min(m, (row_end + s - 1) / s);
  if (j_begin >= j_end) return;

  const Kernels& k = kernels();
  const int lanes = k.lanes;
  const int blocks = (n + lanes - 1) / lanes;
  // Every float row: `lanes` elements of padding on the left (index -1 is read), the vectors,
  // and one more vector on the right (index blocks * lanes is read).
  const std::ptrdiff_t row_len = static_cast<std::ptrdiff_t>(blocks + 2) * lanes;
  constexpr int kPointRows = 3 * 3;  // ring of 3 lattice rows of x, y, z
  constexpr int kSumRows = 2 * 3;    // c + d sums of the cell rows above and below
  constexpr int kOutRows = 4;        // compact nx, ny, nz, curvature at stride > 1
  constexpr int kFloatRows = kPointRows + kSumRows + kOutRows;

  float_buffer.resize(static_cast<std::size_t>(kFloatRows) * row_len);
  std::fill(float_buffer.begin(), float_buffer.begin() + kPointRows * row_len, kNaN);
  std::fill(float_buffer.begin() + kPointRows * row_len, float_buffer.end(), 0.0f);
  byte_buffer.assign(static_cast<std::size_t>(3) * row_len, 0);
  const auto row = [&](int r) { return float_buffer.data() + r * row_len + lanes; };
  const auto vec3 = [&](int r) { return Vec3Row{row(r), row(r + 1), row(r + 2)}; };
  std::uint8_t* faces = byte_buffer.data();
  std::uint8_t* edges = byte_buffer.data() + row_len;
  const std::uint8_t* no_faces = byte_buffer.data() + 2 * row_len;

  // Lattice row j of the cloud lives in point slot j % 3. At stride 1 the kernels read the
  // interior rows in place: their reads from index -1 to blocks * lanes stay inside the planes
  // (the neighbouring rows' ends), and whatever they read outside [0, n) is masked by the face
  // and edge bits, which are 0 there.
  std::array<Vec3Row, 3> point_slots{vec3(0), vec3(3), vec3(6)};
  const std::ptrdiff_t plane_stride = cloud.x.stride();
  const bool in_place = s == 1 && cloud.y.stride() == plane_stride &&
                        cloud.z.stride() == plane_stride && blocks * lanes + 1 <= 2 * plane_stride;
  const auto interior = [&](int j) { return in_place && j >= 1 && j + 1 < m; };
  const auto point_row = [&](int j) {
    if (interior(j)) return PointRow{cloud.x.row(j), cloud.y.row(j), cloud.z.row(j)};
    const Vec3Row& r = point_slots[j % 3];
    return PointRow{r.x, r.y, r.z};
  };
  const auto load_points = [&](int j) {
    if (interior(j)) return;
    const Vec3Row& dst = point_slots[j % 3];
    const float* xs = cloud.x.row(j * s);
    const float* ys = cloud.y.row(j * s);
    const float* zs = cloud.z.row(j * s);
    if (s == 1) {
      std::memcpy(dst.x, xs, sizeof(float) * n);
      std::memcpy(dst.y, ys, sizeof(float) * n);
      std::memcpy(dst.z, zs, sizeof(float) * n);
    } else {
      for (std::ptrdiff_t i = 0; i < n; ++i) {
        dst.x[i] = xs[i * s], dst.y[i] = ys[i * s], dst.z[i] = zs[i * s];
      }
    }
  };
  const auto load_bytes = [&](const BytePlane& plane, int j, std::uint8_t* dst) {
    const std::uint8_t* src = plane.row(j * s);
    if (s == 1) {
      std::memcpy(dst, src, static_cast<std::size_t>(n));
    } else {
      for (std::ptrdiff_t i = 0; i < n; ++i) dst[i] = src[i * s];
    }
  };

  // c + d sums of the cell row above the current lattice row (zero above row 0) and of the one
  // below it.
  Vec3Row sums_above = vec3(9), sums_below = vec3(12);
  float* compact = row(15);
  const auto cells_and_normals = k.normals[mesh.type == MeshType::quad ? 1 : 0];

  // A band starting below row 0 first runs the lattice row above it, for the c + d sums of its
  // cells; that row's normals are discarded.
  const int j_start = std::max(j_begin - 1, 0);
  load_points(j_start);
  for (int j = j_start; j < j_end; ++j) {
    const bool has_cells = j + 1 < m;
    if (has_cells) {
      load_points(j + 1);
      load_bytes(mesh.faces, j, faces);
    }
    const int v = j * s;
    const bool direct = s == 1 && j >= j_begin;  // else through compact rows
    float* nx = direct ? out.nx.row(v) : compact;
    float* ny = direct ? out.ny.row(v) : compact + row_len;
    float* nz = direct ? out.nz.row(v) : compact + 2 * row_len;
    // Without a cell row below, the cells have no faces; their corners are never read as points.
    cells_and_normals(point_row(j), point_row(has_cells ? j + 1 : j), has_cells ? faces : no_faces,
                      sums_above, sums_below, settings.viewpoint.data(), n, nx, ny, nz);
    if (j >= j_begin) {
      // Neighbours outside the lattice have no edge bits; their rows are never read as points.
      const PointRow up = point_row(j > 0 ? j - 1 : j);
      const PointRow down = point_row(has_cells ? j + 1 : j);
      load_bytes(mesh.edges, j, edges);
      float* curvature = direct ? out.curvature.row(v) : compact + 3 * row_len;
      k.curvature(up, point_row(j), down, edges, nx, ny, nz, n, curvature);
      if (!direct) {
        float* ox = out.nx.row(v);
        float* oy = out.ny.row(v);
        float* oz = out.nz.row(v);
        float* oc = out.curvature.row(v);
        for (std::ptrdiff_t i = 0; i < n; ++i) {
          ox[i * s] = nx[i], oy[i * s] = ny[i], oz[i * s] = nz[i], oc[i * s] = curvature[i];
        }
      }
    }
    std::swap(sums_above, sums_below);
  }
}

}  // namespace detail

void validate(const NormalSettings& settings) {
  for (const float p : settings.viewpoint) {
    if (!std::isfinite(p)) {
      throw std::invalid_argument("NormalSettings::viewpoint must be finite, got " +
                                  rangeseg::detail::number_text(p));
    }
  }
}

void compute_normals(const OrganizedCloud& cloud, const Mesh& mesh, const NormalSettings& settings,
                     NormalMap& out) {
  detail::prepare_normals(cloud, mesh, settings, out);
  detail::RowBuffers rows;
  detail::compute_normals_rows(cloud, mesh, settings, out, 0, cloud.height(), rows);
}

}  // namespace rangeseg
