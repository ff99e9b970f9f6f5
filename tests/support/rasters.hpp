#pragma once
/// @file
/// Raster comparisons for tests.

#include <cmath>
#include <cstddef>

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

}  // namespace diachron::test
