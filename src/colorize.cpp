#include "rangeseg/colorize.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace rangeseg {
namespace {

std::array<std::uint8_t, 3> hsv_to_rgb(double hue, double saturation, double value) {
  const double h = (hue - std::floor(hue)) * 6.0;
  const int sector = static_cast<int>(h) % 6;
  const double f = h - std::floor(h);
  const double p = value * (1 - saturation);
  const double q = value * (1 - saturation * f);
  const double t = value * (1 - saturation * (1 - f));
  double r = 0, g = 0, b = 0;
  switch (sector) {
    case 0:
      r = value, g = t, b = p;
      break;
    case 1:
      r = q, g = value, b = p;
      break;
    case 2:
      r = p, g = value, b = t;
      break;
    case 3:
      r = p, g = q, b = value;
      break;
    case 4:
      r = t, g = p, b = value;
      break;
    default:
      r = value, g = p, b = q;
      break;
  }
  const auto byte = [](double c) {
    return static_cast<std::uint8_t>(std::clamp(std::lround(c * 255.0), 0L, 255L));
  };
  return {byte(r), byte(g), byte(b)};
}

void require_same_size(View<const float> a, View<const float> b, const char* what) {
  if (a.width != b.width || a.height != b.height) {
    throw std::invalid_argument(std::string(what) + ": plane sizes differ (" +
                                std::to_string(a.width) + " x " + std::to_string(a.height) +
                                " vs " + std::to_string(b.width) + " x " +
                                std::to_string(b.height) + ")");
  }
}

// Shading factor per pixel in [0.35, 1]: the cosine between the surface normal estimated from
// central differences of the points and the viewing ray, so tilted surfaces look darker.
float shading_at(const OrganizedCloud& cloud, int u, int v) {
  if (!cloud.valid(u, v)) return 0.0f;
  const int w = cloud.width(), h = cloud.height();
  const int u0 = u > 0 && cloud.valid(u - 1, v) ? u - 1 : u;
  const int u1 = u + 1 < w && cloud.valid(u + 1, v) ? u + 1 : u;
  const int v0 = v > 0 && cloud.valid(u, v - 1) ? v - 1 : v;
  const int v1 = v + 1 < h && cloud.valid(u, v + 1) ? v + 1 : v;
  if (u0 == u1 || v0 == v1) return 0.8f;
  const double ax = cloud.x(u1, v) - cloud.x(u0, v), ay = cloud.y(u1, v) - cloud.y(u0, v),
               az = cloud.z(u1, v) - cloud.z(u0, v);
  const double bx = cloud.x(u, v1) - cloud.x(u, v0), by = cloud.y(u, v1) - cloud.y(u, v0),
               bz = cloud.z(u, v1) - cloud.z(u, v0);
  const double nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
  const double px = cloud.x(u, v), py = cloud.y(u, v), pz = cloud.z(u, v);
  const double norm = std::sqrt((nx * nx + ny * ny + nz * nz) * (px * px + py * py + pz * pz));
  if (!(norm > 0)) return 0.8f;
  const double cosine = std::abs(nx * px + ny * py + nz * pz) / norm;
  return static_cast<float>(0.35 + 0.65 * cosine);
}

void set_pixel(RgbImage& image, int x, int y, std::array<std::uint8_t, 3> colour) {
  if (x < 0 || y < 0 || x >= image.width || y >= image.height) return;
  std::uint8_t* p = image.pixel(x, y);
  p[0] = colour[0], p[1] = colour[1], p[2] = colour[2];
}

// Bresenham between two integer pixels; every pixel is clipped individually, which is cheap
// for the short outlines this draws.
void draw_segment(RgbImage& image, long x0, long y0, long x1, long y1,
                  std::array<std::uint8_t, 3> colour) {
  const long dx = std::labs(x1 - x0), dy = -std::labs(y1 - y0);
  const long sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
  long error = dx + dy;
  for (;;) {
    if (x0 >= 0 && y0 >= 0 && x0 < image.width && y0 < image.height) {
      set_pixel(image, static_cast<int>(x0), static_cast<int>(y0), colour);
    }
    if (x0 == x1 && y0 == y1) break;
    const long e2 = 2 * error;
    if (e2 >= dy) error += dy, x0 += sx;
    if (e2 <= dx) error += dx, y0 += sy;
  }
}

}  // namespace

RgbImage RgbImage::black(int w, int h) {
  if (w < 0 || h < 0) {
    throw std::invalid_argument("RgbImage: negative size " + std::to_string(w) + " x " +
                                std::to_string(h));
  }
  RgbImage image;
  image.width = w;
  image.height = h;
  image.rgb.assign(static_cast<std::size_t>(w) * h * 3, 0);
  return image;
}

std::array<std::uint8_t, 3> label_colour(std::int32_t label) {
  // Golden-ratio hue steps put consecutive labels far apart on the hue circle. Labels whose hues
  // come close differ by a Fibonacci number (13, 21, 34, 55, ...); cycling four
  // saturation/value levels by label % 4 gives most of those pairs different levels.
  constexpr double kGoldenRatioConjugate = 0.6180339887498949;
  static constexpr double kSaturation[4] = {0.95, 0.5, 1.0, 0.7};
  static constexpr double kValue[4] = {1.0, 1.0, 0.72, 0.85};
  const std::uint32_t index = static_cast<std::uint32_t>(label);
  const double hue = std::fmod(0.11 + kGoldenRatioConjugate * static_cast<double>(index), 1.0);
  return hsv_to_rgb(hue, kSaturation[index % 4], kValue[index % 4]);
}

RgbImage colorize_labels(const LabelImage& labels, const OrganizedCloud* shade) {
  if (shade != nullptr &&
      (shade->width() != labels.width() || shade->height() != labels.height())) {
    throw std::invalid_argument("colorize_labels: labels are " + std::to_string(labels.width()) +
                                " x " + std::to_string(labels.height()) + " but the cloud is " +
                                std::to_string(shade->width()) + " x " +
                                std::to_string(shade->height()));
  }
  RgbImage image = RgbImage::black(labels.width(), labels.height());
  for (int y = 0; y < labels.height(); ++y) {
    const std::int32_t* row = labels.row(y);
    for (int x = 0; x < labels.width(); ++x) {
      std::array<std::uint8_t, 3> colour = row[x] > 0 ? label_colour(row[x]) : kNoLabelColour;
      if (shade != nullptr) {
        const float factor = shading_at(*shade, x, y);
        for (auto& c : colour) c = static_cast<std::uint8_t>(std::lround(c * factor));
      }
      std::uint8_t* p = image.pixel(x, y);
      p[0] = colour[0], p[1] = colour[1], p[2] = colour[2];
    }
  }
  return image;
}

RgbImage colorize_normals(View<const float> nx, View<const float> ny, View<const float> nz) {
  require_same_size(nx, ny, "colorize_normals");
  require_same_size(nx, nz, "colorize_normals");
  RgbImage image = RgbImage::black(nx.width, nx.height);
  const auto byte = [](float n) {
    return static_cast<std::uint8_t>(std::clamp(std::lround((n + 1.0f) * 0.5f * 255.0f), 0L, 255L));
  };
  for (int y = 0; y < nx.height; ++y) {
    const float *rx = nx.row(y), *ry = ny.row(y), *rz = nz.row(y);
    for (int x = 0; x < nx.width; ++x) {
      std::uint8_t* p = image.pixel(x, y);
      if (std::isnan(rx[x]) || std::isnan(ry[x]) || std::isnan(rz[x])) continue;  // stays black
      p[0] = byte(rx[x]), p[1] = byte(ry[x]), p[2] = byte(rz[x]);
    }
  }
  return image;
}

std::array<std::uint8_t, 3> colour_map(float t) {
  // A rainbow in the spirit of "turbo": piecewise-linear through hand-picked anchor colours
  // with monotone-ish lightness in each half; dark ends keep both extremes distinguishable
  // from the black used for missing data.
  static constexpr float kAnchors[9][3] = {{48, 18, 59},   {70, 107, 227}, {40, 187, 236},
                                           {50, 241, 151}, {164, 252, 60}, {238, 205, 58},
                                           {251, 128, 34}, {209, 50, 8},   {122, 4, 3}};
  if (!(t >= 0.0f)) t = 0.0f;  // also NaN
  if (t > 1.0f) t = 1.0f;
  const float s = t * 8.0f;
  const int i = std::min(static_cast<int>(s), 7);
  const float f = s - static_cast<float>(i);
  std::array<std::uint8_t, 3> out{};
  for (int c = 0; c < 3; ++c) {
    out[c] = static_cast<std::uint8_t>(
        std::lround(kAnchors[i][c] + f * (kAnchors[i + 1][c] - kAnchors[i][c])));
  }
  return out;
}

RgbImage colorize_scalar(View<const float> values, float lo, float hi) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi)) {
    throw std::invalid_argument("colorize_scalar: need finite lo < hi, got lo = " +
                                std::to_string(lo) + ", hi = " + std::to_string(hi));
  }
  RgbImage image = RgbImage::black(values.width, values.height);
  const float scale = 1.0f / (hi - lo);
  for (int y = 0; y < values.height; ++y) {
    const float* row = values.row(y);
    for (int x = 0; x < values.width; ++x) {
      if (!std::isfinite(row[x])) continue;
      const auto colour = colour_map((row[x] - lo) * scale);
      std::uint8_t* p = image.pixel(x, y);
      p[0] = colour[0], p[1] = colour[1], p[2] = colour[2];
    }
  }
  return image;
}

RgbImage colorize_scalar_auto(View<const float> values) {
  std::vector<float> finite;
  finite.reserve(static_cast<std::size_t>(std::max(values.width, 0)) * std::max(values.height, 0));
  for (int y = 0; y < values.height; ++y) {
    const float* row = values.row(y);
    for (int x = 0; x < values.width; ++x) {
      if (std::isfinite(row[x])) finite.push_back(row[x]);
    }
  }
  if (finite.empty()) return RgbImage::black(std::max(values.width, 0), std::max(values.height, 0));
  const auto percentile = [&](double q) {
    const std::size_t k = static_cast<std::size_t>(q * static_cast<double>(finite.size() - 1));
    std::nth_element(finite.begin(), finite.begin() + static_cast<std::ptrdiff_t>(k), finite.end());
    return finite[k];
  };
  float lo = percentile(0.01);
  float hi = percentile(0.99);
  if (!(lo < hi)) {  // constant field: centre it on the map
    const float centre = lo;
    lo = centre - 0.5f * std::max(std::abs(centre), 1.0f);
    hi = centre + 0.5f * std::max(std::abs(centre), 1.0f);
  }
  return colorize_scalar(values, lo, hi);
}

RgbImage colorize_depth(const OrganizedCloud& cloud) {
  require_consistent(cloud, "colorize_depth");
  return colorize_scalar_auto(cloud.z.view());
}

void draw_polyline(RgbImage& image, const std::vector<std::array<float, 2>>& pixels,
                   std::array<std::uint8_t, 3> colour, bool closed) {
  if (image.rgb.size() != static_cast<std::size_t>(image.width) * image.height * 3) {
    throw std::invalid_argument("draw_polyline: image buffer does not match its size");
  }
  const std::size_t n = pixels.size();
  // Points far outside the picture are clamped to a generous box so the integer arithmetic
  // cannot overflow; the line direction inside the picture is unaffected for sane inputs.
  const auto to_pixel = [&](const std::array<float, 2>& p, long& x, long& y) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1])) return false;
    const double limit = 4.0 * (std::max(image.width, image.height) + 16);
    x = std::lround(std::clamp(static_cast<double>(p[0]), -limit, limit));
    y = std::lround(std::clamp(static_cast<double>(p[1]), -limit, limit));
    return true;
  };
  if (n == 1) {
    long x, y;
    if (to_pixel(pixels[0], x, y)) draw_segment(image, x, y, x, y, colour);
    return;
  }
  const std::size_t segments = closed && n > 2 ? n : (n > 0 ? n - 1 : 0);
  for (std::size_t i = 0; i < segments; ++i) {
    long x0, y0, x1, y1;
    if (!to_pixel(pixels[i], x0, y0) || !to_pixel(pixels[(i + 1) % n], x1, y1)) continue;
    draw_segment(image, x0, y0, x1, y1, colour);
  }
}

}  // namespace rangeseg
