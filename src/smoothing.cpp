// Stage 3: bilateral filter of points and normals over the mesh 1-ring (paper, eqs. 3 and 4).
// The pass itself is in detail/smoothing_simd_kernels.hpp, compiled per instruction set and
// picked at run time. The compiler's contraction into fused multiply-adds is off in this file:
// the kernels fuse where they choose (simd mul_add), so one instruction set gives the same bits
// whatever the build flags or row bands; different instruction sets agree to float rounding.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

#include "rangeseg/smoothing.hpp"

#include "detail/gather_points.hpp"
#include "detail/number_text.hpp"
#include "detail/row_bands.hpp"
#include "detail/simd.hpp"
#include "detail/smoothing_rows.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace rangeseg {

namespace {

// The row loops use distinct buffers (inputs and outputs never alias, checked in run()); tell
// the compiler so instead of letting it version every loop for aliasing.
#if defined(__clang__)
#define RANGESEG_VECTORIZE _Pragma("clang loop vectorize(assume_safety)")
#elif defined(__GNUC__)
#define RANGESEG_VECTORIZE _Pragma("GCC ivdep")
#else
#define RANGESEG_VECTORIZE
#endif

#if defined(__GNUC__) || defined(__clang__)
#define RANGESEG_INLINE inline __attribute__((always_inline))
#else
#define RANGESEG_INLINE inline
#endif

/// Weights exp(-a) with a >= kMaxExponent are treated as 0 (e^-30 ~ 1e-13, far below the
/// centre's weight 1).
constexpr float kMaxExponent = 30.0f;

/// c ? a : b on the bits. A plain ?: on floats lets the compiler sink the arithmetic that
/// computes `a` into a branch, which (floating-point ops may trap) it then cannot vectorise.
RANGESEG_INLINE float select(bool c, float a, float b) {
  const std::uint32_t mask = 0u - static_cast<std::uint32_t>(c);
  return std::bit_cast<float>((std::bit_cast<std::uint32_t>(a) & mask) |
                              (std::bit_cast<std::uint32_t>(b) & ~mask));
}

template <class T>
void ensure_size(Plane<T>& plane, int width, int height) {
  if (plane.width() != width || plane.height() != height) plane.resize(width, height);
}

void copy_plane(const FloatPlane& from, FloatPlane& to) {
  ensure_size(to, from.width(), from.height());
  for (int v = 0; v < from.height(); ++v) {
    std::copy(from.row(v), from.row(v) + from.width(), to.row(v));
  }
}

/// Per-frame constants of one pass.
struct PassParams {
  int stride = 1;
  float kd2 = 0;      // distance_scale^2
  float spacing = 0;  // stride * pixel_angle [rad]
  float noise_a = 0, noise_b = 0, noise_z0 = 0;
  float inv_normal_scale = 0;
  float inv_intensity_scale = 0;  // 1 / (c_I s_I)
  std::array<float, 3> origin{};  // added to the output points (inputs are origin-relative)
  const FloatPlane* intensity = nullptr;
  /// When set, the pass also copies these rows of the curvature plane (passed through
  /// unchanged), while the rows are in cache.
  const FloatPlane* curvature_in = nullptr;
  FloatPlane* curvature_out = nullptr;
};

/// Lattice row of the pass inputs, readable from index 0 to blocks * lanes inclusive (values
/// outside [0, n) are masked by the edge bits, which are 0 there).
struct InRow {
  const float *x, *y, *z, *nx, *ny, *nz, *in;
};
/// Per-pixel sums of one lattice row: weight, along-ray term t (or the three components of
/// w (p_j - p_i)), and w (n_j - n_i), interleaved per vector block (block b holds the seven
/// quantities of its lanes one vector after the other from base + 7 b lanes): one pointer per
/// row keeps the kernels' row pointers in registers.
struct SumRow {
  float* base;
};

/// The row buffers of a pass inside the scratch vectors: every float row has `lanes` elements
/// of padding on each side of `len` (whole vectors) columns.
struct PassLayout {
  static constexpr std::size_t kInputRows = 7;  // x, y, z, nx, ny, nz, intensity
  static constexpr std::size_t kSumRows = 7;
  float* base = nullptr;
  std::uint8_t* bytes = nullptr;
  std::size_t row_len = 0;
  int pad = 0;

  float* row(std::size_t r) const { return base + r * row_len + pad; }
  float* input(int slot, int a) const {
    return row(static_cast<std::size_t>(slot) * kInputRows + static_cast<std::size_t>(a));
  }
  float* hd(int slot) const { return row(2 * kInputRows + static_cast<std::size_t>(slot)); }
  float* hn(int slot) const { return row(2 * kInputRows + 2 + static_cast<std::size_t>(slot)); }
  SumRow sums(int slot) const {
    return {base + (2 * kInputRows + 4 + static_cast<std::size_t>(slot) * kSumRows) * row_len};
  }
  void clear_sums(int slot) const {
    std::fill(sums(slot).base, sums(slot).base + kSumRows * row_len, 0.0f);
  }
  /// Six rows for the outputs at stride > 1.
  float* compact() const { return row(2 * kInputRows + 4 + 2 * kSumRows); }
  static std::size_t rows() { return 2 * kInputRows + 4 + 2 * kSumRows + 6; }

  /// Edge bytes of lattice row j (pixel row j s), zero-padded.
  const std::uint8_t* edge_bytes(const Mesh& mesh, int j, int s, int n) const {
    const std::uint8_t* src = mesh.edges.row(j * s);
    std::uint8_t* dst = bytes + pad;
    if (s == 1) {
      std::memcpy(dst, src, static_cast<std::size_t>(n));
    } else {
      for (std::ptrdiff_t i = 0; i < n; ++i) dst[i] = src[i * s];
    }
    return dst;
  }
};

/// The scratch of a pass: float rows and one byte row, laid out for a row length and vector
/// width, reused while they stay the same.
struct PassScratch {
  detail::CacheLineVector<float>& floats;
  detail::CacheLineVector<std::uint8_t>& bytes;
  std::size_t& layout;  // row length the buffers were laid out for

  PassLayout lay_out(int len, int lanes) {
    PassLayout lay;
    lay.pad = lanes;
    lay.row_len = static_cast<std::size_t>(len) + 2 * static_cast<std::size_t>(lanes);
    const std::size_t key = lay.row_len * 64 + static_cast<std::size_t>(lanes);
    if (layout != key || floats.size() != PassLayout::rows() * lay.row_len) {
      floats.assign(PassLayout::rows() * lay.row_len, 0.0f);
      bytes.assign(lay.row_len, 0);
      layout = key;
    }
    lay.base = floats.data();
    lay.bytes = bytes.data();
    return lay;
  }
};

/// The row stride shared by every input plane of a pass, or 0 if they differ.
inline std::ptrdiff_t common_stride(const OrganizedCloud& src, const NormalMap& nm,
                                    const PassParams& prm) {
  const std::ptrdiff_t stride = src.x.stride();
  for (const FloatPlane* p : {&src.y, &src.z, &nm.nx, &nm.ny, &nm.nz, prm.intensity}) {
    if (p != nullptr && p->stride() != stride) return 0;
  }
  return stride;
}

/// Pixel row j of the input planes, read in place (stride 1).
inline InRow plane_row(const OrganizedCloud& src, const NormalMap& nm, const PassParams& prm,
                       int j) {
  return {src.x.row(j),
          src.y.row(j),
          src.z.row(j),
          nm.nx.row(j),
          nm.ny.row(j),
          nm.nz.row(j),
          prm.intensity != nullptr ? prm.intensity->row(j) : nullptr};
}

/// Lattice row j gathered into the slot's padded rows (unless `already` there).
inline InRow copy_lattice_row(const OrganizedCloud& src, const NormalMap& nm, const PassParams& prm,
                              const PassLayout& lay, int j, int s, int n, int slot, bool already) {
  const int v = j * s;
  const FloatPlane* planes[7] = {&src.x, &src.y, &src.z, &nm.nx, &nm.ny, &nm.nz, prm.intensity};
  float* rows[7];
  for (int a = 0; a < 7; ++a) {
    rows[a] = lay.input(slot, a);
    if (already || planes[a] == nullptr) continue;
    const float* from = planes[a]->row(v);
    if (s == 1) {
      std::copy(from, from + n, rows[a]);
    } else {
      for (std::ptrdiff_t i = 0; i < n; ++i) rows[a][i] = from[i * s];
    }
  }
  return {rows[0], rows[1], rows[2], rows[3], rows[4], rows[5], rows[6]};
}

/// Row v of the inputs into the outputs (the points plus the origin): pixels without a vertex
/// at stride > 1.
template <bool kFilterNormals>
void copy_row(const OrganizedCloud& src, const NormalMap& nm, const PassParams& prm, int v,
              OrganizedCloud& dst, NormalMap& dst_normals) {
  const int width = src.width();
  const float* xc = src.x.row(v);
  const float* yc = src.y.row(v);
  const float* zc = src.z.row(v);
  float* xo = dst.x.row(v);
  float* yo = dst.y.row(v);
  float* zo = dst.z.row(v);
  for (int u = 0; u < width; ++u) {
    xo[u] = xc[u] + prm.origin[0];
    yo[u] = yc[u] + prm.origin[1];
    zo[u] = zc[u] + prm.origin[2];
  }
  if constexpr (kFilterNormals) {
    std::copy(nm.nx.row(v), nm.nx.row(v) + width, dst_normals.nx.row(v));
    std::copy(nm.ny.row(v), nm.ny.row(v) + width, dst_normals.ny.row(v));
    std::copy(nm.nz.row(v), nm.nz.row(v) + width, dst_normals.nz.row(v));
  }
}

/// Row v of the pass-through curvature, if the pass copies it.
inline void copy_curvature_row(const PassParams& prm, int v) {
  if (prm.curvature_in == nullptr) return;
  const float* from = prm.curvature_in->row(v);
  std::copy(from, from + prm.curvature_in->width(), prm.curvature_out->row(v));
}

/// The compact outputs (six rows of `len`) of lattice row v into every s-th pixel.
template <bool kFilterNormals>
void scatter_row(const float* o, std::size_t len, int n, int s, int v, OrganizedCloud& dst,
                 NormalMap& dst_normals) {
  float* const rows[6] = {dst.x.row(v),          dst.y.row(v),          dst.z.row(v),
                          dst_normals.nx.row(v), dst_normals.ny.row(v), dst_normals.nz.row(v)};
  const int count = kFilterNormals ? 6 : 3;
  for (int a = 0; a < count; ++a) {
    const float* from = o + static_cast<std::size_t>(a) * len;
    for (std::ptrdiff_t i = 0; i < n; ++i) rows[a][i * s] = from[i];
  }
}

using PassFn = void (*)(const OrganizedCloud&, const NormalMap&, const Mesh&, const PassParams&,
                        PassScratch&, OrganizedCloud&, NormalMap&, int, int);

// The pass, once per instruction set (fused multiply-adds are off in this file, so every width
// computes the same).
#define RANGESEG_SIMD_KERNEL_FILE "detail/smoothing_simd_kernels.hpp"
#include "detail/simd_instances.hpp"
#undef RANGESEG_SIMD_KERNEL_FILE

template <int kFlags>
struct FlagPass {
  static constexpr bool d = (kFlags & 1) != 0, n = (kFlags & 2) != 0, i = (kFlags & 4) != 0,
                        r = (kFlags & 8) != 0, f = (kFlags & 16) != 0;
};
#define RANGESEG_PASS_TABLE(ns)                                                  \
  []<int... kFlags>(std::integer_sequence<int, kFlags...>) {                     \
    return std::array<PassFn, sizeof...(kFlags)>{                                \
        &ns::pass<FlagPass<kFlags>::d, FlagPass<kFlags>::n, FlagPass<kFlags>::i, \
                  FlagPass<kFlags>::r, FlagPass<kFlags>::f>...};                 \
  }                                                                              \
  (std::make_integer_sequence<int, 32>{})

using PassTable = std::array<PassFn, 32>;
const PassTable& pass_table() { RANGESEG_SIMD_PICK(PassTable, RANGESEG_PASS_TABLE); }

/// The pass for the flags (1 distance, 2 normal, 4 intensity, 8 along the ray, 16 normals
/// filtered) on the widest instruction set the CPU has.
PassFn pass_for(int flags) { return pass_table()[static_cast<std::size_t>(flags)]; }
#undef RANGESEG_PASS_TABLE

void require_same_size(const FloatPlane& plane, const OrganizedCloud& cloud, const char* what) {
  if (plane.width() != cloud.width() || plane.height() != cloud.height()) {
    throw std::invalid_argument(
        std::string("smooth: ") + what + " is " + std::to_string(plane.width()) + "x" +
        std::to_string(plane.height()) + ", the cloud " + std::to_string(cloud.width()) + "x" +
        std::to_string(cloud.height()));
  }
}

/// Grey value of row v from RGB (ITU-R BT.601 luma), into `out`.
RANGESEG_INLINE void grey_row(const OrganizedCloud& cloud, int v, float* __restrict out) {
  const std::uint8_t* __restrict r = cloud.r.row(v);
  const std::uint8_t* __restrict g = cloud.g.row(v);
  const std::uint8_t* __restrict b = cloud.b.row(v);
  for (int u = 0; u < cloud.width(); ++u) {
    out[u] = 0.299f * static_cast<float>(r[u]) + 0.587f * static_cast<float>(g[u]) +
             0.114f * static_cast<float>(b[u]);
  }
}

/// max - min of an intensity over the valid points, row by row. Branch-free, so that it
/// vectorises: x - x == 0 is false exactly for NaN and infinities. kLanes independent running
/// minima and maxima (min and max are exact, so the order does not change the result) let the
/// compiler keep them in vector registers instead of one serial scalar chain.
class IntensityRange {
 public:
  IntensityRange() {
    lo_.fill(kInf);
    hi_.fill(-kInf);
  }
  RANGESEG_INLINE void add_row(const float* __restrict z, const float* __restrict in, int width) {
    int u = 0;
    for (; u + kLanes <= width; u += kLanes) {
      for (int i = 0; i < kLanes; ++i) add(i, z[u + i], in[u + i]);
    }
    for (; u < width; ++u) add(0, z[u], in[u]);
  }
  /// 0 when no point is valid.
  float range() const {
    float low = kInf, high = -kInf;
    for (int i = 0; i < kLanes; ++i) {
      low = std::min(low, lo_[i]);
      high = std::max(high, hi_[i]);
    }
    return high >= low ? high - low : 0.0f;
  }
  /// Adds the points another accumulator has seen.
  void merge(const IntensityRange& other) {
    for (int i = 0; i < kLanes; ++i) {
      lo_[i] = std::min(lo_[i], other.lo_[i]);
      hi_[i] = std::max(hi_[i], other.hi_[i]);
    }
  }

 private:
  static constexpr float kInf = std::numeric_limits<float>::infinity();
  static constexpr int kLanes = 16;
  RANGESEG_INLINE void add(int i, float z, float in) {
    const bool ok = ((z - z) == 0.0f) & ((in - in) == 0.0f);
    lo_[i] = std::min(lo_[i], select(ok, in, kInf));
    hi_[i] = std::max(hi_[i], select(ok, in, -kInf));
  }
  std::array<float, kLanes> lo_, hi_;
};

/// Grey from RGB into rows [v_begin, v_end) of `grey` (sized by the caller) and, when `range`
/// is set, their range over the valid points into it, in one sweep while each grey row is in
/// cache.
RANGESEG_INLINE void rgb_to_grey_body(const OrganizedCloud& cloud, FloatPlane& grey, int v_begin,
                                      int v_end, IntensityRange* range) {
  for (int v = v_begin; v < v_end; ++v) {
    grey_row(cloud, v, grey.row(v));
    if (range != nullptr) range->add_row(cloud.z.row(v), grey.row(v), cloud.width());
  }
}

void rgb_to_grey_generic(const OrganizedCloud& cloud, FloatPlane& grey, int v_begin, int v_end,
                         IntensityRange* range) {
  rgb_to_grey_body(cloud, grey, v_begin, v_end, range);
}

#if RANGESEG_SIMD_X86
// AVX2 without FMA: products and sums stay separately rounded, so the grey values equal the
// generic build's bit for bit.
__attribute__((target("avx2"))) void rgb_to_grey_avx2(const OrganizedCloud& cloud, FloatPlane& grey,
                                                      int v_begin, int v_end,
                                                      IntensityRange* range) {
  rgb_to_grey_body(cloud, grey, v_begin, v_end, range);
}
#endif

/// Grey from RGB (and its range over the valid points into *range, unless nullptr), in row
/// bands on `pool` if given (min and max are exact, so the range does not depend on the bands).
void rgb_to_grey(const OrganizedCloud& cloud, FloatPlane& grey, float* range, ThreadPool* pool) {
  ensure_size(grey, cloud.width(), cloud.height());
  IntensityRange total;
  std::mutex merging;
  const auto band = [&](int, int v_begin, int v_end) {
    IntensityRange part;
    IntensityRange* const acc = range != nullptr ? &part : nullptr;
#if RANGESEG_SIMD_X86
    if (detail::simd::cpu_has_avx2()) {
      rgb_to_grey_avx2(cloud, grey, v_begin, v_end, acc);
    } else {
      rgb_to_grey_generic(cloud, grey, v_begin, v_end, acc);
    }
#else
    rgb_to_grey_generic(cloud, grey, v_begin, v_end, acc);
#endif
    if (acc != nullptr) {
      const std::lock_guard<std::mutex> lock(merging);
      total.merge(part);
    }
  };
  if (pool != nullptr) {
    pool->for_each_band(cloud.height(), 1, band);
  } else {
    band(0, 0, cloud.height());
  }
  if (range != nullptr) *range = total.range();
}

RANGESEG_INLINE float intensity_range_body(const OrganizedCloud& cloud,
                                           const FloatPlane& intensity) {
  IntensityRange acc;
  for (int v = 0; v < cloud.height(); ++v) {
    acc.add_row(cloud.z.row(v), intensity.row(v), cloud.width());
  }
  return acc.range();
}

float intensity_range_generic(const OrganizedCloud& cloud, const FloatPlane& intensity) {
  return intensity_range_body(cloud, intensity);
}

#if RANGESEG_SIMD_X86
__attribute__((target("avx2"))) float intensity_range_avx2(const OrganizedCloud& cloud,
                                                           const FloatPlane& intensity) {
  return intensity_range_body(cloud, intensity);
}
#endif

void check_positive(float value, const char* name) {
  if (!(value > 0.0f) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string("SmoothingSettings::") + name +
                                " must be positive and finite, got " +
                                rangeseg::detail::number_text(value));
  }
}

void check_finite(float value, const char* name) {
  if (!std::isfinite(value)) {
    throw std::invalid_argument(std::string("SmoothingSettings::") + name +
                                " must be finite, got " + rangeseg::detail::number_text(value));
  }
}

/// A pass function and its per-frame constants.
struct PassSetup {
  PassParams prm;
  PassFn pass = nullptr;
};

/// The pass for `st` on a mesh of stride `stride`, with the intensity term on `intensity` of
/// range c_I = `range` (off for nullptr or range <= 0: a constant intensity carries no edge).
PassSetup make_pass(const SmoothingSettings& st, float pixel_angle, int stride,
                    const FloatPlane* intensity, float range) {
  PassSetup setup;
  PassParams& prm = setup.prm;
  prm.stride = stride;
  prm.origin = st.viewpoint;
  prm.kd2 = st.distance_scale * st.distance_scale;
  prm.spacing = static_cast<float>(stride) * pixel_angle;
  prm.noise_a = static_cast<float>(st.noise.a);
  prm.noise_b = static_cast<float>(st.noise.b);
  prm.noise_z0 = static_cast<float>(st.noise.z0);
  prm.inv_normal_scale = 1.0f / st.normal_scale;
  const bool use_intensity = st.use_intensity && intensity != nullptr && range > 0.0f;
  if (use_intensity) {
    prm.intensity = intensity;
    prm.inv_intensity_scale = 1.0f / (range * st.intensity_scale);
  }
  const bool filter_normals = !st.recompute_normals;
  const int flags = (st.use_distance ? 1 : 0) | (st.use_normals ? 2 : 0) | (use_intensity ? 4 : 0) |
                    (st.move_along_ray ? 8 : 0) | (filter_normals ? 16 : 0);
  setup.pass = pass_for(flags);
  return setup;
}

}  // namespace

namespace detail {

float frame_intensity_range(const OrganizedCloud& cloud, const FloatPlane& intensity) {
#if RANGESEG_SIMD_X86
  if (detail::simd::cpu_has_avx2()) return intensity_range_avx2(cloud, intensity);
#endif
  return intensity_range_generic(cloud, intensity);
}

void smooth_rows(const SmoothRowsInput& in, const SmoothingSettings& settings, int v0, int v1,
                 SmoothRowsScratch& scratch, OrganizedCloud& out_cloud, NormalMap& out_normals) {
  assert(in.cloud != nullptr && in.mesh != nullptr && in.normals != nullptr);
  const OrganizedCloud& cloud = *in.cloud;
  const int width = cloud.width(), height = cloud.height();
  assert(0 <= v0 && v0 <= v1 && v1 <= height);
  assert(out_cloud.z.width() == width && out_cloud.z.height() == height);
  assert(out_normals.nz.width() == width && out_normals.nz.height() == height);
  (void)width, (void)height;
  const PassSetup setup = make_pass(settings, pixel_angle_for(settings, 0), in.mesh->pixel_stride,
                                    in.intensity, in.intensity_range);
  PassScratch ps{scratch.rows, scratch.bytes, scratch.layout};
  setup.pass(cloud, *in.normals, *in.mesh, setup.prm, ps, out_cloud, out_normals, v0, v1);
}

}  // namespace detail

void validate(const SmoothingSettings& settings) {
  // The filter settles within tens of passes; a count in the millions is a typo that would run
  // for hours.
  if (settings.iterations < 0 || settings.iterations > kMaxSmoothingIterations) {
    throw std::invalid_argument("SmoothingSettings::iterations must be within 0 .. " +
                                std::to_string(kMaxSmoothingIterations) + ", got " +
                                std::to_string(settings.iterations));
  }
  check_positive(settings.distance_scale, "distance_scale");
  check_finite(settings.pixel_angle, "pixel_angle");
  if (settings.pixel_angle < 0.0f) {
    throw std::invalid_argument(
        "SmoothingSettings::pixel_angle must be >= 0 (0 = from the "
        "camera), got " +
        rangeseg::detail::number_text(settings.pixel_angle));
  }
  check_positive(settings.noise.a, "noise.a");
  check_finite(settings.noise.b, "noise.b");
  if (settings.noise.b < 0.0f) {
    throw std::invalid_argument("SmoothingSettings::noise.b must be >= 0, got " +
                                rangeseg::detail::number_text(settings.noise.b));
  }
  check_finite(settings.noise.z0, "noise.z0");
  check_positive(settings.normal_scale, "normal_scale");
  check_positive(settings.intensity_scale, "intensity_scale");
  check_finite(settings.intensity_range, "intensity_range");
  if (settings.intensity_range < 0.0f) {
    throw std::invalid_argument("SmoothingSettings::intensity_range must be >= 0, got " +
                                rangeseg::detail::number_text(settings.intensity_range));
  }
  for (float c : settings.viewpoint) check_finite(c, "viewpoint");
}

Smoother::Smoother(const SmoothingSettings& settings) : settings_(settings) { validate(settings_); }

void Smoother::set_camera_fx(double fx) {
  if (!(fx >= 0) || !std::isfinite(fx)) {
    throw std::invalid_argument("Smoother::set_camera_fx: fx must be >= 0 and finite, got " +
                                rangeseg::detail::number_text(fx));
  }
  camera_fx_ = fx;
}

float pixel_angle_for(const SmoothingSettings& settings, double camera_fx) {
  if (settings.pixel_angle > 0.0f) return settings.pixel_angle;
  return camera_fx > 0 ? static_cast<float>(1.0 / camera_fx) : kDefaultPixelAngle;
}

float Smoother::pixel_angle() const { return pixel_angle_for(settings_, camera_fx_); }

void Smoother::run(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
                   OrganizedCloud& out_cloud, NormalMap& out_normals) {
  run_passes(cloud, mesh, normals, out_cloud, out_normals, nullptr);
}

void Smoother::run(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
                   OrganizedCloud& out_cloud, NormalMap& out_normals, ThreadPool& pool) {
  run_passes(cloud, mesh, normals, out_cloud, out_normals, &pool);
}

void Smoother::run_passes(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
                          OrganizedCloud& out_cloud, NormalMap& out_normals, ThreadPool* pool) {
  require_organized(cloud, "smooth");  // also the cloud's planes' sizes
  if (&out_cloud == &cloud || &out_normals == &normals) {
    throw std::invalid_argument("smooth: the output objects must differ from the inputs");
  }
  if (mesh.width() != cloud.width() || mesh.height() != cloud.height()) {
    throw std::invalid_argument(
        "smooth: mesh is " + std::to_string(mesh.width()) + "x" + std::to_string(mesh.height()) +
        ", the cloud " + std::to_string(cloud.width()) + "x" + std::to_string(cloud.height()));
  }
  if (mesh.pixel_stride < 1) {
    throw std::invalid_argument("smooth: mesh pixel_stride must be >= 1, got " +
                                std::to_string(mesh.pixel_stride));
  }
  require_same_size(normals.nx, cloud, "normals.nx");
  require_same_size(normals.ny, cloud, "normals.ny");
  require_same_size(normals.nz, cloud, "normals.nz");
  const bool pass_curvature = !settings_.recompute_normals;
  if (pass_curvature) require_same_size(normals.curvature, cloud, "normals.curvature");

  const int width = cloud.width(), height = cloud.height();
  const SmoothingSettings& st = settings_;

  // Outputs: x, y, z and normals are written in full by every pass; optional planes are copied.
  for (FloatPlane* p : {&out_cloud.x, &out_cloud.y, &out_cloud.z}) ensure_size(*p, width, height);
  for (FloatPlane* p : {&out_normals.nx, &out_normals.ny, &out_normals.nz}) {
    ensure_size(*p, width, height);
  }
  if (pass_curvature) ensure_size(out_normals.curvature, width, height);

  if (st.iterations == 0) {
    copy_plane(cloud.x, out_cloud.x);
    copy_plane(cloud.y, out_cloud.y);
    copy_plane(cloud.z, out_cloud.z);
    copy_plane(normals.nx, out_normals.nx);
    copy_plane(normals.ny, out_normals.ny);
    copy_plane(normals.nz, out_normals.nz);
    copy_plane(normals.curvature, out_normals.curvature);
    detail::copy_optional_planes(cloud, out_cloud);
    return;
  }

  const FloatPlane* intensity = nullptr;
  float range = 0.0f;
  if (st.use_intensity && (cloud.has_intensity() || cloud.has_rgb())) {
    const bool frame_range = !(st.intensity_range > 0.0f);
    if (cloud.has_intensity()) {
      intensity = &cloud.intensity;
      if (frame_range) range = detail::frame_intensity_range(cloud, *intensity);
    } else {
      rgb_to_grey(cloud, grey_, frame_range ? &range : nullptr, pool);
      intensity = &grey_;
    }
    if (!frame_range) range = st.intensity_range;
  }
  const PassSetup setup = make_pass(st, pixel_angle(), mesh.pixel_stride, intensity, range);
  const PassParams& prm = setup.prm;
  PassParams last_prm = prm;  // the last pass also copies the curvature through
  if (pass_curvature) {
    last_prm.curvature_in = &normals.curvature;
    last_prm.curvature_out = &out_normals.curvature;
  }
  const PassFn pass = setup.pass;
  const bool filter_normals = !st.recompute_normals;
  PassScratch ps{rows_, row_bytes_, rows_layout_};
  if (pool != nullptr) {
    const auto extra = static_cast<std::size_t>(pool->threads() - 1);
    if (band_rows_.size() < extra) {
      band_rows_.resize(extra);
      band_row_bytes_.resize(extra);
      band_rows_layout_.resize(extra, 0);
    }
  }

  // The pass works on origin-relative points (q = p - viewpoint) and adds the viewpoint back.
  const bool shifted = st.viewpoint != std::array<float, 3>{0.0f, 0.0f, 0.0f};
  if (shifted) {
    for (FloatPlane* p : {&shifted_.x, &shifted_.y, &shifted_.z}) ensure_size(*p, width, height);
  }

  if (st.iterations > 1) {
    for (FloatPlane* p : {&scratch_cloud_.x, &scratch_cloud_.y, &scratch_cloud_.z,
                          &scratch_normals_.nx, &scratch_normals_.ny, &scratch_normals_.nz}) {
      ensure_size(*p, width, height);
    }
    if (!filter_normals) ensure_size(scratch_normals_.curvature, width, height);
  }

  const NormalSettings normal_settings{.viewpoint = st.viewpoint};
  const OrganizedCloud* src = &cloud;
  const NormalMap* src_normals = &normals;
  for (int i = 0; i < st.iterations; ++i) {
    // Ping-pong so that the last pass lands in the outputs.
    const bool to_output = (st.iterations - 1 - i) % 2 == 0;
    OrganizedCloud& dst = to_output ? out_cloud : scratch_cloud_;
    NormalMap& dst_normals = to_output ? out_normals : scratch_normals_;
    if (shifted) {
      for (int v = 0; v < height; ++v) {
        for (int u = 0; u < width; ++u) {
          shifted_.x(u, v) = src->x(u, v) - st.viewpoint[0];
          shifted_.y(u, v) = src->y(u, v) - st.viewpoint[1];
          shifted_.z(u, v) = src->z(u, v) - st.viewpoint[2];
        }
      }
    }
    const OrganizedCloud& in = shifted ? shifted_ : *src;
    const PassParams& pass_prm = i + 1 == st.iterations ? last_prm : prm;
    if (pool == nullptr || pool->threads() == 1) {
      pass(in, *src_normals, mesh, pass_prm, ps, dst, dst_normals, 0, height);
    } else {
      pool->for_each_band(height, 1, [&](int band, int v0, int v1) {
        if (band == 0) {
          pass(in, *src_normals, mesh, pass_prm, ps, dst, dst_normals, v0, v1);
          return;
        }
        const auto b = static_cast<std::size_t>(band - 1);
        PassScratch band_ps{band_rows_[b], band_row_bytes_[b], band_rows_layout_[b]};
        pass(in, *src_normals, mesh, pass_prm, band_ps, dst, dst_normals, v0, v1);
      });
    }
    if (!filter_normals) {
      detail::prepare_normals(dst, mesh, normal_settings, dst_normals);
      detail::compute_normals_rows(dst, mesh, normal_settings, dst_normals, 0, height,
                                   normal_rows_);
    }
    src = &dst;
    src_normals = &dst_normals;
  }
  // After the passes: copied before, these planes pushed the pass's rows out of cache (the
  // stage measured ~4 % slower).
  detail::copy_optional_planes(cloud, out_cloud);
}

void smooth(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
            const SmoothingSettings& settings, OrganizedCloud& out_cloud, NormalMap& out_normals) {
  Smoother smoother(settings);
  smoother.run(cloud, mesh, normals, out_cloud, out_normals);
}

}  // namespace rangeseg
