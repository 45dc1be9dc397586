#include "rangeseg/smoothing.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

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

/// Weights exp(-a) with a >= kMaxExponent are treated as 0 (e^-30 ~ 1e-13, far below the
/// centre's weight 1).
constexpr float kMaxExponent = 30.0f;

/// exp(-a) for a in [0, kMaxExponent]: 2^y = 2^n 2^f with n = round(y), |f| <= 1/2, and 2^f from
/// its degree-5 Taylor polynomial in f ln 2 (|f ln 2| <= 0.347, relative error < 4e-6, checked in
/// tests against std::exp through the filter output). Branch-free and integer-free except for bit
/// casts, so the row loops vectorise; std::exp is the whole cost of the filter otherwise.
inline float exp_neg(float a) {
  constexpr float kRound = 12582912.0f;  // 1.5 * 2^23: adding it rounds to an integer
  const float y = a * -1.44269504f;      // -a log2(e), in [-43.3, 0]
  const float t = y + kRound;
  const float n = t - kRound;
  const float g = (y - n) * 0.693147181f;
  const float p =
      1.0f + g * (1.0f + g * (0.5f + g * (1.0f / 6 + g * (1.0f / 24 + g * (1.0f / 120)))));
  const std::int32_t exponent =
      std::bit_cast<std::int32_t>(t) - std::bit_cast<std::int32_t>(kRound);
  return std::bit_cast<float>(std::bit_cast<std::int32_t>(p) + exponent * (1 << 23));
}

/// c ? a : b on the bits. A plain ?: on floats lets the compiler sink the arithmetic that
/// computes `a` into a branch, which (floating-point ops may trap) it then cannot vectorise.
inline float select(bool c, float a, float b) {
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
  float ox = 0, oy = 0, oz = 0;
  float kd2 = 0;      // distance_scale^2
  float spacing = 0;  // stride * pixel_angle [rad]
  float noise_a = 0, noise_b = 0, noise_z0 = 0;
  float inv_normal_scale = 0;
  float inv_intensity_scale = 0;  // 1 / (c_I s_I)
  const FloatPlane* intensity = nullptr;
};

/// Row accumulators, each `width` floats inside Smoother::rows_.
struct RowScratch {
  float* w;        // sum of weights
  float* a0;       // sum w t (along ray) or sum w x
  float* a1;       // sum w y
  float* a2;       // sum w z
  float* n0;       // sum w nx
  float* n1;       // sum w ny
  float* n2;       // sum w nz
  float* inv2sd2;  // 1 / (2 s_d(z_i)^2)
  float* inv_sn;   // 1 / s_n(z_i)
};

template <bool kDistance, bool kNormal, bool kIntensity, bool kAlongRay, bool kFilterNormals>
void smooth_pass(const OrganizedCloud& src, const NormalMap& src_normals, const Mesh& mesh,
                 const PassParams& prm, RowScratch sc, OrganizedCloud& dst,
                 NormalMap& dst_normals) {
  const int width = src.width(), height = src.height(), s = prm.stride;
  const float ox = prm.ox, oy = prm.oy, oz = prm.oz;
  float* __restrict aw = sc.w;
  float* __restrict a0 = sc.a0;
  float* __restrict a1 = sc.a1;
  float* __restrict a2 = sc.a2;
  float* __restrict n0 = sc.n0;
  float* __restrict n1 = sc.n1;
  float* __restrict n2 = sc.n2;
  float* __restrict inv2sd2 = sc.inv2sd2;
  float* __restrict inv_sn = sc.inv_sn;

  for (int v = 0; v < height; ++v) {
    const float* __restrict xc = src.x.row(v);
    const float* __restrict yc = src.y.row(v);
    const float* __restrict zc = src.z.row(v);
    const float* __restrict nxc = src_normals.nx.row(v);
    const float* __restrict nyc = src_normals.ny.row(v);
    const float* __restrict nzc = src_normals.nz.row(v);
    const float* __restrict ic = kIntensity ? prm.intensity->row(v) : nullptr;
    const std::uint8_t* __restrict edges = mesh.edges.row(v);

    // The centre pixel itself, weight 1.
    RANGESEG_VECTORIZE
    for (int u = 0; u < width; ++u) {
      aw[u] = 1.0f;
      if constexpr (kAlongRay) {
        const float qx = xc[u] - ox, qy = yc[u] - oy, qz = zc[u] - oz;
        a0[u] = qx * qx + qy * qy + qz * qz;
      } else {
        a0[u] = xc[u];
        a1[u] = yc[u];
        a2[u] = zc[u];
      }
      if constexpr (kFilterNormals) {
        n0[u] = nxc[u];
        n1[u] = nyc[u];
        n2[u] = nzc[u];
      }
      if constexpr (kDistance || kNormal) {
        const float z = zc[u], dz = z - prm.noise_z0;
        const float sigma = prm.noise_a + prm.noise_b * dz * dz;
        const float spacing = prm.spacing * std::fabs(z);
        if constexpr (kDistance) {
          inv2sd2[u] = 0.5f / (prm.kd2 * (spacing * spacing + 2.0f * sigma * sigma));
        }
        // Normal noise grows with sigma / spacing: 1 / s_n = min(1, spacing / sigma) /
        // normal_scale.
        if constexpr (kNormal) {
          const float ratio = spacing / sigma;
          inv_sn[u] = prm.inv_normal_scale * select(ratio < 1.0f, ratio, 1.0f);
        }
      }
    }

    for (int k = 0; k < 8; ++k) {
      const int vn = v + s * kNeighbourDv[k];
      if (vn < 0 || vn >= height) continue;  // the mesh has no edge leaving the grid
      const int du = s * kNeighbourDu[k];
      const int u_begin = std::max(0, -du), u_end = std::min(width, width - du);
      const float* __restrict xn = src.x.row(vn) + du;
      const float* __restrict yn = src.y.row(vn) + du;
      const float* __restrict zn = src.z.row(vn) + du;
      const float* __restrict nxn = src_normals.nx.row(vn) + du;
      const float* __restrict nyn = src_normals.ny.row(vn) + du;
      const float* __restrict nzn = src_normals.nz.row(vn) + du;
      const float* __restrict in = kIntensity ? prm.intensity->row(vn) + du : nullptr;
      const unsigned bit = 1u << k;

      RANGESEG_VECTORIZE
      for (int u = u_begin; u < u_end; ++u) {
        float arg = 0.0f;
        if constexpr (kDistance) {
          const float dx = xn[u] - xc[u], dy = yn[u] - yc[u], dz = zn[u] - zc[u];
          arg += (dx * dx + dy * dy + dz * dz) * inv2sd2[u];
        }
        if constexpr (kNormal) {
          arg += (std::fabs(nxn[u] - nxc[u]) + std::fabs(nyn[u] - nyc[u]) +
                  std::fabs(nzn[u] - nzc[u])) *
                 inv_sn[u];
        }
        if constexpr (kIntensity) arg += std::fabs(in[u] - ic[u]) * prm.inv_intensity_scale;
        // Everything is evaluated for every lane and then selected, so that the loop has no
        // branches and vectorises. NaN (a NaN normal or intensity) fails the comparison.
        const bool use = ((edges[u] & bit) != 0) & (arg < kMaxExponent);
        const float e = exp_neg(select(arg < kMaxExponent, arg, kMaxExponent));
        const float w = select(use, e, 0.0f);
        aw[u] += w;
        if constexpr (kAlongRay) {
          const float t = (xn[u] - ox) * (xc[u] - ox) + (yn[u] - oy) * (yc[u] - oy) +
                          (zn[u] - oz) * (zc[u] - oz);
          a0[u] += w * select(use, t, 0.0f);
        } else {
          const float xv = xn[u], yv = yn[u], zv = zn[u];
          a0[u] += w * select(use, xv, 0.0f);
          a1[u] += w * select(use, yv, 0.0f);
          a2[u] += w * select(use, zv, 0.0f);
        }
        if constexpr (kFilterNormals) {
          // Without the normal term a NaN neighbour normal must be skipped explicitly.
          const float nxv = nxn[u], nyv = nyn[u], nzv = nzn[u];
          const bool use_n = kNormal ? use : (use & (nxv == nxv));
          n0[u] += w * select(use_n, nxv, 0.0f);
          n1[u] += w * select(use_n, nyv, 0.0f);
          n2[u] += w * select(use_n, nzv, 0.0f);
        }
      }
    }

    float* __restrict xo = dst.x.row(v);
    float* __restrict yo = dst.y.row(v);
    float* __restrict zo = dst.z.row(v);
    RANGESEG_VECTORIZE
    for (int u = 0; u < width; ++u) {
      if constexpr (kAlongRay) {
        // p' = o + q (q . (m - o)) / (q . q), m the weighted mean, q = p - o: the weighted mean
        // projected onto the viewing ray; the self term of a0 was q . q.
        const float qx = xc[u] - ox, qy = yc[u] - oy, qz = zc[u] - oz;
        const float qq = qx * qx + qy * qy + qz * qz;
        const float scale = select(qq > 0.0f, a0[u] / (aw[u] * qq), 1.0f);
        xo[u] = ox + qx * scale;
        yo[u] = oy + qy * scale;
        zo[u] = oz + qz * scale;
      } else {
        const float inv = 1.0f / aw[u];
        xo[u] = a0[u] * inv;
        yo[u] = a1[u] * inv;
        zo[u] = a2[u] * inv;
      }
    }
    if constexpr (kFilterNormals) {
      float* __restrict nxo = dst_normals.nx.row(v);
      float* __restrict nyo = dst_normals.ny.row(v);
      float* __restrict nzo = dst_normals.nz.row(v);
      RANGESEG_VECTORIZE
      for (int u = 0; u < width; ++u) {
        const float len2 = n0[u] * n0[u] + n1[u] * n1[u] + n2[u] * n2[u];
        // Opposite normals can cancel; then (and for NaN) the pixel keeps its normal.
        const bool ok = len2 > 1e-12f;
        const float inv = 1.0f / std::sqrt(select(ok, len2, 1.0f));
        nxo[u] = select(ok, n0[u] * inv, nxc[u]);
        nyo[u] = select(ok, n1[u] * inv, nyc[u]);
        nzo[u] = select(ok, n2[u] * inv, nzc[u]);
      }
    }
  }
}

using PassFn = void (*)(const OrganizedCloud&, const NormalMap&, const Mesh&, const PassParams&,
                        RowScratch, OrganizedCloud&, NormalMap&);

template <int kFlags>
constexpr PassFn pass_for() {
  return &smooth_pass<(kFlags & 1) != 0, (kFlags & 2) != 0, (kFlags & 4) != 0, (kFlags & 8) != 0,
                      (kFlags & 16) != 0>;
}

template <int... kFlags>
constexpr std::array<PassFn, sizeof...(kFlags)> make_pass_table(
    std::integer_sequence<int, kFlags...>) {
  return {pass_for<kFlags>()...};
}

constexpr auto kPassTable = make_pass_table(std::make_integer_sequence<int, 32>{});

void require_same_size(const FloatPlane& plane, const OrganizedCloud& cloud, const char* what) {
  if (plane.width() != cloud.width() || plane.height() != cloud.height()) {
    throw std::invalid_argument(
        std::string("smooth: ") + what + " is " + std::to_string(plane.width()) + "x" +
        std::to_string(plane.height()) + ", the cloud " + std::to_string(cloud.width()) + "x" +
        std::to_string(cloud.height()));
  }
}

/// Grey value of every pixel from RGB (ITU-R BT.601 luma), into `grey`.
void rgb_to_grey(const OrganizedCloud& cloud, FloatPlane& grey) {
  ensure_size(grey, cloud.width(), cloud.height());
  for (int v = 0; v < cloud.height(); ++v) {
    const std::uint8_t* r = cloud.r.row(v);
    const std::uint8_t* g = cloud.g.row(v);
    const std::uint8_t* b = cloud.b.row(v);
    float* out = grey.row(v);
    for (int u = 0; u < cloud.width(); ++u) {
      out[u] = 0.299f * static_cast<float>(r[u]) + 0.587f * static_cast<float>(g[u]) +
               0.114f * static_cast<float>(b[u]);
    }
  }
}

/// max - min of `intensity` over the valid points of `cloud` (0 when none).
float intensity_range(const OrganizedCloud& cloud, const FloatPlane& intensity) {
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (int v = 0; v < cloud.height(); ++v) {
    const float* z = cloud.z.row(v);
    const float* in = intensity.row(v);
    for (int u = 0; u < cloud.width(); ++u) {
      if (!std::isfinite(z[u]) || !std::isfinite(in[u])) continue;
      lo = std::min(lo, in[u]);
      hi = std::max(hi, in[u]);
    }
  }
  return hi >= lo ? hi - lo : 0.0f;
}

void check_positive(float value, const char* name) {
  if (!(value > 0.0f) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string("SmoothingSettings::") + name +
                                " must be positive and finite, got " + std::to_string(value));
  }
}

void check_finite(float value, const char* name) {
  if (!std::isfinite(value)) {
    throw std::invalid_argument(std::string("SmoothingSettings::") + name +
                                " must be finite, got " + std::to_string(value));
  }
}

}  // namespace

void validate(const SmoothingSettings& settings) {
  if (settings.iterations < 0) {
    throw std::invalid_argument("SmoothingSettings::iterations must be >= 0, got " +
                                std::to_string(settings.iterations));
  }
  check_positive(settings.distance_scale, "distance_scale");
  check_positive(settings.pixel_angle, "pixel_angle");
  check_positive(settings.noise.a, "noise_a");
  check_finite(settings.noise.b, "noise_b");
  if (settings.noise.b < 0.0f) {
    throw std::invalid_argument("SmoothingSettings::noise_b must be >= 0, got " +
                                std::to_string(settings.noise.b));
  }
  check_finite(settings.noise.z0, "noise_z0");
  check_positive(settings.normal_scale, "normal_scale");
  check_positive(settings.intensity_scale, "intensity_scale");
  check_finite(settings.intensity_range, "intensity_range");
  if (settings.intensity_range < 0.0f) {
    throw std::invalid_argument("SmoothingSettings::intensity_range must be >= 0, got " +
                                std::to_string(settings.intensity_range));
  }
  for (float c : settings.viewpoint) check_finite(c, "viewpoint");
}

Smoother::Smoother(const SmoothingSettings& settings) : settings_(settings) { validate(settings_); }

void Smoother::run(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
                   OrganizedCloud& out_cloud, NormalMap& out_normals) {
  require_organized(cloud, "smooth");
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
  require_same_size(cloud.x, cloud, "x");
  require_same_size(cloud.y, cloud, "y");
  require_same_size(normals.nx, cloud, "normals.nx");
  require_same_size(normals.ny, cloud, "normals.ny");
  require_same_size(normals.nz, cloud, "normals.nz");
  const bool pass_curvature = !settings_.recompute_normals;
  if (pass_curvature) require_same_size(normals.curvature, cloud, "normals.curvature");

  const int width = cloud.width(), height = cloud.height();
  const SmoothingSettings& st = settings_;

  // Outputs: x, y, z and normals are written in full by every pass; optional planes are copied.
  for (FloatPlane* p : {&out_cloud.x, &out_cloud.y, &out_cloud.z}) ensure_size(*p, width, height);
  out_cloud.intensity = cloud.intensity;
  out_cloud.r = cloud.r;
  out_cloud.g = cloud.g;
  out_cloud.b = cloud.b;
  out_cloud.label = cloud.label;
  for (FloatPlane* p : {&out_normals.nx, &out_normals.ny, &out_normals.nz}) {
    ensure_size(*p, width, height);
  }
  if (pass_curvature) copy_plane(normals.curvature, out_normals.curvature);

  if (st.iterations == 0) {
    copy_plane(cloud.x, out_cloud.x);
    copy_plane(cloud.y, out_cloud.y);
    copy_plane(cloud.z, out_cloud.z);
    copy_plane(normals.nx, out_normals.nx);
    copy_plane(normals.ny, out_normals.ny);
    copy_plane(normals.nz, out_normals.nz);
    if (!pass_curvature) copy_plane(normals.curvature, out_normals.curvature);
    return;
  }

  PassParams prm;
  prm.stride = mesh.pixel_stride;
  prm.ox = st.viewpoint[0];
  prm.oy = st.viewpoint[1];
  prm.oz = st.viewpoint[2];
  prm.kd2 = st.distance_scale * st.distance_scale;
  const float spacing = static_cast<float>(mesh.pixel_stride) * st.pixel_angle;
  prm.spacing = spacing;
  prm.noise_a = static_cast<float>(st.noise.a);
  prm.noise_b = static_cast<float>(st.noise.b);
  prm.noise_z0 = static_cast<float>(st.noise.z0);
  prm.inv_normal_scale = 1.0f / st.normal_scale;

  bool use_intensity = false;
  if (st.use_intensity && (cloud.has_intensity() || cloud.has_rgb())) {
    if (cloud.has_intensity()) {
      require_same_size(cloud.intensity, cloud, "intensity");
      prm.intensity = &cloud.intensity;
    } else {
      rgb_to_grey(cloud, grey_);
      prm.intensity = &grey_;
    }
    const float range =
        st.intensity_range > 0.0f ? st.intensity_range : intensity_range(cloud, *prm.intensity);
    // A constant intensity carries no edge: the term is left out.
    if (range > 0.0f) {
      use_intensity = true;
      prm.inv_intensity_scale = 1.0f / (range * st.intensity_scale);
    }
  }

  const bool filter_normals = !st.recompute_normals;
  const int flags = (st.use_distance ? 1 : 0) | (st.use_normals ? 2 : 0) | (use_intensity ? 4 : 0) |
                    (st.move_along_ray ? 8 : 0) | (filter_normals ? 16 : 0);
  const PassFn pass = kPassTable[static_cast<std::size_t>(flags)];

  const std::size_t w = static_cast<std::size_t>(width);
  if (rows_.size() < 9 * w) rows_.resize(9 * w);
  RowScratch sc{rows_.data(),         rows_.data() + w,     rows_.data() + 2 * w,
                rows_.data() + 3 * w, rows_.data() + 4 * w, rows_.data() + 5 * w,
                rows_.data() + 6 * w, rows_.data() + 7 * w, rows_.data() + 8 * w};

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
    pass(*src, *src_normals, mesh, prm, sc, dst, dst_normals);
    if (!filter_normals) compute_normals(dst, mesh, normal_settings, dst_normals);
    src = &dst;
    src_normals = &dst_normals;
  }
}

void smooth(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
            const SmoothingSettings& settings, OrganizedCloud& out_cloud, NormalMap& out_normals) {
  Smoother smoother(settings);
  smoother.run(cloud, mesh, normals, out_cloud, out_normals);
}

}  // namespace rangeseg
