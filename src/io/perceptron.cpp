#include "rangeseg/io/perceptron.hpp"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "detail/number_text.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/rasterfile.hpp"

namespace rangeseg::io {
namespace {

constexpr int kSide = 512;  // every SegComp Perceptron image is 512 x 512
constexpr std::size_t kPixelBytes = std::size_t{kSide} * kSide * 4;
constexpr int kHeaderLines = 10;
constexpr std::size_t kMaxLineBytes = 1024;
constexpr std::size_t kBytesAfterHeader = 2;  // after the last field: the line end

bool whitespace(std::uint8_t b) { return b == ' ' || b == '\t' || b == '\r' || b == '\n'; }

void require_calibration(const PerceptronCalibration& c) {
  const double lengths[] = {c.h1, c.h2, c.r0, c.delta, c.metres_per_unit};
  const double angles[] = {c.gamma, c.theta, c.h_fov, c.v_fov};
  bool ok = true;
  for (const double v : lengths) ok = ok && std::isfinite(v);
  for (const double v : angles) ok = ok && std::isfinite(v) && v > 0 && v < 3.14159265358979;
  ok = ok && c.delta > 0 && c.metres_per_unit > 0;
  if (!ok) {
    throw std::invalid_argument(
        "PerceptronCalibration: lengths must be finite, delta and metres_per_unit > 0, angles in "
        "(0, pi) rad; got h1 " +
        rangeseg::detail::number_text(c.h1) + ", h2 " + rangeseg::detail::number_text(c.h2) +
        ", r0 " + rangeseg::detail::number_text(c.r0) + ", delta " +
        rangeseg::detail::number_text(c.delta) + ", metres_per_unit " +
        rangeseg::detail::number_text(c.metres_per_unit) + ", gamma " +
        rangeseg::detail::number_text(c.gamma) + ", theta " +
        rangeseg::detail::number_text(c.theta) + ", h_fov " +
        rangeseg::detail::number_text(c.h_fov) + ", v_fov " +
        rangeseg::detail::number_text(c.v_fov));
  }
}

/// The ray of pixel (row, col) in the USF scanner frame (X left, Y up, Z forward, units).
struct ScannerRay {
  double ox, oy, oz;  // where the beam leaves the nodding mirror
  double dx, dy, dz;  // unit direction
  double offset;      // travel from the origin at range value 0 [units]
};

ScannerRay scanner_ray(int row, int col, int width, int height, const PerceptronCalibration& c) {
  const double alpha = c.h_fov * (0.5 * (width - 1) - col) / width;
  const double beta = c.v_fov * (0.5 * (height - 1) - row) / height;
  // The rotating mirror's laser spot moves along the beam as alpha turns the mirror; the nodding
  // mirror meets the beam higher or lower by that shift, and further out to the side with alpha.
  const double shift = -c.h1 * (1.0 - std::cos(alpha)) / std::tan(c.gamma);
  const double rise = shift * std::tan(c.theta + 0.5 * beta);
  const double side = (c.h2 + rise) * std::tan(alpha);
  // The range counts the whole laser path from the diode, of which the part inside the scanner
  // (to the rotating mirror, then to the nodding mirror) is subtracted.
  const double inside = (shift - c.h2) + std::sqrt(side * side + (c.h2 + rise) * (c.h2 + rise));
  return {side,
          rise,
          shift,
          std::sin(alpha),
          std::cos(alpha) * std::sin(beta),
          std::cos(alpha) * std::cos(beta),
          c.r0 * c.delta - inside};
}

/// The ray in this library's frame (x = -X, y = -Y, z = Z) and metres.
PerceptronRay camera_ray(const ScannerRay& s, const PerceptronCalibration& calib) {
  const double m = calib.metres_per_unit;
  PerceptronRay ray;
  ray.origin = {-s.ox * m, -s.oy * m, s.oz * m};
  ray.direction = {-s.dx, -s.dy, s.dz};
  ray.step = calib.delta * m;
  ray.offset = s.offset * m;
  return ray;
}

void require_size(const char* what, int width, int height) {
  if (width < 1 || height < 1) {
    throw std::invalid_argument(std::string(what) + ": image size " + std::to_string(width) + "x" +
                                std::to_string(height) + " is empty");
  }
}

}  // namespace

PerceptronRay perceptron_ray(int row, int col, int width, int height,
                             const PerceptronCalibration& calib) {
  require_calibration(calib);
  require_size("perceptron_ray", width, height);
  return camera_ray(scanner_ray(row, col, width, height, calib), calib);
}

Plane<std::uint16_t> decode_perceptron_range(const std::uint8_t* data, std::size_t size,
                                             const std::string& name) {
  const auto fail = [&](const std::string& why) {
    return std::runtime_error("Perceptron range image '" + name + "': " + why);
  };
  if (data == nullptr || size <= kPixelBytes) {
    throw fail("file has " + std::to_string(size) + " bytes; a 10-line header and " +
               std::to_string(kPixelBytes) + " bytes of 512 x 512 32-bit pixels are expected");
  }
  const std::size_t pixels_at = size - kPixelBytes;
  std::size_t at = 0;
  for (int line = 0; line < kHeaderLines; ++line) {
    const std::size_t line_start = at;
    while (at < pixels_at && data[at] != '\n') {
      // Any text encoding passes; a NUL byte or an endless line is binary data.
      if (data[at] == 0 || at - line_start >= kMaxLineBytes) {
        throw fail("header line " + std::to_string(line + 1) + " is not text (" +
                   (data[at] == 0 ? "a NUL byte at " + std::to_string(at)
                                  : "no line end in " + std::to_string(kMaxLineBytes) + " bytes") +
                   "); is it a Perceptron image?");
      }
      ++at;
    }
    if (at == pixels_at) {
      throw fail("the header ends after " + std::to_string(line) + " of its " +
                 std::to_string(kHeaderLines) + " lines, " + std::to_string(kPixelBytes) +
                 " bytes before the end of the file (truncated pixel data?)");
    }
    ++at;  // the '\n'
  }
  // The SegComp tools read the header's fields and then exactly two bytes (the line end) before
  // the pixels; counted from the last field, that also catches a file a byte short or long.
  std::size_t field_end = at;
  while (field_end > 0 && whitespace(data[field_end - 1])) --field_end;
  if (pixels_at != field_end + kBytesAfterHeader) {
    throw fail("the pixels start " + std::to_string(pixels_at) + " bytes into the file (" +
               std::to_string(kPixelBytes) + " bytes before its end), but " +
               std::to_string(field_end + kBytesAfterHeader) +
               " after the header's last field and line end: the file is truncated or has extra "
               "bytes");
  }
  Plane<std::uint16_t> range(kSide, kSide);
  const std::uint8_t* p = data + pixels_at;
  for (int y = 0; y < kSide; ++y) {
    std::uint16_t* out = range.row(y);
    for (int x = 0; x < kSide; ++x, p += 4) {
      // Big-endian word; the range is its low 12 bits, in the last two bytes.
      out[x] = static_cast<std::uint16_t>(((p[2] << 8) | p[3]) & 0x0fff);
    }
  }
  return range;
}

OrganizedCloud perceptron_range_to_cloud(View<const std::uint16_t> range,
                                         const PerceptronCalibration& calib) {
  require_calibration(calib);
  require_size("perceptron_range_to_cloud", range.width, range.height);
  OrganizedCloud cloud(range.width, range.height);
  for (int r = 0; r < range.height; ++r) {
    const std::uint16_t* in = range.row(r);
    float* xs = cloud.x.row(r);
    float* ys = cloud.y.row(r);
    float* zs = cloud.z.row(r);
    for (int c = 0; c < range.width; ++c) {
      const PerceptronRay ray =
          camera_ray(scanner_ray(r, c, range.width, range.height, calib), calib);
      const double t = in[c] * ray.step + ray.offset;
      xs[c] = static_cast<float>(ray.origin[0] + t * ray.direction[0]);
      ys[c] = static_cast<float>(ray.origin[1] + t * ray.direction[1]);
      zs[c] = static_cast<float>(ray.origin[2] + t * ray.direction[2]);
    }
  }
  return cloud;
}

SegcompSensor segcomp_sensor(const std::uint8_t* data, std::size_t size) {
  return is_rasterfile(data, size) ? SegcompSensor::abw : SegcompSensor::perceptron;
}

OrganizedCloud read_segcomp_range(const std::string& path, SegcompSensor* sensor) {
  const std::vector<std::uint8_t> bytes = read_file(path);
  const SegcompSensor kind = segcomp_sensor(bytes.data(), bytes.size());
  if (sensor != nullptr) *sensor = kind;
  if (kind == SegcompSensor::abw) {
    const BytePlane image = decode_rasterfile(bytes.data(), bytes.size(), path);
    return abw_range_to_cloud(image.view(), AbwCalibration::for_image(path));
  }
  const Plane<std::uint16_t> image = decode_perceptron_range(bytes.data(), bytes.size(), path);
  return perceptron_range_to_cloud(image.view());
}

}  // namespace rangeseg::io
