// SegComp PERCEPTRON range images (Hoover et al. 1996): the file format, the scanner's geometry,
// and one reader for both SegComp range formats.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"

namespace rangeseg::io {

/// Geometry of the Perceptron LASAR scanner of the SegComp database, as the USF tools
/// (range-to-coords) model it: the beam is deflected by a rotating mirror (horizontal angle
/// alpha) and a nodding mirror (vertical angle beta), so each pixel measures along its own ray,
/// which leaves the nodding mirror a few centimetres off the scanner's origin. Lengths are in
/// scanner units, which the USF constants give in centimetres; `metres_per_unit` converts them.
struct PerceptronCalibration {
  static constexpr double kDegree = 3.14159265358979323846 / 180.0;
  double h1 = 3.0;              ///< rotating mirror axis to the laser beam [scanner units]
  double h2 = 5.5;              ///< nodding mirror axis to the rotating mirror's laser spot [units]
  double gamma = 45 * kDegree;  ///< slope of the rotating mirror [rad]
  double theta = 45 * kDegree;  ///< slope of the nodding mirror in mid position [rad]
  double h_fov = 51.65 * kDegree;  ///< horizontal field across the image width [rad]
  double v_fov = 36.73 * kDegree;  ///< vertical field across the image height [rad]
  double r0 = 830.3;               ///< standoff: laser travel at range value 0 [range counts]
  double delta = 0.20236;          ///< laser travel per range count [scanner units]
  double metres_per_unit = 0.01;   ///< scanner units are centimetres
};

/// The ray along which pixel (row, col) of a width x height Perceptron image measures, in this
/// library's camera frame (x right, y down, z forward, metres): the point of range value R is
/// origin + (R * step + offset) * direction, with `direction` a unit vector.
struct PerceptronRay {
  std::array<double, 3> origin{};     ///< where the beam leaves the nodding mirror [m]
  std::array<double, 3> direction{};  ///< unit
  double step = 0;                    ///< metres of range per count (delta * metres_per_unit)
  double offset = 0;                  ///< metres from `origin` at range value 0
};
PerceptronRay perceptron_ray(int row, int col, int width, int height,
                             const PerceptronCalibration& calib = {});

/// Decodes a Perceptron range file: a text header of 10 lines, then 512 x 512 big-endian 32-bit
/// words in row order, whose low 12 bits are the range (the higher bits carry the reflectance and
/// control bits). As the SegComp tools read it, the pixels start two bytes (the line end, e.g.
/// "\n\n" or "\r\n") after the header's last field, and fill the rest of the file. Returns the
/// 12-bit range values. Throws std::runtime_error naming `name` and the problem (not a text
/// header, a file shorter or longer than that layout).
Plane<std::uint16_t> decode_perceptron_range(const std::uint8_t* data, std::size_t size,
                                             const std::string& name);

/// Converts Perceptron range values to an organized cloud in metres (every pixel measures; the
/// SegComp tools mark none as missing). The USF model gives scanner coordinates X (left), Y (up)
/// and Z (forward); this library's frame is x = -X, y = -Y, z = Z (a rotation by 180 degrees
/// about the viewing axis), scaled by `metres_per_unit`. Throws std::invalid_argument for an
/// empty image or a calibration with a non-finite value or with delta or metres_per_unit <= 0.
OrganizedCloud perceptron_range_to_cloud(View<const std::uint16_t> range,
                                         const PerceptronCalibration& calib = {});

/// The two range formats of the SegComp database.
enum class SegcompSensor { abw, perceptron };

/// Which SegComp format the bytes hold: a Sun rasterfile (ABW) or anything else (Perceptron,
/// whose decoder then checks the header).
SegcompSensor segcomp_sensor(const std::uint8_t* data, std::size_t size);

/// Reads a SegComp `.range` file of either scanner, told apart by its content: ABW images
/// (rasterfiles, read_abw_range) or Perceptron images (decode_perceptron_range +
/// perceptron_range_to_cloud). `sensor`, if given, receives which one it was.
OrganizedCloud read_segcomp_range(const std::string& path, SegcompSensor* sensor = nullptr);

}  // namespace rangeseg::io
