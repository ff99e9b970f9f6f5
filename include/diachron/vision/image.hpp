#pragma once
/// @file
/// Raster <-> cv::Mat: zero-copy views, checked copies back, and 8-bit grayscale image files.
///
/// A view shares memory with the raster (no pixel is copied): writing through it writes the raster,
/// and it dangles once the raster is resized or destroyed. The copy back (`to_raster`) checks the
/// Mat's depth and channel count and says what it got. Both sides use the same pixel convention
/// (element (x, y) is column x, row y; docs/conventions.md), so no coordinate changes here.

#include <cstdint>
#include <cstring>
#include <string>
#include <sys/stat.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>

namespace diachron {

namespace detail {

/// OpenCV single-channel type of a raster element; only the types OpenCV can hold are defined.
template <class T>
struct CvType;
template <>
struct CvType<std::uint8_t> {
  static constexpr int value = CV_8UC1;
};
template <>
struct CvType<std::int8_t> {
  static constexpr int value = CV_8SC1;
};
template <>
struct CvType<std::uint16_t> {
  static constexpr int value = CV_16UC1;
};
template <>
struct CvType<std::int16_t> {
  static constexpr int value = CV_16SC1;
};
template <>
struct CvType<std::int32_t> {
  static constexpr int value = CV_32SC1;
};
template <>
struct CvType<float> {
  static constexpr int value = CV_32FC1;
};
template <>
struct CvType<double> {
  static constexpr int value = CV_64FC1;
};

inline bool path_exists(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0;
}

}  // namespace detail

/// A cv::Mat header over the raster's own pixels (no copy): height rows, width columns, one
/// channel of the matching depth (uint8_t -> CV_8UC1, float -> CV_32FC1, ...). An empty raster
/// gives an empty Mat. Valid while the raster is neither resized nor destroyed.
template <class T>
cv::Mat as_mat(Raster<T>& raster) {
  if (raster.empty()) return cv::Mat();
  return cv::Mat(raster.height(), raster.width(), detail::CvType<T>::value, raster.data());
}

/// A read-only view of a const raster. OpenCV has no const Mat, so the header is mutable in
/// principle: callers must only read through it (every OpenCV function taking an InputArray does).
template <class T>
cv::Mat as_mat(const Raster<T>& raster) {
  if (raster.empty()) return cv::Mat();
  return cv::Mat(raster.height(), raster.width(), detail::CvType<T>::value,
                 const_cast<T*>(raster.data()));
}

/// The view of a temporary raster would dangle as soon as the statement ends: does not compile.
template <class T>
cv::Mat as_mat(const Raster<T>&& raster) = delete;

/// Copies a single-channel Mat of exactly T's depth into a new raster (continuous or not, e.g. a
/// ROI). Throws diachron::Error when the Mat has several channels, another depth, or more than
/// two dimensions; convert first (cv::cvtColor, Mat::convertTo) when that is what is meant.
template <class T>
Raster<T> to_raster(const cv::Mat& mat) {
  DIACHRON_CHECK(mat.dims <= 2, "expected a 2D image, got a Mat with " << mat.dims << " dimensions");
  if (mat.empty()) return Raster<T>();
  DIACHRON_CHECK(mat.type() == detail::CvType<T>::value,
                 "expected a Mat of type " << cv::typeToString(detail::CvType<T>::value) << ", got "
                                           << cv::typeToString(mat.type()) << " (" << mat.cols
                                           << " x " << mat.rows << ")");
  Raster<T> raster(mat.cols, mat.rows);
  const std::size_t row_bytes = static_cast<std::size_t>(mat.cols) * sizeof(T);
  for (int y = 0; y < mat.rows; ++y) std::memcpy(raster.row(y), mat.ptr<T>(y), row_bytes);
  return raster;
}

/// Loads an image file as 8-bit grayscale (any format OpenCV's imgcodecs reads: PNG, TIFF, JPEG,
/// ...). Colour images are converted to gray with OpenCV's weights; 16-bit images are reduced to
/// 8 bits by OpenCV (value / 256), so stretch DSMs yourself before saving them when that matters
/// (read_image_grey8 of io/grey_image.hpp stretches them between percentiles, as epoch folders do).
/// Throws diachron::Error naming the file when it does not exist or cannot be decoded.
inline Raster<std::uint8_t> load_gray8(const std::string& path) {
  DIACHRON_CHECK(detail::path_exists(path), "cannot read image '" << path << "': no such file");
  cv::Mat mat;
  try {
    mat = cv::imread(path, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    DIACHRON_CHECK(false, "cannot read image '" << path << "': " << e.what());
  }
  DIACHRON_CHECK(!mat.empty(), "cannot read image '" << path
                                                     << "': not an image format OpenCV can decode");
  return to_raster<std::uint8_t>(mat);
}

/// Writes an 8-bit raster as a grayscale image; the format follows the extension (".png" is
/// lossless). Throws diachron::Error naming the file when the raster is empty, the extension is
/// unknown or the file cannot be written.
inline void save_gray8(const std::string& path, const Raster<std::uint8_t>& raster) {
  DIACHRON_CHECK(!raster.empty(), "cannot write image '" << path << "': the raster is empty");
  bool ok = false;
  try {
    ok = cv::imwrite(path, as_mat(raster));
  } catch (const cv::Exception& e) {
    DIACHRON_CHECK(false, "cannot write image '" << path << "': " << e.what());
  }
  DIACHRON_CHECK(ok, "cannot write image '" << path << "': OpenCV could not write it (directory "
                                            << "missing or not writable?)");
}

/// Writes any Mat OpenCV can encode (e.g. a BGR drawing); same errors as save_gray8.
inline void save_image(const std::string& path, const cv::Mat& image) {
  DIACHRON_CHECK(!image.empty(), "cannot write image '" << path << "': the image is empty");
  bool ok = false;
  try {
    ok = cv::imwrite(path, image);
  } catch (const cv::Exception& e) {
    DIACHRON_CHECK(false, "cannot write image '" << path << "': " << e.what());
  }
  DIACHRON_CHECK(ok, "cannot write image '" << path << "': OpenCV could not write it (directory "
                                            << "missing or not writable?)");
}

}  // namespace diachron
