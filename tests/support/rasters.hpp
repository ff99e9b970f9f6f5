#pragma once
/// @file
/// Raster comparisons and test images for tests.

#include <cmath>
#include <cstddef>
#include <cstdint>

#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>

namespace diachron::test {

/// True when both rasters have the same size and the same values, NaN matching NaN (holes).
template <class T>
bool same_values(const Raster<T>& a, const Raster<T>& b) {
  if (a.width() != b.width() || a.height() != b.height()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const T x = a.data()[i], y = b.data()[i];
    if (!(x == y || (std::isnan(x) && std::isnan(y)))) return false;
  }
  return true;
}

/// A w x h image of grey levels drawn uniformly from [0, 255), one RandomStream per seed.
inline Raster<std::uint8_t> uniform_noise_image(int w, int h, std::uint64_t seed) {
  RandomStream rng(seed);
  Raster<std::uint8_t> img(w, h);
  for (auto& v : img) v = static_cast<std::uint8_t>(rng.uniform(0.0, 255.0));
  return img;
}

}  // namespace diachron::test
