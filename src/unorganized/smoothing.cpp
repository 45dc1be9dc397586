// Stage 3 over k-nearest-neighbour rings: the bilateral filter of points and normals.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <vector>

#include "rangeseg/unorganized.hpp"
#include "unorganized/internal.hpp"

namespace rangeseg {
namespace {

using unorganized::at;

using unorganized::Scales;

/// Below this |cos| between a viewing ray and the filtered normal (85 deg off the normal) a
/// point moves to the weighted mean's projection onto its ray instead of the ray's
/// intersection with the mean's tangent plane, which runs away at grazing incidence [1].
constexpr double kMinRayCosine = 0.087;
/// How far a pass may move a point along its ray, in units of the depth noise sigma at its
/// range (SmoothingSettings::noise) [1]: three passes (the default) up to 3 sigma. Without a
/// bound, a 16-beam lidar's walls, whose rings span scan lines 0.35 m apart, moved by up to
/// 0.9 m.
constexpr double kMaxMoveSigmas = 1.0;

/// Grey values in ring order (intensity, else from RGB), or empty when the cloud has neither,
/// and c_I: the setting, or max - min over the valid points.
void grey_values(const OrganizedCloud& cloud, const SmoothingSettings& s,
                 const std::vector<float>& xyz, std::vector<float>& grey, float& range) {
  grey.clear();
  range = 0;
  if (!s.use_intensity || (!cloud.has_intensity() && !cloud.has_rgb())) return;
  grey.resize(cloud.size());
  float lo = INFINITY, hi = -INFINITY;
  for (std::size_t i = 0; i < grey.size(); ++i) {
    const float g = cloud.has_intensity() ? at(cloud.intensity, i)
                                          : 0.299f * at(cloud.r, i) + 0.587f * at(cloud.g, i) +
                                                0.114f * at(cloud.b, i);
    grey[i] = g;
    if (!std::isnan(xyz[3 * i]) && std::isfinite(g)) {
      lo = std::min(lo, g);
      hi = std::max(hi, g);
    }
  }
  range = s.intensity_range > 0 ? s.intensity_range : (hi > lo ? hi - lo : 0.0f);
  if (!(range > 0)) grey.clear();
}

void one_pass(const PointRings& rings, const SmoothingSettings& s, const std::vector<float>& grey,
              float inv_intensity, const std::vector<float>& xyz, const std::vector<float>& n,
              std::vector<Scales>& scales, std::vector<float>& xyz_out, std::vector<float>& n_out,
              ThreadPool* pool) {
  const std::size_t count = rings.size();
  const float ds2 = s.distance_scale * s.distance_scale;
  unorganized::for_points(count, pool, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      if (rings.count[i] == 0) continue;
      const float* p = xyz.data() + 3 * i;
      double msd = 0;
      for (const std::int32_t j : rings.ring(i)) {
        msd += unorganized::squared_distance(p, xyz.data() + 3 * static_cast<std::size_t>(j));
      }
      msd /= rings.count[i];
      const float rx = p[0] - s.viewpoint[0], ry = p[1] - s.viewpoint[1],
                  rz = p[2] - s.viewpoint[2];
      const double sigma =
          s.noise.sigma(std::sqrt(double{rx} * rx + double{ry} * ry + double{rz} * rz));
      scales[i].inv_distance = msd > 0 ? static_cast<float>(1.0 / (2.0 * ds2 * msd)) : 0.0f;
      const double spread = msd > 0 ? std::max(1.0, sigma / std::sqrt(msd)) : 1.0;
      scales[i].inv_normal = static_cast<float>(1.0 / (s.normal_scale * spread));
    }
  });
  xyz_out = xyz;
  n_out = n;
  unorganized::for_points(count, pool, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      if (rings.count[i] == 0) continue;
      const float* p = xyz.data() + 3 * i;
      const float* ni = n.data() + 3 * i;
      const bool normal_i = !std::isnan(ni[0]);
      if (s.use_normals && !normal_i) continue;  // keeps its point, as on the grid
      double sp[3] = {p[0], p[1], p[2]}, sn[3] = {ni[0], ni[1], ni[2]};
      double total = 1.0;
      for (const std::int32_t jj : rings.ring(i)) {
        const auto j = static_cast<std::size_t>(jj);
        const float* q = xyz.data() + 3 * j;
        const float* nj = n.data() + 3 * j;
        float exponent = 0;
        if (s.use_distance) {
          exponent += unorganized::squared_distance(p, q) * 0.5f *
                      (scales[i].inv_distance + scales[j].inv_distance);
        }
        if (s.use_normals) {
          if (std::isnan(nj[0])) continue;
          const float l1 =
              std::fabs(ni[0] - nj[0]) + std::fabs(ni[1] - nj[1]) + std::fabs(ni[2] - nj[2]);
          exponent += l1 * 0.5f * (scales[i].inv_normal + scales[j].inv_normal);
        }
        if (!grey.empty()) exponent += std::fabs(grey[i] - grey[j]) * inv_intensity;
        if (!(exponent < 30.0f)) continue;
        const double wij = std::exp(-exponent);
        total += wij;
        for (int c = 0; c < 3; ++c) sp[c] += wij * q[c];
        if (normal_i && !std::isnan(nj[0])) {
          for (int c = 0; c < 3; ++c) sn[c] += wij * nj[c];
        }
      }
      for (double& c : sp) c /= total;
      const double sn_norm = std::sqrt(sn[0] * sn[0] + sn[1] * sn[1] + sn[2] * sn[2]);
      float* po = xyz_out.data() + 3 * i;
      if (s.move_along_ray) {
        const double r[3] = {double{p[0]} - s.viewpoint[0], double{p[1]} - s.viewpoint[1],
                             double{p[2]} - s.viewpoint[2]};
        const double m[3] = {sp[0] - s.viewpoint[0], sp[1] - s.viewpoint[1],
                             sp[2] - s.viewpoint[2]};
        const double r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
        const double range = std::sqrt(r2);
        double t = 1.0;
        if (range > 0) {
          // Where the ray meets the plane through the weighted mean, normal to the filtered
          // normal. A ring need not lie around its point (a lidar's scan lines lie further apart
          // than its points): projected onto the ray, the mean's offset across it would move the
          // point off a slanted surface. Without a normal, or where the ray runs within
          // kMinRayCosine of that plane, the mean is projected all the same.
          const double rn =
              normal_i && sn_norm > 0 ? (r[0] * sn[0] + r[1] * sn[1] + r[2] * sn[2]) / sn_norm : 0;
          t = std::fabs(rn) > kMinRayCosine * range
                  ? (m[0] * sn[0] + m[1] * sn[1] + m[2] * sn[2]) / sn_norm / rn
                  : (m[0] * r[0] + m[1] * r[1] + m[2] * r[2]) / r2;
          // A filter of noise moves a point by a few sigma at most; more is another surface's
          // pull (a ring across an edge the normals do not show).
          const double limit = kMaxMoveSigmas * s.noise.sigma(range) / range;
          t = std::clamp(t, 1.0 - limit, 1.0 + limit);
        }
        for (int c = 0; c < 3; ++c) po[c] = static_cast<float>(s.viewpoint[c] + t * r[c]);
      } else {
        for (int c = 0; c < 3; ++c) po[c] = static_cast<float>(sp[c]);
      }
      if (normal_i && sn_norm > 0) {
        for (int c = 0; c < 3; ++c) n_out[3 * i + c] = static_cast<float>(sn[c] / sn_norm);
      }
    }
  });
}

}  // namespace

namespace {

void smooth_over_rings(const OrganizedCloud& cloud, const PointRings& rings,
                       const NormalMap& normals, const SmoothingSettings& settings,
                       OrganizedCloud& out_cloud, NormalMap& out_normals, ThreadPool* pool,
                       RingBuffers::Impl& b) {
  validate(settings);
  unorganized::require_rings_match(cloud, rings, &normals, "smooth");
  if (&out_cloud == &cloud || &out_normals == &normals) {
    throw std::invalid_argument("smooth: an output object is the corresponding input");
  }
  std::vector<float>& xyz = b.xyz;
  std::vector<float>& n = b.n;
  n.resize(cloud.size() * 3);
  unorganized::pack_points(cloud, xyz);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    n[3 * i] = at(normals.nx, i);
    n[3 * i + 1] = at(normals.ny, i);
    n[3 * i + 2] = at(normals.nz, i);
  }
  float range = 0;
  grey_values(cloud, settings, xyz, b.grey, range);
  const float inv_intensity = b.grey.empty() ? 0.0f : 1.0f / (range * settings.intensity_scale);
  b.scales.resize(cloud.size());
  std::vector<float>& xyz_next = b.xyz_next;
  std::vector<float>& n_next = b.n_next;
  for (int pass = 0; pass < settings.iterations; ++pass) {
    one_pass(rings, settings, b.grey, inv_intensity, xyz, n, b.scales, xyz_next, n_next, pool);
    xyz.swap(xyz_next);
    n.swap(n_next);
  }
  out_cloud = cloud;
  out_normals = normals;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (rings.count[i] == 0) continue;
    at(out_cloud.x, i) = xyz[3 * i];
    at(out_cloud.y, i) = xyz[3 * i + 1];
    at(out_cloud.z, i) = xyz[3 * i + 2];
    at(out_normals.nx, i) = n[3 * i];
    at(out_normals.ny, i) = n[3 * i + 1];
    at(out_normals.nz, i) = n[3 * i + 2];
  }
}

}  // namespace

RingBuffers::RingBuffers() : impl_(std::make_unique<Impl>()) {}

RingBuffers::Impl& RingBuffers::impl() {
  if (!impl_) impl_ = std::make_unique<Impl>();  // moved from
  return *impl_;
}
RingBuffers::~RingBuffers() = default;
RingBuffers::RingBuffers(RingBuffers&&) noexcept = default;
RingBuffers& RingBuffers::operator=(RingBuffers&&) noexcept = default;

void smooth(const OrganizedCloud& cloud, const PointRings& rings, const NormalMap& normals,
            const SmoothingSettings& settings, OrganizedCloud& out_cloud, NormalMap& out_normals) {
  RingBuffers buffers;
  smooth_over_rings(cloud, rings, normals, settings, out_cloud, out_normals, nullptr,
                    buffers.impl());
}

void smooth(const OrganizedCloud& cloud, const PointRings& rings, const NormalMap& normals,
            const SmoothingSettings& settings, OrganizedCloud& out_cloud, NormalMap& out_normals,
            ThreadPool& pool) {
  RingBuffers buffers;
  smooth_over_rings(cloud, rings, normals, settings, out_cloud, out_normals, &pool, buffers.impl());
}

void smooth(const OrganizedCloud& cloud, const PointRings& rings, const NormalMap& normals,
            const SmoothingSettings& settings, OrganizedCloud& out_cloud, NormalMap& out_normals,
            ThreadPool* pool, RingBuffers& buffers) {
  smooth_over_rings(cloud, rings, normals, settings, out_cloud, out_normals, pool, buffers.impl());
}

}  // namespace rangeseg
