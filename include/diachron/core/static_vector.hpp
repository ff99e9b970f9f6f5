#pragma once
/// @file
/// A fixed-capacity vector that lives on the stack: minimal solvers return their (few) models in
/// one, so the RANSAC inner loop never touches the heap.

#include <array>
#include <cstddef>

#include <diachron/core/error.hpp>

namespace diachron {

/// Up to `Capacity` values of `T` without heap allocation. `T` must be default-constructible.
/// push_back beyond the capacity throws diachron::Error (a solver breaking its contract).
template <class T, std::size_t Capacity>
class StaticVector {
 public:
  using value_type = T;
  static constexpr std::size_t kCapacity = Capacity;

  void push_back(const T& value) {
    DIACHRON_CHECK(size_ < Capacity, "StaticVector capacity " << Capacity << " exceeded");
    items_[size_++] = value;
  }
  void clear() { size_ = 0; }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  static constexpr std::size_t capacity() { return Capacity; }
  T& operator[](std::size_t i) { return items_[i]; }
  const T& operator[](std::size_t i) const { return items_[i]; }
  T* begin() { return items_.data(); }
  T* end() { return items_.data() + size_; }
  const T* begin() const { return items_.data(); }
  const T* end() const { return items_.data() + size_; }

 private:
  std::array<T, Capacity> items_{};
  std::size_t size_ = 0;
};

}  // namespace diachron
