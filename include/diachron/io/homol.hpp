#pragma once
/// @file
/// MicMac tie points in text form: `Homol<SH>/Pastis<image1>/<image2>.txt`, one tie point per
/// line as `x1 y1 x2 y2` (pixels of image1, then of image2), the layout TiePHistorical writes
/// (both directions) and Tapas / Campari read with ExpTxt=1. Needs the standard library and Eigen
/// only (no GDAL, despite living in io/). docs/homol.md.
///
/// Pixel convention: MicMac indexes an image from the centre of its top-left pixel, as diachron
/// does (docs/conventions.md; TiePHistorical writes SuperGlue's OpenCV keypoints into Homol
/// unchanged, and MicMac's own interpolators put pixel (i, j) at integer coordinates). The offset
/// is nevertheless explicit: MicMac pixel = diachron pixel + kMicmacHomolPixelShift, and every
/// function takes it as its last argument for data made with a corner convention.

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>


#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/matching/point_match.hpp>

namespace diachron {

/// MicMac Homol pixel coordinate minus diachron pixel coordinate, px: Homol files are in MicMac's
/// image pixels, so this is MicMac's one pixel convention (core/types.hpp), 0.
inline constexpr double kMicmacHomolPixelShift = kMicmacPixelShift;

/// One tie-point file of a Homol folder: `path` holds the tie points of `image1` (first two
/// columns) with `image2` (last two).
struct HomolPair {
  std::string image1;
  std::string image2;
  std::string path;
};

/// `<homol_dir>/Pastis<image1>/<image2>.txt`. `homol_dir` is the Homol folder itself (e.g.
/// "project/Homol-Guided"). Throws diachron::Error for an empty image name or one with a '/'.
inline std::string homol_file_path(const std::string& homol_dir, const std::string& image1, const std::string& image2);

/// Writes `matches` (a = pixel of image1, b = pixel of image2, diachron convention; scores are
/// not stored) as `Pastis<image1>/<image2>.txt` and, swapped, `Pastis<image2>/<image1>.txt`,
/// creating the folders as needed and replacing existing files. Coordinates are written in the C
/// locale with the shortest text that reads back to the same double. An empty list writes two
/// empty files. Throws diachron::Error for a non-finite coordinate (before writing anything), an
/// invalid image name, or a file that cannot be written.
inline void write_homol(const std::string& homol_dir, const std::string& image1, const std::string& image2,
                        const PointMatches& matches, double pixel_shift_px = kMicmacHomolPixelShift);

/// Reads one tie-point file: a = the first two columns, b = the last two, in diachron's convention
/// (MicMac's minus `pixel_shift_px`), score 0, in file order. Blank lines (spaces, tabs, CR) are
/// skipped. Throws diachron::Error "<path>:<line>: ..." for a line that is not exactly 4 finite
/// numbers (a weighted 5-column file included), and naming the path when it cannot be opened.
inline PointMatches read_homol(const std::string& path, double pixel_shift_px = kMicmacHomolPixelShift);

/// read_homol of homol_file_path(homol_dir, image1, image2).
inline PointMatches read_homol(const std::string& homol_dir, const std::string& image1, const std::string& image2,
                               double pixel_shift_px = kMicmacHomolPixelShift);

/// Every `Pastis<image1>/<image2>.txt` of a Homol folder (MicMac's binary `.dat` files are not
/// listed), sorted by (image1, image2). Throws diachron::Error when `homol_dir` is not a folder.
inline std::vector<HomolPair> list_homol_pairs(const std::string& homol_dir);

// Implementation ----------------------------------------------------------------------------------

namespace detail {

inline constexpr std::string_view kHomolPastisPrefix = "Pastis";
inline constexpr std::string_view kHomolExtension = ".txt";

inline void check_homol_image_name(const std::string& name) {
  DIACHRON_CHECK(!name.empty() && name.find('/') == std::string::npos,
                 "Homol image name '" << name << "' must be non-empty and contain no '/'");
}

inline void append_homol_number(std::string& line, double v) {
  char buffer[32];
  const auto [end, error] = std::to_chars(buffer, buffer + sizeof buffer, v);
  DIACHRON_CHECK(error == std::errc(), "cannot format " << v);
  line.append(buffer, end);
}

inline void write_homol_file(const std::string& path, const PointMatches& matches, bool swap, double shift) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  DIACHRON_CHECK(out.good(), "cannot write '" << path << "': the file cannot be created");
  std::string line;
  for (const PointMatch& m : matches) {
    const Eigen::Vector2d& p = swap ? m.b : m.a;
    const Eigen::Vector2d& q = swap ? m.a : m.b;
    line.clear();
    append_homol_number(line, p.x() + shift);
    line += ' ';
    append_homol_number(line, p.y() + shift);
    line += ' ';
    append_homol_number(line, q.x() + shift);
    line += ' ';
    append_homol_number(line, q.y() + shift);
    line += '\n';
    out << line;
  }
  out.flush();
  DIACHRON_CHECK(out.good(), "cannot write '" << path << "': writing failed");
}

}  // namespace detail

inline std::string homol_file_path(const std::string& homol_dir, const std::string& image1, const std::string& image2) {
  detail::check_homol_image_name(image1);
  detail::check_homol_image_name(image2);
  std::string dir = homol_dir;
  if (!dir.empty() && dir.back() != '/') dir += '/';
  return dir + std::string(detail::kHomolPastisPrefix) + image1 + "/" + image2 + std::string(detail::kHomolExtension);
}

inline void write_homol(const std::string& homol_dir, const std::string& image1, const std::string& image2,
                        const PointMatches& matches, double pixel_shift_px) {
  DIACHRON_CHECK(std::isfinite(pixel_shift_px), "write_homol: pixel_shift_px must be finite");
  for (std::size_t i = 0; i < matches.size(); ++i)
    DIACHRON_CHECK(matches[i].a.allFinite() && matches[i].b.allFinite(),
                   "write_homol: match " << i << " has a non-finite coordinate");
  const std::string forward = homol_file_path(homol_dir, image1, image2);
  const std::string backward = homol_file_path(homol_dir, image2, image1);
  for (const std::string& file : {forward, backward}) make_folders(file.substr(0, file.rfind('/')), "write_homol");
  detail::write_homol_file(forward, matches, false, pixel_shift_px);
  detail::write_homol_file(backward, matches, true, pixel_shift_px);
}

inline PointMatches read_homol(const std::string& path, double pixel_shift_px) {
  DIACHRON_CHECK(std::isfinite(pixel_shift_px), "read_homol: pixel_shift_px must be finite");
  std::ifstream in(path, std::ios::binary);
  DIACHRON_CHECK(in.good(), "cannot read '" << path << "': the file does not exist or cannot be opened");
  PointMatches out;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    double v[4];
    int count = 0;
    const char* p = line.data();
    const char* end = p + line.size();
    auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
    for (;;) {
      while (p != end && blank(*p)) ++p;
      if (p == end) break;
      const char* start = p;
      while (p != end && !blank(*p)) ++p;
      const std::string_view field(start, static_cast<std::size_t>(p - start));
      DIACHRON_CHECK(count < 4, path << ":" << number << ": more than 4 fields (expected x1 y1 x2 y2)");
      double value = 0.0;
      const auto [stop, error] = std::from_chars(field.data(), field.data() + field.size(), value);
      DIACHRON_CHECK(error == std::errc() && stop == field.data() + field.size() && std::isfinite(value),
                     path << ":" << number << ": '" << field << "' is not a finite number");
      v[count++] = value;
    }
    if (count == 0) continue;
    DIACHRON_CHECK(count == 4, path << ":" << number << ": " << count << " fields, expected 4 (x1 y1 x2 y2)");
    out.push_back(PointMatch{Eigen::Vector2d(v[0] - pixel_shift_px, v[1] - pixel_shift_px),
                             Eigen::Vector2d(v[2] - pixel_shift_px, v[3] - pixel_shift_px), 0.0});
  }
  DIACHRON_CHECK(in.eof(), "cannot read '" << path << "': reading failed after line " << number);
  return out;
}

inline PointMatches read_homol(const std::string& homol_dir, const std::string& image1, const std::string& image2,
                               double pixel_shift_px) {
  return read_homol(homol_file_path(homol_dir, image1, image2), pixel_shift_px);
}

inline std::vector<HomolPair> list_homol_pairs(const std::string& homol_dir) {
  DIACHRON_CHECK(is_folder(homol_dir), "list_homol_pairs: '" << homol_dir << "' is not a folder");
  const std::string root = homol_dir.back() == '/' ? homol_dir : homol_dir + "/";
  std::vector<HomolPair> out;
  for (const std::string& dir_name : folder_entries(homol_dir)) {
    if (dir_name.size() <= detail::kHomolPastisPrefix.size() ||
        dir_name.compare(0, detail::kHomolPastisPrefix.size(), detail::kHomolPastisPrefix) != 0 ||
        !is_folder(root + dir_name))
      continue;
    const std::string image1 = dir_name.substr(detail::kHomolPastisPrefix.size());
    for (const std::string& name : folder_entries(root + dir_name)) {
      const std::string path = root + dir_name + "/" + name;
      if (name.size() <= detail::kHomolExtension.size() ||
          name.compare(name.size() - detail::kHomolExtension.size(), detail::kHomolExtension.size(),
                       detail::kHomolExtension) != 0 ||
          !is_regular_file(path))
        continue;
      out.push_back(HomolPair{image1, name.substr(0, name.size() - detail::kHomolExtension.size()), path});
    }
  }
  std::sort(out.begin(), out.end(), [](const HomolPair& a, const HomolPair& b) {
    return a.image1 < b.image1 || (a.image1 == b.image1 && a.image2 < b.image2);
  });
  return out;
}

}  // namespace diachron
