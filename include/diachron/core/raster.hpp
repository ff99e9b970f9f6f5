#pragma once
/// @file
/// Raster<T>: a dense row-major 2D grid of values (images, DSMs, masks) that owns its storage.

#include <cstddef>
#include <vector>

#include <diachron/core/error.hpp>

namespace diachron {

/// A width x height grid, row-major, element (x, y) at data()[y * width + x].
/// x is the column (to the right), y the row (down), as pixel coordinates (docs/conventions.md).
/// Single-channel: multi-channel images are several rasters or a Raster of a small struct.
template <class T>
class Raster {
 public:
  using value_type = T;

  Raster() = default;
  /// A width x height raster filled with `fill`. Negative or overflowing sizes throw diachron::Error.
  Raster(int width, int height, const T& fill = T{}) { resize(width, height, fill); }

  void resize(int width, int height, const T& fill = T{}) {
    DIACHRON_CHECK(width >= 0 && height >= 0,
                   "raster size must be non-negative, got " << width << " x " << height);
    width_ = width;
    height_ = height;
    data_.assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), fill);
  }

  int width() const { return width_; }
  int height() const { return height_; }
  std::size_t size() const { return data_.size(); }
  bool empty() const { return data_.empty(); }
  bool contains(int x, int y) const { return x >= 0 && y >= 0 && x < width_ && y < height_; }

  /// Unchecked element access (column x, row y).
  T& operator()(int x, int y) { return data_[index(x, y)]; }
  const T& operator()(int x, int y) const { return data_[index(x, y)]; }
  /// Checked element access: throws diachron::Error outside the raster.
  const T& at(int x, int y) const {
    DIACHRON_CHECK(contains(x, y), "pixel (" << x << ", " << y << ") outside a " << width_ << " x "
                                             << height_ << " raster");
    return data_[index(x, y)];
  }
  T& at(int x, int y) {
    DIACHRON_CHECK(contains(x, y), "pixel (" << x << ", " << y << ") outside a " << width_ << " x "
                                             << height_ << " raster");
    return data_[index(x, y)];
  }

  T* data() { return data_.data(); }
  const T* data() const { return data_.data(); }
  T* row(int y) { return data_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(width_); }
  const T* row(int y) const {
    return data_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(width_);
  }
  typename std::vector<T>::iterator begin() { return data_.begin(); }
  typename std::vector<T>::iterator end() { return data_.end(); }
  typename std::vector<T>::const_iterator begin() const { return data_.begin(); }
  typename std::vector<T>::const_iterator end() const { return data_.end(); }

 private:
  std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(x);
  }

  int width_ = 0;
  int height_ = 0;
  std::vector<T> data_;
};

}  // namespace diachron
