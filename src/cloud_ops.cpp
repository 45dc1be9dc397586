#include <cstddef>
#include <stdexcept>
#include <string>

#include "rangeseg/cloud.hpp"

namespace rangeseg {
namespace {

template <class T>
void take_every(const Plane<T>& in, int factor, int out_width, int out_height, Plane<T>& out) {
  if (in.empty()) return;
  out.resize(out_width, out_height);
  for (int v = 0; v < out_height; ++v) {
    const T* src = in.row(v * factor);
    T* dst = out.row(v);
    for (int u = 0; u < out_width; ++u) dst[u] = src[static_cast<std::ptrdiff_t>(u) * factor];
  }
}

}  // namespace

OrganizedCloud downsample(const OrganizedCloud& cloud, int factor) {
  require_consistent(cloud, "downsample");
  if (factor < 1) {
    throw std::invalid_argument("downsample: factor must be >= 1, got " + std::to_string(factor));
  }
  const int w = (cloud.width() + factor - 1) / factor;
  const int h = (cloud.height() + factor - 1) / factor;
  OrganizedCloud out;
  take_every(cloud.x, factor, w, h, out.x);
  take_every(cloud.y, factor, w, h, out.y);
  take_every(cloud.z, factor, w, h, out.z);
  take_every(cloud.intensity, factor, w, h, out.intensity);
  take_every(cloud.r, factor, w, h, out.r);
  take_every(cloud.g, factor, w, h, out.g);
  take_every(cloud.b, factor, w, h, out.b);
  take_every(cloud.label, factor, w, h, out.label);
  return out;
}

}  // namespace rangeseg
