// Stage 1: the implicit mesh as per-pixel bit masks.
//
// One sweep over the lattice rows; per row three passes over small row buffers, each on whole
// vectors (detail/simd.hpp; compiled for SSE2 and AVX2, picked at run time):
//  1. per-pixel quantities of the row that enters the window (range, eps_d^2, noise variance),
//     computed once per pixel;
//  2. edge bits: the validity (paper, eq. 1, plus the noise gate) of the edges a-b, a-d, a-c,
//     b-c of every cell, each geometric edge tested exactly once;
//  3. faces per cell from the edge bits of two rows, and each vertex's 1-ring as the union of
//     what its <= 4 cells contribute, written to the output rows in one go.
// The arithmetic is the same sequence of IEEE operations in every instruction set, and
// contraction into fused multiply-adds is off in this file, so the mesh does not depend on the
// CPU or the build flags.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

#include "rangeseg/mesh.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "detail/bad_setting.hpp"
#include "detail/row_bands.hpp"
#include "detail/simd.hpp"

namespace rangeseg {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

// Edge bits of pass 2, stored at the cell's top-left vertex a = (u, v).
constexpr std::uint8_t kEdgeAB = 1;        // a -> b (right)
constexpr std::uint8_t kEdgeAD = 2;        // a -> d (down-right)
constexpr std::uint8_t kEdgeAC = 4;        // a -> c (down)
constexpr std::uint8_t kEdgeBC = 8;        // b -> c (down-left, stored at a)
constexpr std::uint8_t kAdNotLonger = 16;  // |a-d| <= |b-c|

// Edge bits of Mesh::edges (kNeighbourDu/Dv order).
constexpr std::uint8_t kR = 1, kDR = 2, kD = 4, kDL = 8, kL = 16, kUL = 32, kU = 64, kUR = 128;

// Per-pixel quantities of one lattice row, relative to the viewpoint (structure of arrays).
struct PixelRow {
  float* x;
  float* y;
  float* z;
  float* range;      // |p - viewpoint|
  float* cos2_r2;    // cos(eps_theta)^2 |p - viewpoint|^2
  float* max_len2;   // eps_d(range)^2
  float* noise_var;  // (jump_sigmas sigma(range))^2
};
constexpr int kFloatsPerPixel = 7;

struct EdgeParams {
  float vx, vy, vz;   // viewpoint
  float cos2;         // cos(eps_theta)^2
  float a, bs, c;     // eps_d(r) = a + bs r + c r^2 (bs = b * stride)
  float na, nb, nz0;  // sigma(r) = na + nb (r - nz0)^2
  float k2;           // jump_sigmas^2
};

#define RANGESEG_SIMD_KERNEL_FILE "detail/mesh_simd_kernels.hpp"
#include "detail/simd_instances.hpp"
#undef RANGESEG_SIMD_KERNEL_FILE

// The kernels of one instruction set.
struct Kernels {
  int lanes;  // floats per vector; a byte vector covers 4 * lanes cells
  void (*quantities)(const float*, const float*, const float*, int, const EdgeParams&,
                     const PixelRow&);
  void (*edges)(const PixelRow&, const PixelRow*, int, std::uint8_t*);
  std::array<void (*)(const std::uint8_t*, const std::uint8_t*, const std::uint8_t*, int,
                      std::uint8_t*, std::uint8_t*, std::uint8_t*),
             4>
      faces;  // per MeshType
};

#define RANGESEG_MESH_KERNELS(ns)                                                             \
  Kernels {                                                                                   \
    ns::kLanes, &ns::pixel_quantities, &ns::edge_bits, {                                      \
      &ns::faces_and_rings<MeshType::quad>, &ns::faces_and_rings<MeshType::left_cut>,         \
          &ns::faces_and_rings<MeshType::right_cut>, &ns::faces_and_rings<MeshType::adaptive> \
    }                                                                                         \
  }

const Kernels& kernels() { RANGESEG_SIMD_PICK(Kernels, RANGESEG_MESH_KERNELS); }
#undef RANGESEG_MESH_KERNELS

}  // namespace

void validate(const MeshSettings& s) {
  const auto fail = [](std::string_view field, const auto& value, const char* condition) {
    detail::throw_bad_setting("MeshSettings", field, value, condition);
  };
  const int t = static_cast<int>(s.type);
  if (t < 0 || t > 3) fail("type", t, "a MeshType (quad, left_cut, right_cut or adaptive)");
  if (!(s.eps_theta >= 0.0f && s.eps_theta <= 1.5707964f)) {
    fail("eps_theta", s.eps_theta, "in [0, pi/2] rad");
  }
  const std::array<std::pair<const char*, float>, 4> bounds{{{"max_edge_a", s.max_edge_a},
                                                             {"max_edge_b", s.max_edge_b},
                                                             {"max_edge_c", s.max_edge_c},
                                                             {"jump_sigmas", s.jump_sigmas}}};
  for (const auto& [field, value] : bounds) {
    if (!(value >= 0.0f) || !std::isfinite(value)) fail(field, value, "finite and >= 0");
  }
  for (std::size_t k = 0; k < 3; ++k) {
    if (!std::isfinite(s.viewpoint[k])) {
      fail("viewpoint[" + std::to_string(k) + "]", s.viewpoint[k], "finite [m]");
    }
  }
  detail::require_noise(s.noise, "MeshSettings");
  if (s.pixel_stride < 1) fail("pixel_stride", s.pixel_stride, ">= 1");
}

namespace {

void validate(const OrganizedCloud& cloud, const MeshSettings& s) {
  require_organized(cloud, "build_mesh");  // also the planes' sizes
  if (static_cast<long long>(cloud.width()) * cloud.height() >
      std::numeric_limits<std::int32_t>::max()) {
    throw std::invalid_argument(
        "build_mesh: cloud too large for int32 pixel indices: " + std::to_string(cloud.width()) +
        "x" + std::to_string(cloud.height()));
  }
  rangeseg::validate(s);
}

}  // namespace

namespace detail {

void prepare_mesh(const OrganizedCloud& cloud, const MeshSettings& settings, Mesh& mesh) {
  validate(cloud, settings);
  const int width = cloud.width(), height = cloud.height(), s = settings.pixel_stride;
  mesh.type = settings.type;
  mesh.pixel_stride = s;
  // At stride 1 every element of both planes is written by the sweep, so a plane of the right
  // size is not refilled; otherwise Plane::resize keeps the allocation and zeroes the
  // off-lattice pixels.
  if (s != 1 || mesh.faces.width() != width || mesh.faces.height() != height) {
    mesh.faces.resize(width, height, 0);
  }
  if (s != 1 || mesh.edges.width() != width || mesh.edges.height() != height) {
    mesh.edges.resize(width, height, 0);
  }
}

void build_mesh_rows(const OrganizedCloud& cloud, const MeshSettings& settings, Mesh& mesh,
                     int row_begin, int row_end, RowBuffers& buffers) {
  CacheLineVector<float>& float_buffer = buffers.floats;
  CacheLineVector<std::uint8_t>& byte_buffer = buffers.bytes;
  const int width = cloud.width(), height = cloud.height(), s = settings.pixel_stride;
  assert(mesh.faces.width() == width && mesh.faces.height() == height && s >= 1);
  // Lattice size and the band's lattice rows [j_begin, j_end).
  const int n = (width - 1) / s + 1, m = (height - 1) / s + 1;
  row_begin = std::max(row_begin, 0);
  row_end = std::min(row_end, height);
  if (row_begin >= row_end) return;
  const int j_begin = (row_begin + s - 1) / s, j_end = std::min(m, (row_end + s - 1) / s);
  if (j_begin >= j_end) return;

  const float cos_theta = std::cos(settings.eps_theta);
  const SensorNoise& noise = settings.noise;
  const EdgeParams params{settings.viewpoint[0],
                          settings.viewpoint[1],
                          settings.viewpoint[2],
                          cos_theta * cos_theta,
                          settings.max_edge_a,
                          settings.max_edge_b * static_cast<float>(s),
                          settings.max_edge_c,
                          static_cast<float>(noise.a),
                          static_cast<float>(noise.b),
                          static_cast<float>(noise.z0),
                          settings.jump_sigmas * settings.jump_sigmas};

  const Kernels& k = kernels();
  const int cells_per_block = 4 * k.lanes;
  const int blocks = (n + cells_per_block - 1) / cells_per_block;
  // Float rows are read up to index blocks * cells_per_block (the right neighbour of the last
  // cell of the last block), byte rows from -1 to that index.
  const std::ptrdiff_t float_len = blocks * cells_per_block + k.lanes;
  constexpr int kBytePad = 64;
  const std::ptrdiff_t byte_len = blocks * cells_per_block + 2 * kBytePad;

  float_buffer.resize(static_cast<std::size_t>(3 * kFloatsPerPixel + 3) * float_len);
  byte_buffer.assign(static_cast<std::size_t>(8) * byte_len, 0);
  std::array<PixelRow, 3> rows{};
  for (int r = 0; r < 3; ++r) {
    float* base = float_buffer.data() + static_cast<std::size_t>(r * kFloatsPerPixel) * float_len;
    rows[r] = {base,
               base + float_len,
               base + 2 * float_len,
               base + 3 * float_len,
               base + 4 * float_len,
               base + 5 * float_len,
               base + 6 * float_len};
  }
  // Gathered input row at stride > 1; all NaN first, to fill the padding of the pixel rows.
  float* gathered = float_buffer.data() + static_cast<std::size_t>(3 * kFloatsPerPixel) * float_len;
  float* gx = gathered;
  float* gy = gathered + float_len;
  float* gz = gathered + 2 * float_len;
  std::fill(gathered, gathered + 3 * static_cast<std::size_t>(float_len), kNaN);
  for (const PixelRow& row : rows) {
    k.quantities(gx, gy, gz, static_cast<int>(float_len), params, row);
  }

  const auto byte_row = [&](int r) { return byte_buffer.data() + r * byte_len + kBytePad; };
  std::uint8_t* cand = byte_row(0);
  std::uint8_t* cand_below = byte_row(1);
  std::uint8_t* from_above = byte_row(2);
  std::uint8_t* to_below = byte_row(3);
  std::uint8_t* faces = byte_row(4);
  std::uint8_t* edges = byte_row(5);
  const std::uint8_t* no_cells = byte_row(6);  // edge bits below the last row: none

  const auto load = [&](int j, const PixelRow& out) {
    const int v = j * s;
    if (s == 1) {
      k.quantities(cloud.x.row(v), cloud.y.row(v), cloud.z.row(v), n, params, out);
      return;
    }
    const float* xs = cloud.x.row(v);
    const float* ys = cloud.y.row(v);
    const float* zs = cloud.z.row(v);
    for (std::ptrdiff_t i = 0; i < n; ++i) gx[i] = xs[i * s], gy[i] = ys[i * s], gz[i] = zs[i * s];
    k.quantities(gx, gy, gz, n, params, out);
  };
  const auto faces_and_rings = k.faces[static_cast<int>(settings.type)];

  // A band starting below row 0 first runs the lattice row above it, for what its cells
  // contribute to the band's first row (`to_below`); that row's own output is discarded.
  const int j_start = std::max(j_begin - 1, 0);
  PixelRow* top = &rows[0];
  PixelRow* mid = &rows[1];
  PixelRow* low = &rows[2];
  load(j_start, *top);
  if (j_start + 1 < m) load(j_start + 1, *mid);
  k.edges(*top, j_start + 1 < m ? mid : nullptr, blocks, cand);
  for (int j = j_start; j < j_end; ++j) {
    // Edge bits of row j + 1 need pixel row j + 2.
    const std::uint8_t* next = no_cells;
    if (j + 1 < m) {
      if (j + 2 < m) load(j + 2, *low);
      k.edges(*mid, j + 2 < m ? low : nullptr, blocks, cand_below);
      next = cand_below;
    }
    faces_and_rings(cand, next, from_above, blocks, faces, edges, to_below);
    if (j >= j_begin) {
      std::uint8_t* face_row = mesh.faces.row(j * s);
      std::uint8_t* edge_row = mesh.edges.row(j * s);
      if (s == 1) {
        std::memcpy(face_row, faces, static_cast<std::size_t>(n));
        std::memcpy(edge_row, edges, static_cast<std::size_t>(n));
      } else {
        for (std::ptrdiff_t i = 0; i < n; ++i) {
          face_row[i * s] = faces[i], edge_row[i * s] = edges[i];
        }
      }
    }
    std::swap(cand, cand_below);
    std::swap(from_above, to_below);
    PixelRow* const old_top = top;
    top = mid;
    mid = low;
    low = old_top;
  }
}

}  // namespace detail

void build_mesh(const OrganizedCloud& cloud, const MeshSettings& settings, Mesh& mesh) {
  detail::prepare_mesh(cloud, settings, mesh);
  detail::RowBuffers rows;
  detail::build_mesh_rows(cloud, settings, mesh, 0, cloud.height(), rows);
}

std::size_t count_faces(const Mesh& mesh) {
  std::size_t count = 0;
  const int width = mesh.faces.width();
  for (int v = 0; v < mesh.faces.height(); ++v) {
    const std::uint8_t* f = mesh.faces.row(v);
    std::size_t row = 0;
    for (int u = 0; u < width; ++u) row += std::popcount(static_cast<unsigned>(f[u] & 7u));
    count += row;
  }
  return count;
}

const char* to_string(MeshType type) {
  switch (type) {
    case MeshType::adaptive:
      return "adaptive";
    case MeshType::quad:
      return "quad";
    case MeshType::left_cut:
      return "left";
    case MeshType::right_cut:
      return "right";
  }
  return "unknown";
}

MeshType mesh_type_from_string(std::string_view name) {
  if (name == "adaptive") return MeshType::adaptive;
  if (name == "quad") return MeshType::quad;
  if (name == "left") return MeshType::left_cut;
  if (name == "right") return MeshType::right_cut;
  throw std::invalid_argument("unknown mesh type '" + std::string(name) +
                              "' (expected adaptive, quad, left or right)");
}

}  // namespace rangeseg
