#pragma once
/// @file
/// A read-only view of a subset of an array, without copying: all of it, or the elements named by
/// an index list. RANSAC hands inlier sets to least-squares refits this way.

#include <cstddef>

namespace diachron {

/// View of `data[indices[i]]` for i in [0, size), or of `data[i]` when `indices` is null.
/// Holds pointers only: the data and index arrays must outlive the view.
template <class T>
class Subset {
 public:
  /// All `size` elements of `data`.
  Subset(const T* data, std::size_t size) : data_(data), indices_(nullptr), size_(size) {}
  /// The `size` elements `data[indices[0]]`, `data[indices[1]]`, ...
  Subset(const T* data, const std::size_t* indices, std::size_t size)
      : data_(data), indices_(indices), size_(size) {}

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  const T& operator[](std::size_t i) const { return indices_ ? data_[indices_[i]] : data_[i]; }
  /// Index of element i in the underlying array.
  std::size_t index(std::size_t i) const { return indices_ ? indices_[i] : i; }

 private:
  const T* data_;
  const std::size_t* indices_;
  std::size_t size_;
};

}  // namespace diachron
