// Pictures for people: labels, normals, depth and scalar fields as 8-bit RGB images.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"

namespace rangeseg {

/// An 8-bit RGB picture: `rgb` holds width * height * 3 bytes, interleaved R, G, B, row-major,
/// no row padding.
struct RgbImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;

  /// A black picture of the given size. Throws std::invalid_argument for negative sizes.
  static RgbImage black(int width, int height);

  std::uint8_t* pixel(int x, int y) {
    return rgb.data() + (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                         static_cast<std::size_t>(x)) *
                            3;
  }
  const std::uint8_t* pixel(int x, int y) const {
    return rgb.data() + (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                         static_cast<std::size_t>(x)) *
                            3;
  }
};

/// The fixed colour of label `label` (> 0): hue from the golden-ratio sequence, so consecutive
/// labels get well separated hues, with four saturation/value levels cycled by label % 4 so
/// that labels whose hues come close still differ (the first 50 labels differ pairwise by at
/// least 40 in the sum of |R|, |G|, |B| differences).
std::array<std::uint8_t, 3> label_colour(std::int32_t label);

/// Colour of label 0 / negative labels ("no segment"): dark grey.
inline constexpr std::array<std::uint8_t, 3> kNoLabelColour = {40, 40, 40};

/// Colours each label with label_colour(); label <= 0 is dark grey (kNoLabelColour) or black
/// where `shade` has no valid point. If `shade` (same size as `labels`) is given, the colours
/// are modulated by a Lambert-like shading from the depth gradient so the shape of the surface
/// shows through the labels (the "label overlay over the depth image").
/// Throws std::invalid_argument if the sizes differ.
RgbImage colorize_labels(const LabelImage& labels, const OrganizedCloud* shade = nullptr);

/// Normal vectors (components in [-1, 1]) to RGB as (n + 1) / 2 * 255 per channel, so a normal
/// facing the camera (0, 0, -1) is (128, 128, 0); any NaN component gives black.
/// Throws std::invalid_argument if the three views differ in size.
RgbImage colorize_normals(View<const float> nx, View<const float> ny, View<const float> nz);

/// False colour of a scalar field on the "turbo"-like rainbow map (dark blue at `lo`, through
/// cyan, green, yellow, to dark red at `hi`; values outside are clamped). NaN / inf give black.
/// Throws std::invalid_argument unless lo and hi are finite with lo < hi.
RgbImage colorize_scalar(View<const float> values, float lo, float hi);

/// colorize_scalar with lo, hi = the 1st and 99th percentiles of the finite values (robust to
/// outliers); all-NaN input gives a black picture.
RgbImage colorize_scalar_auto(View<const float> values);

/// False colour of the z plane (depth) of a cloud, auto range; invalid points are black.
RgbImage colorize_depth(const OrganizedCloud& cloud);

/// The colour map of colorize_scalar at t in [0, 1] (clamped).
std::array<std::uint8_t, 3> colour_map(float t);

/// Draws the polyline through `pixels` (x, y in pixel coordinates, rounded to the nearest
/// pixel) with Bresenham segments; `closed` also joins the last point to the first. Parts
/// outside the picture are clipped; non-finite points are skipped (breaking the line).
void draw_polyline(RgbImage& image, const std::vector<std::array<float, 2>>& pixels,
                   std::array<std::uint8_t, 3> colour, bool closed);

}  // namespace rangeseg
