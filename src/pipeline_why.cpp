// Pipeline::why_no_segments: the causes in the input of a frame without segments, in words
// that name what to change.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <string>
#include <vector>

#include "rangeseg/pipeline.hpp"

namespace rangeseg {
namespace {

/// The period and first index of the rows (or columns) that hold a valid point: the gcd of the
/// gaps between them (1 when they follow each other anywhere).
struct Period {
  int step = 1, first = 0;
};
Period period_of(const std::vector<int>& holding) {
  Period p;
  if (holding.empty()) return p;
  p.first = holding.front();
  int step = 0;
  for (std::size_t i = 1; i < holding.size(); ++i) {
    step = std::gcd(step, holding[i] - holding[i - 1]);
  }
  p.step = std::max(1, step);
  return p;
}

/// The k-th smallest of `values` (reordered): the median is the upper middle one (k = n / 2), a
/// quantile q the one at q (n - 1) rounded down.
template <class T>
double nth_value(std::vector<T>& values, std::size_t k) {
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(k);
  std::nth_element(values.begin(), at, values.end());
  return static_cast<double>(*at);
}
template <class T>
double median(std::vector<T>& values) {
  return nth_value(values, values.size() / 2);
}
template <class T>
double quantile(std::vector<T>& values, double q) {
  return nth_value(values, static_cast<std::size_t>(q * static_cast<double>(values.size() - 1)));
}

/// Points far apart on the lattice: the valid pixels lie on every k-th row or column, or too
/// few of them have neighbours for a mesh. The hint names the rows and columns to take when the
/// valid pixels have a period, and nothing when they do not (random dropouts, a checkerboard).
std::string sparse_cause(const OrganizedCloud& points, int s, std::size_t lattice_valid,
                         std::size_t with_cell) {
  if (s >= points.width() || s >= points.height()) {
    return "mesh.pixel_stride = " + std::to_string(s) + " leaves no lattice cell in this " +
           std::to_string(points.width()) + " x " + std::to_string(points.height()) +
           " grid (a cell needs two rows and two columns of it)";
  }
  std::vector<int> rows, columns;
  std::vector<char> column_holds(static_cast<std::size_t>(points.width()), 0);
  for (int v = 0; v < points.height(); ++v) {
    bool any = false;
    for (int u = 0; u < points.width(); ++u) {
      if (!points.valid(u, v)) continue;
      any = true;
      column_holds[static_cast<std::size_t>(u)] = 1;
    }
    if (any) rows.push_back(v);
  }
  for (int u = 0; u < points.width(); ++u) {
    if (column_holds[static_cast<std::size_t>(u)]) columns.push_back(u);
  }
  const Period pr = period_of(rows), pc = period_of(columns);
  std::string text = "neighbouring pixels seldom both hold a point (" + std::to_string(with_cell) +
                     " of the " + std::to_string(lattice_valid) +
                     " points on the mesh's lattice have one to the right and below)";
  if (pr.step == 1 && pc.step == 1) return text;
  const auto every = [](const char* what, const Period& p) {
    const char* nth = p.step == 2 ? "nd" : p.step == 3 ? "rd" : "th";
    return "every " + std::to_string(p.step) + nth + " " + what + " from " + what + " " +
           std::to_string(p.first);
  };
  text += "; the points lie on ";
  if (pr.step > 1) text += every("row", pr);
  if (pr.step > 1 && pc.step > 1) text += " and ";
  if (pc.step > 1) text += every("column", pc);
  text += ": mesh those (NumPy: points[" + std::to_string(pr.first) +
          "::" + std::to_string(pr.step) + ", " + std::to_string(pc.first) +
          "::" + std::to_string(pc.step) + "])";
  // A lattice of step k holds only valid rows and columns when they start at 0 and k is a
  // multiple of both periods.
  const int k = std::lcm(pr.step, pc.step);
  if (pr.first % pr.step == 0 && pc.first % pc.step == 0 && k != s) {
    text += ", or give \"mesh\": {\"pixel_stride\": " + std::to_string(k) + "}";
  }
  return text;
}

/// Why a grid's mesh has hardly any face, if its input is the cause: its lattice points seldom
/// have valid neighbours, or its pixels' rays lie so far apart that even a surface facing the
/// sensor has edges longer than the bound eps_d (a camera much coarser than the presets'). Empty
/// when neither holds: the points themselves (depth steps, noise, surfaces seen edge-on) leave
/// the mesh without faces.
std::string why_no_faces(const OrganizedCloud& points, const MeshSettings& mesh) {
  const int s = std::max(1, mesh.pixel_stride);
  std::size_t lattice_valid = 0, with_cell = 0;
  // Angles between the rays of lattice neighbours (right, down, down-right) and ranges.
  std::array<std::vector<double>, 3> angles;
  std::vector<double> ranges;
  const auto ray_angle = [&](int u0, int v0, int u1, int v1) {
    const double x0 = points.x(u0, v0), y0 = points.y(u0, v0), z0 = points.z(u0, v0);
    const double x1 = points.x(u1, v1), y1 = points.y(u1, v1), z1 = points.z(u1, v1);
    const double cx = y0 * z1 - z0 * y1, cy = z0 * x1 - x0 * z1, cz = x0 * y1 - y0 * x1;
    return std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), x0 * x1 + y0 * y1 + z0 * z1);
  };
  for (int v = 0; v < points.height(); v += s) {
    for (int u = 0; u < points.width(); u += s) {
      if (!points.valid(u, v)) continue;
      ++lattice_valid;
      const double x = points.x(u, v), y = points.y(u, v), z = points.z(u, v);
      ranges.push_back(std::sqrt(x * x + y * y + z * z));
      const bool right = u + s < points.width() && points.valid(u + s, v);
      const bool down = v + s < points.height() && points.valid(u, v + s);
      with_cell += right && down;  // a cell's corners, but for the one across
      if (right) angles[0].push_back(ray_angle(u, v, u + s, v));
      if (down) angles[1].push_back(ray_angle(u, v, u, v + s));
      if (right && down && points.valid(u + s, v + s)) {
        angles[2].push_back(ray_angle(u, v, u + s, v + s));
      }
    }
  }
  if (lattice_valid == 0 || 2 * with_cell < lattice_valid || angles[2].empty()) {
    return sparse_cause(points, s, lattice_valid, with_cell);
  }
  const double r = median(ranges);
  double angle = 0;
  for (std::vector<double>& a : angles) angle = std::max(angle, a.empty() ? 0.0 : median(a));
  const double spacing = r * angle;  // between the points of a surface facing the sensor [m]
  const double bound = mesh.max_edge_a + mesh.max_edge_b * s * r + mesh.max_edge_c * r * r;
  if (!(spacing > bound)) return {};
  // A bound with room for surfaces up to ~50 deg from facing the sensor.
  const double b = (1.5 * spacing - mesh.max_edge_a - mesh.max_edge_c * r * r) / (s * r);
  char text[400];
  std::snprintf(text, sizeof text,
                "neighbouring pixels' rays lie %.3g rad apart (median; diagonal neighbours "
                "included), %.3g m at the median range of %.3g m, beyond the mesh's edge bound "
                "there, %.3g m: a camera much coarser than the preset's. Raise mesh.max_edge_b "
                "(now %.3g m per m of range) to about %.2g",
                angle, spacing, r, bound, static_cast<double>(mesh.max_edge_b), b);
  return text;
}

}  // namespace

std::string Pipeline::why_not_smooth() const {
  // The smooth model admits a point whose curvature is at most max_curvature and whose normal
  // is within max_smooth_angle of its neighbour's; a noisy sensor's 1-ring curvature (a
  // Kinect's: a median of ~130 1/m at 1-2 m) and neighbouring normals may fail either nearly
  // everywhere. Every 2nd point, with its right and lower neighbours.
  const SegmentationSettings& settings = settings_.segmentation;
  const NormalMap& n = normals();
  std::vector<float> curvatures, angles;
  const auto angle = [&](int u0, int v0, int u1, int v1) {
    const double dot = static_cast<double>(n.nx(u0, v0)) * n.nx(u1, v1) +
                       static_cast<double>(n.ny(u0, v0)) * n.ny(u1, v1) +
                       static_cast<double>(n.nz(u0, v0)) * n.nz(u1, v1);
    if (std::isfinite(dot)) {
      angles.push_back(static_cast<float>(std::acos(std::clamp(dot, -1.0, 1.0))));
    }
  };
  for (int v = 0; v + 1 < n.curvature.height(); v += 2) {
    for (int u = 0; u + 1 < n.curvature.width(); u += 2) {
      if (!std::isfinite(n.curvature(u, v))) continue;
      curvatures.push_back(n.curvature(u, v));
      angle(u, v, u + 1, v);
      angle(u, v, u, v + 1);
    }
  }
  if (curvatures.empty()) return {};
  const auto share_above = [](const std::vector<float>& values, double bound) {
    const auto above = std::count_if(values.begin(), values.end(),
                                     [&](float x) { return static_cast<double>(x) > bound; });
    return static_cast<double>(above) /
           static_cast<double>(std::max<std::size_t>(values.size(), 1));
  };
  const double curved = share_above(curvatures, settings.max_curvature);
  const double bent = share_above(angles, settings.max_smooth_angle);
  // Half the points off, or a quarter of the neighbour pairs: growth stalls.
  const bool by_curvature = curved >= 0.5, by_angle = !angles.empty() && bent >= 0.25;
  if (!by_curvature && !by_angle) return {};
  std::string text = "the smooth model's bounds reject most of the points:";
  char part[300];
  if (by_curvature) {
    const double middle = median(curvatures);
    std::snprintf(part, sizeof part,
                  " %.0f %% lie above segmentation.max_curvature = %g 1/m (median %.3g 1/m: the "
                  "depth noise's curvature); raise it to about %.3g (the frame's 90th "
                  "percentile).",
                  100 * curved, settings.max_curvature, middle, quantile(curvatures, 0.9));
    text += part;
  }
  if (by_angle) {
    std::snprintf(part, sizeof part,
                  " %.0f %% of neighbouring normals differ by more than "
                  "segmentation.max_smooth_angle = %.3g rad; raise it to about %.3g (the "
                  "frame's 90th percentile).",
                  100 * bent, settings.max_smooth_angle, quantile(angles, 0.9));
    text += part;
  }
  return text + " Or use the plane or auto model";
}

std::string Pipeline::why_no_segments() const {
  if (!settings_.segment || !segmentation_.segments.empty()) return {};
  const OrganizedCloud& points = cloud();
  // Finite points off the sensor's origin, where many drivers put a pixel without depth.
  std::size_t valid = 0;
  for (int v = 0; v < points.height(); ++v) {
    const float *x = points.x.row(v), *y = points.y.row(v), *z = points.z.row(v);
    for (int u = 0; u < points.width(); ++u) {
      valid += std::isfinite(x[u]) && std::isfinite(y[u]) && std::isfinite(z[u]) &&
               (x[u] != 0 || y[u] != 0 || z[u] != 0);
    }
  }
  if (valid == 0) {
    return "the cloud has no point (every x, y or z is NaN or infinite, or the point is the "
           "sensor's origin)";
  }
  // Last, coordinates at an implausible scale (depth in millimetres read as metres, a float
  // depth of 1e30): the command line and Python say so for a stream's first cloud, a C++
  // caller learns it here.
  const auto scale = [&] { return cloud_scale_problem(points); };
  // The mesh is the last frame's when it was a grid, or an unorganized cloud put back on its
  // pixel grid (whose points are grid_cloud_).
  const OrganizedCloud* grid = points.is_organized() ? &points : nullptr;
  if (grid == nullptr && grid_.found()) grid = &grid_cloud_;
  if (grid == nullptr || mesh_.width() != grid->width() || mesh_.height() != grid->height()) {
    return scale();
  }
  const auto s = static_cast<std::size_t>(std::max(1, mesh_.pixel_stride));
  const std::size_t lattice_points = std::max<std::size_t>(1, valid / (s * s));
  const std::size_t faces = count_faces(mesh_);
  if (10 * faces >= lattice_points) {
    return settings_.segmentation.model == RegionModel::smooth ? why_not_smooth() : scale();
  }
  const std::string cause = why_no_faces(*grid, settings_.mesh);
  if (cause.empty()) return scale();
  return "the mesh joins hardly any of the points (" + std::to_string(faces) + " faces for " +
         std::to_string(valid) + " points): " + cause;
}

}  // namespace rangeseg
