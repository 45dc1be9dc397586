#include "rangeseg/colorize.hpp"
#include "detail/number_text.hpp"

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

// Shading factors of row v in [0.35, 1]: the cosine between the surface normal estimated from
// central differences of the points and the viewing ray, so tilted surfaces look darker; 0 for
// an invalid point, 0.8 where a point has no valid neighbour along a row or a column.
// `valid_above` / `valid_below` are the validity of rows v - 1 and v + 1 (null outside the image).
void shading_row(const OrganizedCloud& cloud, int v, const std::uint8_t* valid_above,
                 const std::uint8_t* valid, const std::uint8_t* valid_below, float* factor) {
  const int w = cloud.width();
  const float *x = cloud.x.row(v), *y = cloud.y.row(v), *z = cloud.z.row(v);
  const float* x_above = valid_above != nullptr ? cloud.x.row(v - 1) : x;
  const float* y_above = valid_above != nullptr ? cloud.y.row(v - 1) : y;
  const float* z_above = valid_above != nullptr ? cloud.z.row(v - 1) : z;
  const float* x_below = valid_below != nullptr ? cloud.x.row(v + 1) : x;
  const float* y_below = valid_below != nullptr ? cloud.y.row(v + 1) : y;
  const float* z_below = valid_below != nullptr ? cloud.z.row(v + 1) : z;
  for (int u = 0; u < w; ++u) {
    if (!valid[u]) {
      factor[u] = 0.0f;
      continue;
    }
    const int u0 = u > 0 && valid[u - 1] ? u - 1 : u;
    const int u1 = u + 1 < w && valid[u + 1] ? u + 1 : u;
    const bool up = valid_above != nullptr && valid_above[u];
    const bool down = valid_below != nullptr && valid_below[u];
    if (u0 == u1 || !(up || down)) {
      factor[u] = 0.8f;
      continue;
    }
    const double ax = x[u1] - x[u0], ay = y[u1] - y[u0], az = z[u1] - z[u0];
    const double bx = (down ? x_below[u] : x[u]) - (up ? x_above[u] : x[u]);
    const double by = (down ? y_below[u] : y[u]) - (up ? y_above[u] : y[u]);
    const double bz = (down ? z_below[u] : z[u]) - (up ? z_above[u] : z[u]);
    const double nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
    const double px = x[u], py = y[u], pz = z[u];
    const double norm = std::sqrt((nx * nx + ny * ny + nz * nz) * (px * px + py * py + pz * pz));
    if (!(norm > 0)) {
      factor[u] = 0.8f;
      continue;
    }
    const double cosine = std::abs(nx * px + ny * py + nz * pz) / norm;
    factor[u] = static_cast<float>(0.35 + 0.65 * cosine);
  }
}

void valid_row(const OrganizedCloud& cloud, int v, std::uint8_t* valid) {
  const float *x = cloud.x.row(v), *y = cloud.y.row(v), *z = cloud.z.row(v);
  for (int u = 0; u < cloud.width(); ++u) {
    valid[u] = std::isfinite(x[u]) && std::isfinite(y[u]) && std::isfinite(z[u]);
  }
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
  const int width = labels.width(), height = labels.height();
  RgbImage image = RgbImage::black(width, height);
  // Validity of rows v - 1, v and v + 1, rolling.
  std::vector<std::uint8_t> valid(shade != nullptr ? 3 * static_cast<std::size_t>(width) : 0);
  std::vector<float> factor(shade != nullptr ? static_cast<std::size_t>(width) : 0);
  const auto valid_of = [&](int v) {
    return valid.data() + static_cast<std::ptrdiff_t>(v % 3) * width;
  };
  if (shade != nullptr && height > 0) valid_row(*shade, 0, valid_of(0));
  // Neighbouring pixels mostly share a label: its colour is computed once per run.
  std::int32_t last_label = 0;
  std::array<std::uint8_t, 3> last_colour = kNoLabelColour;
  for (int v = 0; v < height; ++v) {
    if (shade != nullptr) {
      if (v + 1 < height) valid_row(*shade, v + 1, valid_of(v + 1));
      shading_row(*shade, v, v > 0 ? valid_of(v - 1) : nullptr, valid_of(v),
                  v + 1 < height ? valid_of(v + 1) : nullptr, factor.data());
    }
    const std::int32_t* row = labels.row(v);
    std::uint8_t* p = image.pixel(0, v);
    for (int u = 0; u < width; ++u, p += 3) {
      if (row[u] != last_label) {
        last_label = row[u];
        last_colour = last_label > 0 ? label_colour(last_label) : kNoLabelColour;
      }
      std::array<std::uint8_t, 3> colour = last_colour;
      if (shade != nullptr) {
        for (auto& c : colour) c = static_cast<std::uint8_t>(std::lround(c * factor[u]));
      }
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
    throw std::invalid_argument(
        "colorize_scalar: need finite lo < hi, got lo = " + rangeseg::detail::number_text(lo) +
        ", hi = " + rangeseg::detail::number_text(hi));
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
