// RegionModel::automatic: plane segmentation, then curved surfaces put back together. The plane
// model cuts a cylinder or sphere into facets (each within k sigma of a plane); adjacent facets
// whose union one cylinder or sphere explains within the sensor noise, with the measured normals
// agreeing with the model's, are merged, and every segment is labelled with the simplest surface
// that explains it.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "detail/headroom.hpp"
#include "detail/primitive_fit.hpp"
#include "rangeseg/primitives.hpp"
#include "segmentation/primitive_internal.hpp"

namespace rangeseg {

const char* to_string(SurfaceKind kind) {
  switch (kind) {
    case SurfaceKind::plane:
      return "plane";
    case SurfaceKind::cylinder:
      return "cylinder";
    case SurfaceKind::sphere:
      return "sphere";
    case SurfaceKind::smooth:
      return "smooth";
  }
  return "unknown";
}

const char* to_string(RegionModel model) {
  switch (model) {
    case RegionModel::plane:
      return "plane";
    case RegionModel::smooth:
      return "smooth";
    case RegionModel::incremental_plane:
      return "incremental_plane";
    case RegionModel::automatic:
      return "auto";
  }
  return "unknown";
}

RegionModel region_model_from_string(std::string_view name) {
  if (name == "plane") return RegionModel::plane;
  if (name == "smooth") return RegionModel::smooth;
  if (name == "incremental_plane" || name == "incremental") return RegionModel::incremental_plane;
  if (name == "auto") return RegionModel::automatic;
  throw std::invalid_argument("unknown model '" + std::string(name) +
                              "' (expected plane, smooth, incremental_plane or auto)");
}

}  // namespace rangeseg

namespace rangeseg::seg {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
/// Points per merge test and per classification of a single segment; enough to tell a
/// cylinder from a sphere from a plane at a few hundred microseconds per test.
constexpr int kTestSample = 250;
/// Points for the reported parameters of a curved segment.
constexpr int kFinalSample = 4000;
/// Levenberg-Marquardt steps per test fit (they converge in 3-6 from the closed-form start).
constexpr int kTestIterations = 8;
/// A curved model explains points when their RMS distance, in units of each point's sigma(z),
/// is at most this (the points are the bilaterally smoothed ones in the pipeline, so their real
/// noise is below sigma; 1.5 leaves room for raw input and the model's own noise mismatch) ...
constexpr double kMaxSurfaceSigmas = 1.5;
/// ... and the mean angle between measured normals and the model's normals is at most this: two
/// planes meeting at a crease can be approximated by a cylinder within the noise when they are
/// far away, but their normals cluster in two directions instead of turning continuously.
/// (Normals of the smoothed Kinect points at 2-3 m scatter by ~15 degrees about the truth.)
constexpr double kMaxMeanNormalAngle = 25.0 * kDeg;
/// Adjacent plane segments are merge candidates when their normals differ by at most this. The
/// plane pieces of a curved surface face the mean direction of their arcs, so two pieces of a
/// half cylinder or hemisphere (the visible part of a ball) differ by up to 90 deg; 80 keeps the
/// right-angle creases of boxes, the commonest adjacent pair, out of the curved fits (those that
/// enter are rejected by the residual and normal tests).
constexpr double kMaxPairAngle = 80.0 * kDeg;
/// Curved models with radii outside this range are planes or noise [m].
constexpr double kMinRadius = 0.01, kMaxRadius = 1.5;
/// ... and so are patches covering less than a ~30 degree arc of their model (Model::spread):
/// a slightly bent board is not a cylinder.
constexpr double kMinSpread = 0.01;
/// A plane explains a segment when its RMS residual is within this many sigma(z); a single
/// segment is relabelled curved only if the curved fit is also this much better than the plane.
constexpr double kPlaneSigmas = 1.0;
constexpr double kCurvedGain = 0.6;
/// Unions of segments whose plane residual is below this many sigma(z) are not tested.
constexpr double kMinCurvatureSigmas = 0.3;

struct Model {
  SurfaceKind kind = SurfaceKind::plane;
  SphereFit sphere;
  CylinderFit cylinder;
  double nrms = INFINITY;          ///< RMS residual / sigma(z) on the sample
  double nrms_but_one = INFINITY;  ///< the same without the sample's largest residual
  double normal_angle = INFINITY;  ///< mean angle between measured and model normals [rad]
  /// 1 - |mean of the model's unit normals at the points|: 0 for a flat patch, 0.011 for a
  /// 30 degree arc of a cylinder, 0.36 for a half cylinder.
  double spread = 0;
  /// Mean angle that the sensor's normal noise alone puts between measured and true normals at
  /// the sample's depths [rad] (0 when the frame's noise was not measured).
  double noise_angle = 0;

  /// Signed distance to the surface and the surface's unit normal direction at p.
  double distance(const Point3& p, Point3* normal) const {
    if (kind == SurfaceKind::sphere) {
      const double dx = p[0] - sphere.centre[0], dy = p[1] - sphere.centre[1],
                   dz = p[2] - sphere.centre[2];
      const double r = std::sqrt(dx * dx + dy * dy + dz * dz);
      if (normal && r > 0) *normal = {dx / r, dy / r, dz / r};
      return r - sphere.radius;
    }
    const auto& a = cylinder.axis;
    const double wx = p[0] - cylinder.axis_point[0], wy = p[1] - cylinder.axis_point[1],
                 wz = p[2] - cylinder.axis_point[2];
    const double t = wx * a[0] + wy * a[1] + wz * a[2];
    const double qx = wx - t * a[0], qy = wy - t * a[1], qz = wz - t * a[2];
    const double r = std::sqrt(qx * qx + qy * qy + qz * qz);
    if (normal && r > 0) *normal = {qx / r, qy / r, qz / r};
    return r - cylinder.radius;
  }
  double radius() const { return kind == SurfaceKind::sphere ? sphere.radius : cylinder.radius; }
};

}  // namespace

/// The primitive pass's buffers, kept in Segmenter::Scratch::primitive across frames.
struct PrimitiveScratch {
  std::vector<std::int32_t> start;   ///< per label: first entry in `pixels`; size labels + 2
  std::vector<std::int32_t> pixels;  ///< lattice pixel indices grouped by label
  std::vector<std::uint64_t> pairs, new_pairs, narrow_pairs, tested_pairs;
  std::vector<std::int32_t> parent, next_member, last_member, group_pixels;
  std::vector<detail::PlaneStats> stats;
  std::vector<Model> models;
  std::vector<Point3> points, normals;
  std::vector<std::int32_t> queue, remap, order, row_pixels;
  std::vector<std::uint8_t> queued, changed, final_changed;
  std::vector<std::uint8_t> round_grown;  ///< per group: grew in this re-assignment round
  std::vector<std::int32_t> grown;  ///< per group: the last merge pass in which it grew, or -1
  std::vector<std::int32_t> grown_roots;  ///< groups joined after re-assignment, this round
  std::vector<Segment> segments;
  detail::PrimitiveFitBuffers fits;
};

void PrimitiveScratchDeleter::operator()(PrimitiveScratch* p) const { delete p; }

namespace {

using Scratch = PrimitiveScratch;

class PrimitivePass {
 public:
  PrimitivePass(const Frame& f, const SegmentationSettings& settings, Segmentation& out, Scratch& s,
                const PrimitiveContext& context)
      : f_(f),
        settings_(settings),
        out_(out),
        s_(s),
        n_(static_cast<std::int32_t>(out.segments.size())),
        tentative_from_(context.tentative_from),
        normal_noise_c_(context.normal_noise_c),
        segment_stats_(context.segment_stats) {}

  void run() {
    if (n_ == 0) return;
    group_pixels_by_label();
    collect_adjacent_pairs();
    init_groups();
    // Each pass after the first retests only the pairs with a side grown since its last test;
    // a pass without a join ends it (every join removes a group, so this terminates).
    int pass = 0;
    while (merge_pairs(pass) > 0) ++pass;
    // Facets too narrow to be told from a plane in pairs, then in threes, until nothing joins.
    while (join_narrow_triples(pass + 1) > 0) {
      pass += 1;
      while (merge_pairs(pass) > 0) ++pass;
    }
    classify_groups();
    release_dropped();
    // Re-assigned points can make a curved group the neighbour of a facet or group it was not
    // adjacent to; each round that joins one re-assigns again around the joined group.
    do {
      reassign_to_curved();
    } while (join_reassigned_neighbours() > 0);
    relabel();
  }

 private:
  double sigma(double z) const { return settings_.noise.sigma(z); }
  double depth(const Point3& p) const { return noise_depth(p, f_.ring_neighbours != nullptr); }
  template <class Fn>
  void for_each_neighbour(std::ptrdiff_t i, bool forward, Fn&& fn) const {
    seg::for_each_neighbour(f_, i, forward ? 0x05u : 0xFFu, fn);
  }

  void group_pixels_by_label() {
    s_.start.assign(static_cast<std::size_t>(n_) + 2, 0);
    const int step = f_.pixel_stride;
    // Calls fn(label, first pixel, pixel count) for the runs of equal labels along each lattice
    // row: a count or a block of consecutive slots per run instead of a dependent update of the
    // same counter per pixel.
    const auto for_each_run = [&](auto&& fn) {
      for (int v = 0; v < f_.height; v += step) {
        const std::ptrdiff_t row = v * f_.stride;
        const std::int32_t* const labels = f_.labels + row;
        for (int u = 0; u < f_.width;) {
          const std::int32_t l = labels[u];
          const int first = u;
          do {
            u += step;
          } while (u < f_.width && labels[u] == l);
          fn(l, row + first, (u - first + step - 1) / step);
        }
      }
    };
    for_each_run([&](std::int32_t l, std::ptrdiff_t, int n) {
      s_.start[static_cast<std::size_t>(l) + 1] += n;
    });
    // start[l] = first slot of label l (label 0 included, then ignored).
    std::int32_t total = 0;
    for (std::size_t l = 0; l <= static_cast<std::size_t>(n_); ++l) {
      const std::int32_t c = s_.start[l + 1];
      s_.start[l + 1] = total;
      total += c;
    }
    s_.pixels.resize(static_cast<std::size_t>(total));
    for_each_run([&](std::int32_t l, std::ptrdiff_t i, int n) {
      std::int32_t& next = s_.start[static_cast<std::size_t>(l) + 1];
      std::int32_t* const out = s_.pixels.data() + next;
      for (int j = 0; j < n; ++j) out[j] = static_cast<std::int32_t>(i + std::ptrdiff_t{j} * step);
      next += n;
    });
    // Now start[l + 1] is the end of label l, i.e. start[l] is the beginning of label l.
  }
  std::int32_t begin(std::int32_t l) const { return s_.start[static_cast<std::size_t>(l)]; }
  std::int32_t end(std::int32_t l) const { return s_.start[static_cast<std::size_t>(l) + 1]; }

  void collect_adjacent_pairs() {
    s_.pairs.clear();
    std::uint64_t last = 0;
    const int step = f_.pixel_stride;
    // On the grid, right and down neighbours: 4-connected adjacency suffices to find the
    // facets of one surface and halves the work.
    const auto visit = [&](std::ptrdiff_t i) {
      const std::int32_t a = f_.labels[i];
      if (a == 0) return;
      for_each_neighbour(i, true, [&](std::ptrdiff_t q) {
        const std::int32_t b = f_.labels[q];
        if (b == 0 || b == a) return;
        const std::uint64_t key = (static_cast<std::uint64_t>(std::min(a, b)) << 32) |
                                  static_cast<std::uint32_t>(std::max(a, b));
        if (key != last) s_.pairs.push_back(key);
        last = key;
      });
    };
    // At stride 1 the inner rows are screened a vector at a time: only a pixel whose label
    // differs from a forward neighbour's can add a pair.
    const bool screen = step == 1 && f_.width > 2 && f_.ring_neighbours == nullptr;
    if (screen) s_.row_pixels.resize(static_cast<std::size_t>(f_.width));
    for (int v = 0; v < f_.height; v += step) {
      const std::ptrdiff_t row = v * f_.stride;
      int u = 0;
      if (screen && v + 1 < f_.height) {
        visit(row);
        int found = 0;
        u = adjacency_pixels(f_.labels + row, f_.labels + row + f_.stride, 1, f_.width - 1,
                             s_.row_pixels.data(), found);
        for (int j = 0; j < found; ++j) visit(row + s_.row_pixels[static_cast<std::size_t>(j)]);
      }
      for (; u < f_.width; u += step) visit(row + u);
    }
    if (f_.columns_wrap) {
      const int last = last_lattice_column(f_);
      for (int v = 0; v < f_.height; v += step) {
        const std::ptrdiff_t row = v * f_.stride;
        const std::int32_t a = f_.labels[row + last], b = f_.labels[row];
        if (a == 0 || b == 0 || a == b || !column_seam_linked(f_, row + last, row)) continue;
        s_.pairs.push_back((static_cast<std::uint64_t>(std::min(a, b)) << 32) |
                           static_cast<std::uint32_t>(std::max(a, b)));
      }
    }
    std::sort(s_.pairs.begin(), s_.pairs.end());
    s_.pairs.erase(std::unique(s_.pairs.begin(), s_.pairs.end()), s_.pairs.end());
  }

  void init_groups() {
    const auto size = static_cast<std::size_t>(n_) + 1;
    // Sized by the frame's segments: with headroom, so that a stream settles.
    detail::resize_with_headroom(s_.parent, size);
    std::iota(s_.parent.begin(), s_.parent.end(), 0);
    detail::assign_with_headroom(s_.next_member, size, 0);
    detail::resize_with_headroom(s_.last_member, size);
    std::iota(s_.last_member.begin(), s_.last_member.end(), 0);
    detail::assign_with_headroom(s_.group_pixels, size, 0);
    detail::assign_with_headroom(s_.stats, size, detail::PlaneStats{});
    detail::assign_with_headroom(s_.changed, size, 0);
    detail::assign_with_headroom(s_.grown, size, -1);
    s_.narrow_pairs.clear();
    detail::assign_with_headroom(s_.models, size, Model{});
    for (std::int32_t l = 1; l <= n_; ++l) s_.group_pixels[l] = end(l) - begin(l);
  }

  /// Plane statistics of a segment that is still its own group, computed when first needed.
  const detail::PlaneStats& stats_of(std::int32_t root) {
    detail::PlaneStats& st = s_.stats[root];
    if (st.count == 0 && static_cast<std::size_t>(root) <= segment_stats_.size()) {
      st = segment_stats_[static_cast<std::size_t>(root) - 1];
    }
    if (st.count == 0) {
      for (std::int32_t j = begin(root); j < end(root); ++j) {
        const std::int32_t i = s_.pixels[static_cast<std::size_t>(j)];
        st.add(f_.x[i], f_.y[i], f_.z[i]);
      }
    }
    return st;
  }

  /// Every k-th point (and normal) of a group's member segments, about max_points in all.
  void gather(std::int32_t root, int max_points) {
    s_.points.clear();
    s_.normals.clear();
    const std::int64_t total = s_.group_pixels[root];
    const std::int64_t step = std::max<std::int64_t>(1, (total + max_points - 1) / max_points);
    std::int64_t phase = 0;
    for (std::int32_t l = root; l != 0; l = s_.next_member[l]) {
      std::int32_t j = begin(l) + static_cast<std::int32_t>(phase);
      for (; j < end(l); j += static_cast<std::int32_t>(step)) {
        const std::int32_t i = s_.pixels[static_cast<std::size_t>(j)];
        s_.points.push_back({f_.x[i], f_.y[i], f_.z[i]});
        s_.normals.push_back({f_.nx[i], f_.ny[i], f_.nz[i]});
      }
      phase = j - end(l);
    }
  }

  /// RMS residual in units of sigma(z) and mean normal angle of a model on the gathered sample.
  void score(Model& m) const {
    double sum = 0, largest = 0, angle = 0;
    double mx = 0, my = 0, mz = 0;
    int angles = 0;
    for (std::size_t j = 0; j < s_.points.size(); ++j) {
      const Point3& p = s_.points[j];
      Point3 normal{};
      const double d = m.distance(p, &normal) / sigma(depth(p));
      sum += d * d;
      largest = std::max(largest, d * d);
      mx += normal[0];
      my += normal[1];
      mz += normal[2];
      const Point3& n = s_.normals[j];
      const double c = std::fabs(n[0] * normal[0] + n[1] * normal[1] + n[2] * normal[2]);
      if (std::isfinite(c)) {
        angle += std::acos(std::min(c, 1.0));
        ++angles;
      }
    }
    m.nrms = std::sqrt(sum / static_cast<double>(std::max<std::size_t>(1, s_.points.size())));
    m.nrms_but_one =
        s_.points.size() > 1
            ? std::sqrt(std::max(0.0, sum - largest) / static_cast<double>(s_.points.size() - 1))
            : m.nrms;
    m.normal_angle = angles > 0 ? angle / angles : INFINITY;
    const double count = static_cast<double>(std::max<std::size_t>(1, s_.points.size()));
    m.spread = 1.0 - std::sqrt(mx * mx + my * my + mz * mz) / count;
    // Per-axis spread s = sigma_n(z) makes the angle Rayleigh distributed, mean s sqrt(pi / 2).
    double noise = 0;
    for (const Point3& p : s_.points) noise += sigma(depth(p)) / depth(p);
    m.noise_angle = std::sqrt(std::numbers::pi / 2) * normal_noise_c_ * noise / count;
  }

  double plane_nrms(const detail::PlaneStats& stats) const {
    const detail::PlaneFit fit = stats.fit();
    if (!fit.ok) return INFINITY;
    double sum = 0;
    for (const Point3& p : s_.points) {
      const double d = fit.distance(p[0], p[1], p[2]) / sigma(depth(p));
      sum += d * d;
    }
    return std::sqrt(sum / static_cast<double>(std::max<std::size_t>(1, s_.points.size())));
  }

  /// `noise_aware`: the mean normal angle may exceed kMaxMeanNormalAngle by what the normal
  /// noise adds (in quadrature), for patches the plane model left (see classify_groups).
  static bool plausible(const Model& m, bool need_spread = true, bool noise_aware = false) {
    const double max_angle =
        noise_aware ? std::hypot(kMaxMeanNormalAngle, m.noise_angle) : kMaxMeanNormalAngle;
    return m.nrms <= kMaxSurfaceSigmas && m.normal_angle <= max_angle && m.radius() >= kMinRadius &&
           m.radius() <= kMaxRadius && (!need_spread || m.spread >= kMinSpread);
  }

  /// The better of sphere and cylinder on the gathered sample (the sphere, with one parameter
  /// fewer, unless the cylinder is clearly better).
  Model fit_curved(int iterations, bool* narrow = nullptr, bool noise_aware = false) const {
    // Plain least squares for the many candidate tests; the reported fit drops outliers.
    const PrimitiveFitSettings fs{.max_iterations = iterations, .outlier_refits = 0};
    Model sphere, cylinder;
    sphere.kind = SurfaceKind::sphere;
    sphere.sphere = detail::fit_sphere(s_.points, s_.normals, fs, s_.fits);
    if (sphere.sphere.ok) score(sphere);
    cylinder.kind = SurfaceKind::cylinder;
    cylinder.cylinder = detail::fit_cylinder(s_.points, s_.normals, fs, s_.fits);
    if (cylinder.cylinder.ok) score(cylinder);
    const bool sphere_ok = sphere.sphere.ok && plausible(sphere, true, noise_aware);
    const bool cylinder_ok = cylinder.cylinder.ok && plausible(cylinder, true, noise_aware);
    if (sphere_ok && (!cylinder_ok || sphere.nrms <= 1.1 * cylinder.nrms)) return sphere;
    if (cylinder_ok) return cylinder;
    if (narrow != nullptr) {
      // Nothing curved fits, or a model fits but covers too short an arc to tell.
      *narrow = (sphere.sphere.ok && plausible(sphere, false)) ||
                (cylinder.cylinder.ok && plausible(cylinder, false));
    }
    return Model{};  // kind plane: nothing curved fits
  }

  static double normal_angle(const Segment& a, const Segment& b) {
    const double c = std::fabs(a.normal[0] * b.normal[0] + a.normal[1] * b.normal[1] +
                               a.normal[2] * b.normal[2]);
    return std::acos(std::min(c, 1.0));
  }

  /// Adjacent groups join when a sphere or cylinder explains their union; returns how many
  /// joined. One pass visits the pairs in label order, so a pair tested before either side grew
  /// is tested again in the next pass (a cylinder whose middle facet joined one neighbour first,
  /// then the other). Two narrow facets of a low-noise cylinder cover too short an arc to tell
  /// a cylinder from a plane (kMinSpread), so such a surface is put together from its wider
  /// parts outwards, over as many passes as that takes. Pass 0 tests every pair, pass p > 0
  /// those with a side grown in pass p - 1 or p.
  int merge_pairs(int pass) {
    int joined = 0;
    for (const std::uint64_t key : s_.pairs) {
      const auto la = static_cast<std::int32_t>(key >> 32);
      const auto lb = static_cast<std::int32_t>(key & 0xFFFFFFFFu);
      const std::int32_t a = find_root(s_.parent, la), b = find_root(s_.parent, lb);
      if (a == b || (pass > 0 && s_.grown[a] < pass - 1 && s_.grown[b] < pass - 1)) continue;
      if (!try_join(la, lb, true)) continue;
      s_.grown[a] = pass;
      ++joined;
    }
    return joined;
  }

  /// Joins the groups of the adjacent segments la and lb (into la's) when a sphere or cylinder
  /// explains their union; the group's model is then that test fit. `facet_angle`: only if
  /// the two segments' planes are at most kMaxPairAngle apart.
  bool try_join(std::int32_t la, std::int32_t lb, bool facet_angle) {
    const std::int32_t a = find_root(s_.parent, la), b = find_root(s_.parent, lb);
    if (a == b) return false;
    if (facet_angle && normal_angle(out_.segments[la - 1], out_.segments[lb - 1]) > kMaxPairAngle) {
      return false;
    }
    detail::PlaneStats merged = stats_of(a);
    merged.merge(stats_of(b));
    const Link link = link_union(a, b);
    gather(a, kTestSample);
    const double union_plane = plane_nrms(merged);
    Model model;
    // A union that is flat within a fraction of the noise is post-processing's business,
    // unless its facets face directions too far apart for merging to join them as one plane
    // (a small, far cylinder: two facets 30 deg apart sag by less than the noise).
    if (union_plane > kMinCurvatureSigmas ||
        normal_angle(out_.segments[la - 1], out_.segments[lb - 1]) >
            settings_.merge_rms_max_angle) {
      bool narrow = false;
      model = fit_curved(kTestIterations, &narrow);
      // Tentative patches are no plane facets: triples are for facets too narrow to tell.
      if (narrow && facet_angle && std::max(la, lb) <= tentative_from_) {
        s_.narrow_pairs.push_back((static_cast<std::uint64_t>(la) << 32) |
                                  static_cast<std::uint32_t>(lb));
      }
    }
    // The curved model must explain the union clearly better than one plane does.
    const bool accept = model.kind != SurfaceKind::plane && model.nrms <= kCurvedGain * union_plane;
    const bool both_curved =
        s_.models[a].kind != SurfaceKind::plane && s_.models[b].kind != SurfaceKind::plane;
    if (!accept || !fits_like_parts(model, part_residual(a), part_residual(b), both_curved)) {
      unlink_union(a, link);
      return false;
    }
    s_.last_member[a] = s_.last_member[b];
    s_.parent[b] = a;
    s_.models[a] = model;
    s_.changed[a] = 1;
    s_.stats[a] = merged;
    return true;
  }

  /// Pairs of plane facets that one curved model explains, but over too short an arc to tell
  /// it from a plane (kMinSpread; the facets of a cylinder seen with little noise, ~10 deg
  /// each), are tested again with a third facet next to either: three facets cover the arc.
  /// The union must pass the pair test's residual tests. Joined groups are marked grown in
  /// `pass`; returns how many triples joined.
  int join_narrow_triples(int pass) {
    auto& pairs = s_.narrow_pairs;
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    // Copied, not swapped: each buffer keeps the capacity of its own role, so that a frame with
    // no more pairs than an earlier one allocates nothing, in whichever order frames come.
    s_.tested_pairs.assign(pairs.begin(), pairs.end());
    pairs.clear();
    int joined = 0;
    for (const std::uint64_t key : s_.tested_pairs) {
      const auto la = static_cast<std::int32_t>(key >> 32);
      const auto lb = static_cast<std::int32_t>(key & 0xFFFFFFFFu);
      for (const std::uint64_t other : s_.pairs) {
        const auto l0 = static_cast<std::int32_t>(other >> 32);
        const auto l1 = static_cast<std::int32_t>(other & 0xFFFFFFFFu);
        if (l0 != la && l0 != lb && l1 != la && l1 != lb) continue;
        const std::int32_t lc = l0 == la || l0 == lb ? l1 : l0;
        if (lc > tentative_from_) continue;
        if (try_join_three(la, lb, lc)) {
          s_.grown[find_root(s_.parent, la)] = pass;
          ++joined;
          break;
        }
      }
    }
    return joined;
  }

  bool try_join_three(std::int32_t la, std::int32_t lb, std::int32_t lc) {
    const std::int32_t a = find_root(s_.parent, la), b = find_root(s_.parent, lb),
                       c = find_root(s_.parent, lc);
    if (a == b || a == c || b == c) return false;
    for (const std::int32_t g : {a, b, c}) {
      if (s_.models[g].kind != SurfaceKind::plane) return false;
    }
    if (normal_angle(out_.segments[la - 1], out_.segments[lc - 1]) > kMaxPairAngle ||
        normal_angle(out_.segments[lb - 1], out_.segments[lc - 1]) > kMaxPairAngle) {
      return false;
    }
    detail::PlaneStats merged = stats_of(a);
    merged.merge(stats_of(b));
    merged.merge(stats_of(c));
    const std::int32_t a_last = s_.last_member[a], b_last = s_.last_member[b];
    const std::int32_t a_pixels = s_.group_pixels[a];
    s_.next_member[a_last] = b;
    s_.next_member[b_last] = c;
    s_.group_pixels[a] += s_.group_pixels[b] + s_.group_pixels[c];
    gather(a, kTestSample);
    const double union_plane = plane_nrms(merged);
    const Model model = fit_curved(kTestIterations);
    const double parts = std::min({part_residual(a), part_residual(b), part_residual(c)});
    if (model.kind == SurfaceKind::plane || !(model.nrms <= kCurvedGain * union_plane) ||
        !fits_like_parts(model, parts, parts)) {
      s_.next_member[a_last] = 0;
      s_.next_member[b_last] = 0;
      s_.group_pixels[a] = a_pixels;
      return false;
    }
    s_.last_member[a] = s_.last_member[c];
    s_.parent[b] = a;
    s_.parent[c] = a;
    s_.models[a] = model;
    s_.changed[a] = 1;
    s_.stats[a] = merged;
    return true;
  }

  /// A part's plane residual is its noise plus its curvature, so a model of the true surface
  /// fits the union about as well as the flatter part's plane (or curved model; residuals `pa`,
  /// `pb` in units of sigma): a cylinder bent over a crease between two planes (each fitting
  /// its plane at the noise level) does not.
  /// `but_one`: two groups that are curved already (no crease between plane facets to guard
  /// against) may have one point of the union's sample off their common surface: a noise-free
  /// cylinder's rim point that smoothing pulled 3 sigma towards its lid, in a part whose sample
  /// missed it, lifted the union's RMS from 0 to 0.2 sigma and kept the cylinder in two halves
  /// (`curved_scene` over rings).
  static bool fits_like_parts(const Model& model, double pa, double pb, bool but_one = false) {
    return (but_one ? model.nrms_but_one : model.nrms) <= 1.5 * std::min(pa, pb) + 0.15;
  }

  /// Where group a's member list ended and its pixel count, before link_union.
  struct Link {
    std::int32_t a_last, a_pixels;
  };
  /// Links b's members after a's (temporarily, to sample the union with `gather`).
  Link link_union(std::int32_t a, std::int32_t b) {
    const Link link{s_.last_member[a], s_.group_pixels[a]};
    s_.next_member[link.a_last] = b;
    s_.group_pixels[a] += s_.group_pixels[b];
    return link;
  }
  void unlink_union(std::int32_t a, const Link& link) {
    s_.next_member[link.a_last] = 0;
    s_.group_pixels[a] = link.a_pixels;
  }

  /// The reported parameters of a curved group: its model's kind fitted again to a larger
  /// sample. False (and `m` unchanged) when that fit fails.
  bool fit_final(std::int32_t root, Model& m) {
    gather(root, kFinalSample);
    Model final_model;
    final_model.kind = m.kind;
    if (m.kind == SurfaceKind::sphere) {
      final_model.sphere = detail::fit_sphere(s_.points, s_.normals, {}, s_.fits);
      if (!final_model.sphere.ok) return false;
    } else {
      final_model.cylinder = detail::fit_cylinder(s_.points, s_.normals, {}, s_.fits);
      if (!final_model.cylinder.ok) return false;
    }
    score(final_model);
    m = final_model;
    return true;
  }

  /// The residual of a group in units of sigma: its curved model's, else its plane's.
  double part_residual(std::int32_t root) {
    if (s_.models[root].kind != SurfaceKind::plane) return s_.models[root].nrms;
    const detail::PlaneFit fit = stats_of(root).fit();
    if (!fit.ok) return INFINITY;
    return fit.rms / sigma(depth(fit.centroid));
  }

  void classify_groups() {
    for (std::int32_t l = 1; l <= n_; ++l) {
      if (s_.parent[l] != l) continue;
      Model& m = s_.models[l];
      if (m.kind == SurfaceKind::plane) {
        // A single facet: curved only if a plane does not explain it and a curved model does,
        // much better.
        const Segment& seg = out_.segments[static_cast<std::size_t>(l - 1)];
        // A tentative patch is one the plane model did not grow: tested as curved even where a
        // plane explains it within the noise.
        const bool tentative = l > tentative_from_;
        if (!tentative && seg.rms_residual <= kPlaneSigmas * sigma(depth(seg.centroid))) continue;
        gather(l, kTestSample);
        const double plane = plane_nrms(stats_of(l));
        if (!tentative && plane <= kPlaneSigmas) continue;
        Model curved = fit_curved(kTestIterations, nullptr, tentative);
        if (curved.kind == SurfaceKind::plane || curved.nrms > kCurvedGain * plane) continue;
        m = curved;
      }
      fit_final(l, m);
    }
  }

  /// Unlabelled points next to a curved segment join it when within k sigma(z) of its surface
  /// (the plane model's boundary re-assignment measured them against the facets' planes).
  void reassign_to_curved() {
    const std::size_t pixels = static_cast<std::size_t>(f_.stride) * f_.height;
    s_.queued.assign(pixels, 0);
    s_.queue.clear();
    s_.new_pairs.clear();
    const auto curved_root = [&](std::int32_t label) {
      if (label == 0) return 0;
      const std::int32_t r = find_root(s_.parent, label);
      return s_.models[r].kind != SurfaceKind::plane ? r : 0;
    };
    bool any_curved = false;
    for (std::int32_t l = 1; l <= n_ && !any_curved; ++l) {
      any_curved = s_.parent[l] == l && s_.models[l].kind != SurfaceKind::plane;
    }
    if (!any_curved) return;
    const auto push_unlabelled_neighbours = [&](std::ptrdiff_t i) {
      for_each_neighbour(i, false, [&](std::ptrdiff_t q) {
        if (f_.labels[q] == 0 && !s_.queued[q] && std::isfinite(f_.z[q])) {
          s_.queued[q] = 1;
          s_.queue.push_back(static_cast<std::int32_t>(q));
        }
      });
    };
    for (std::int32_t l = 1; l <= n_; ++l) {
      if (curved_root(l) == 0) continue;
      for (std::int32_t j = begin(l); j < end(l); ++j) {
        push_unlabelled_neighbours(s_.pixels[static_cast<std::size_t>(j)]);
      }
    }
    const double k = settings_.max_distance_sigmas;
    for (std::size_t head = 0; head < s_.queue.size(); ++head) {
      const std::int32_t q = s_.queue[head];
      const Point3 p{f_.x[q], f_.y[q], f_.z[q]};
      double best_distance = k * sigma(depth(p));
      std::int32_t best = 0;
      for_each_neighbour(q, false, [&](std::ptrdiff_t o) {
        const std::int32_t label = f_.labels[o];
        const std::int32_t r = curved_root(label);
        if (r == 0) return;
        const double d = std::fabs(s_.models[r].distance(p, nullptr));
        if (d <= best_distance) {
          best_distance = d;
          best = label;
        }
      });
      if (best == 0) continue;
      f_.labels[q] = best;
      ++reassigned_;
      const std::int32_t root = find_root(s_.parent, best);
      note_new_neighbours(q, root);
      s_.group_pixels[root] += 1;
      s_.changed[root] = 1;
      push_unlabelled_neighbours(q);
    }
  }

  /// Records the pairs of group `root` (curved, which point q just joined) and the other groups
  /// among q's mesh neighbours.
  void note_new_neighbours(std::int32_t q, std::int32_t root) {
    for_each_neighbour(q, false, [&](std::ptrdiff_t o) {
      const std::int32_t other = f_.labels[o];
      if (other == 0) return;
      const std::int32_t other_root = find_root(s_.parent, other);
      if (other_root == root) return;
      s_.new_pairs.push_back((static_cast<std::uint64_t>(root) << 32) |
                             static_cast<std::uint32_t>(other_root));
    });
  }

  /// The pairs that re-assigned points made adjacent are tested as merge_pairs tests pairs, and
  /// a group that grows gets its reported fit (classify_groups); returns how many joined. The
  /// facets of a cylinder seen with little noise can be separated from the rest of it by a
  /// column of points that no facet's plane took, and only become its neighbours here. The
  /// pairs are of groups, not of two facets, so the facet angle gate does not apply.
  int join_reassigned_neighbours() {
    auto& pairs = s_.new_pairs;
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    int joined = 0;
    s_.grown_roots.clear();
    for (const std::uint64_t key : pairs) {
      // Groups recorded as roots; either may have joined another since.
      const std::int32_t a = find_root(s_.parent, static_cast<std::int32_t>(key >> 32));
      const std::int32_t b = find_root(s_.parent, static_cast<std::int32_t>(key & 0xFFFFFFFFu));
      if (!near_curved_model(a, b) || !try_join(a, b, false)) continue;
      s_.grown_roots.push_back(a);
      ++joined;
    }
    if (joined > 0) joined += join_grown_facet_pairs();
    // The reported fit once per grown group (the tests above use the test fits).
    std::sort(s_.grown_roots.begin(), s_.grown_roots.end());
    for (std::size_t j = 0; j < s_.grown_roots.size(); ++j) {
      const std::int32_t a = s_.grown_roots[j];
      if ((j > 0 && a == s_.grown_roots[j - 1]) || s_.parent[a] != a) continue;
      fit_final(a, s_.models[a]);
    }
    return joined;
  }

  /// The facet pairs (merge_pairs') across which a group grown in this round meets another
  /// group are tested again, until none joins: two curved groups that each grew by re-assigned
  /// neighbours can now cover adjacent arcs of one cylinder, and the merge passes are over
  /// (noise-free mixed scene 3 with `--preset ideal`: one cylinder in halves of 2594 and
  /// 2138 px, radius exact in both). Returns how many joined.
  int join_grown_facet_pairs() {
    detail::assign_with_headroom(s_.round_grown, s_.parent.size(), 0);
    for (const std::int32_t r : s_.grown_roots) s_.round_grown[static_cast<std::size_t>(r)] = 1;
    int joined = 0;
    for (int added = 1; added > 0;) {
      added = 0;
      for (const std::uint64_t key : s_.pairs) {
        auto la = static_cast<std::int32_t>(key >> 32);
        auto lb = static_cast<std::int32_t>(key & 0xFFFFFFFFu);
        std::int32_t a = find_root(s_.parent, la), b = find_root(s_.parent, lb);
        if (a == b || (!s_.round_grown[a] && !s_.round_grown[b])) continue;
        if (!s_.round_grown[a]) {
          std::swap(a, b);
          std::swap(la, lb);
        }
        if (!near_curved_model(a, b) || !try_join(la, lb, true)) continue;
        s_.round_grown[a] = 1;
        s_.grown_roots.push_back(a);
        ++added;
      }
      joined += added;
    }
    return joined;
  }

  /// Whether group b's points are worth a union fit with the curved group a (the one a
  /// re-assigned point joined): their RMS distance to a's model within twice the re-assignment
  /// bound, k sigma(z). The model was fitted to a alone and is extrapolated across the gap (the
  /// two halves of a mug: 4.0 sigma; the joins measured on the synthetic and real inputs: at
  /// most 4.4), while the table or wall beside a curved object lies tens of sigma off it.
  bool near_curved_model(std::int32_t a, std::int32_t b) {
    if (a == b || s_.models[a].kind == SurfaceKind::plane) return false;
    gather(b, kTestSample);
    Model model = s_.models[a];
    score(model);
    return model.nrms <= 2.0 * settings_.max_distance_sigmas;
  }

  /// A group of tentative segments only, that no curved surface explains.
  bool dropped(std::int32_t root) const {
    if (s_.models[root].kind != SurfaceKind::plane) return false;
    for (std::int32_t l = root; l != 0; l = s_.next_member[l]) {
      if (l <= tentative_from_) return false;
    }
    return true;
  }

  /// Unlabels the points of dropped groups, so that re-assignment can give them to a curved
  /// neighbour.
  void release_dropped() {
    for (std::int32_t l = tentative_from_ + 1; l <= n_; ++l) {
      if (s_.parent[l] != l || !dropped(l)) continue;
      for (std::int32_t m = l; m != 0; m = s_.next_member[m]) {
        for (std::int32_t j = begin(m); j < end(m); ++j) f_.labels[s_.pixels[j]] = 0;
      }
      s_.group_pixels[l] = 0;
    }
  }

  void relabel() {
    // Groups by size, descending (ties by old label), as post-processing orders segments.
    s_.order.clear();
    for (std::int32_t l = 1; l <= n_; ++l) {
      if (s_.parent[l] == l && !dropped(l)) s_.order.push_back(l);
    }
    std::sort(s_.order.begin(), s_.order.end(), [&](std::int32_t a, std::int32_t b) {
      const auto ca = s_.group_pixels[a], cb = s_.group_pixels[b];
      return ca != cb ? ca > cb : a < b;
    });
    detail::assign_with_headroom(s_.remap, static_cast<std::size_t>(n_) + 1, 0);
    for (std::size_t j = 0; j < s_.order.size(); ++j) {
      s_.remap[s_.order[j]] = static_cast<std::int32_t>(j + 1);
    }
    for (std::int32_t l = 1; l <= n_; ++l) s_.remap[l] = s_.remap[find_root(s_.parent, l)];
    const int step = f_.pixel_stride;
    // Plane statistics of the changed segments (merged, or with re-assigned points).
    const std::size_t m = s_.order.size();
    detail::assign_with_headroom(s_.final_changed, m + 1, 0);
    for (std::size_t j = 0; j < m; ++j) s_.final_changed[j + 1] = s_.changed[s_.order[j]];
    detail::assign_with_headroom(s_.stats, m + 1, detail::PlaneStats{});
    // The labels stay as they are only when no group was joined or dropped, no point moved and
    // the order by size is the old one: a tentative patch, labelled after every plane
    // segment, may be larger than some of them.
    bool identity = m == static_cast<std::size_t>(n_) && reassigned_ == 0;
    for (std::int32_t l = 1; l <= n_ && identity; ++l) identity = s_.remap[l] == l;
    for (int v = 0; v < f_.height && !identity; v += step) {
      const std::ptrdiff_t row = v * f_.stride;
      for (int u = 0; u < f_.width; u += step) {
        std::int32_t& label = f_.labels[row + u];
        if (label == 0) continue;
        label = s_.remap[label];
        if (s_.final_changed[label]) {
          s_.stats[label].add(f_.x[row + u], f_.y[row + u], f_.z[row + u]);
        }
      }
    }
    s_.segments.resize(m);
    for (std::size_t j = 0; j < m; ++j) {
      const std::int32_t root = s_.order[j];
      Segment seg = out_.segments[root - 1];
      if (s_.final_changed[j + 1]) {
        double area = 0;
        for (std::int32_t l = root; l != 0; l = s_.next_member[l]) {
          area += out_.segments[l - 1].area_m2;
          seg.grazing = seg.grazing || out_.segments[l - 1].grazing;
        }
        set_plane_fields(s_.stats[j + 1], seg);
        seg.area_m2 = area;
      }
      seg.label = static_cast<int>(j + 1);
      const Model& model = s_.models[root];
      seg.kind = model.kind;
      seg.model = model.kind == SurfaceKind::plane ? RegionModel::plane : RegionModel::automatic;
      seg.surface_rms = seg.rms_residual;
      if (model.kind == SurfaceKind::sphere) {
        seg.centre = model.sphere.centre;
        seg.radius = model.sphere.radius;
        seg.surface_rms = model.sphere.rms;
      } else if (model.kind == SurfaceKind::cylinder) {
        seg.centre = model.cylinder.axis_point;
        seg.axis = model.cylinder.axis;
        seg.radius = model.cylinder.radius;
        seg.extent = model.cylinder.extent;
        seg.surface_rms = model.cylinder.rms;
      }
      s_.segments[j] = seg;
    }
    // The two lists trade places every frame: each keeps the larger capacity, so that a frame
    // with more segments than the last one in its role does not allocate once a stream has run.
    const std::size_t capacity = std::max(out_.segments.capacity(), s_.segments.capacity());
    out_.segments.swap(s_.segments);
    out_.segments.reserve(capacity);
    s_.segments.reserve(capacity);
  }

  const Frame& f_;
  const SegmentationSettings& settings_;
  Segmentation& out_;
  Scratch& s_;
  std::int32_t n_;
  std::int32_t tentative_from_;  ///< labels above it are tentative
  double normal_noise_c_;
  std::span<const detail::PlaneStats> segment_stats_;
  std::int64_t reassigned_ = 0;
};

}  // namespace

void fit_primitives(const Frame& frame, const SegmentationSettings& settings, Segmentation& out,
                    PrimitiveScratchPtr& scratch, const PrimitiveContext& context) {
  if (!scratch) scratch.reset(new PrimitiveScratch);
  PrimitivePass(frame, settings, out, *scratch, context).run();
}

}  // namespace rangeseg::seg
