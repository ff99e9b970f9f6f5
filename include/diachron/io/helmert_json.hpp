#pragma once
/// @file
/// A Helmert3 as the JSON file the programs write (`helmert.json` of rough_coregistration,
/// `rough_helmert.json` of match_epochs):
/// @code
/// {"scale": s, "rotation": [[r00, r01, r02], [r10, r11, r12], [r20, r21, r22]], "translation": [tx, ty, tz]}
/// @endcode
/// meaning X2 = s R X1 + t (epoch 1 into epoch 2, docs/conventions.md). Written with 17 significant
/// digits, so a file read back gives the same doubles. Standard library and Eigen only.

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <limits>
#include <locale>
#include <sstream>
#include <string>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/geometry/helmert3.hpp>

namespace diachron {

/// The JSON text of `h` (see the file comment), one key per line.
inline std::string helmert_json(const Helmert3& h) {
  std::ostringstream out;
  out.imbue(std::locale::classic());
  out.precision(std::numeric_limits<double>::max_digits10);
  out << "{\n  \"scale\": " << h.scale << ",\n  \"rotation\": [";
  for (int r = 0; r < 3; ++r)
    out << (r ? ", " : "") << "[" << h.rotation(r, 0) << ", " << h.rotation(r, 1) << ", " << h.rotation(r, 2) << "]";
  out << "],\n  \"translation\": [" << h.translation.x() << ", " << h.translation.y() << ", " << h.translation.z()
      << "]\n}\n";
  return out.str();
}

/// Writes helmert_json(h) to `path` (overwrites). Throws diachron::Error naming the file on failure.
inline void write_helmert_json(const Helmert3& h, const std::string& path) {
  std::ofstream out(path);
  DIACHRON_CHECK(out.good(), "cannot write '" << path << "'");
  out << helmert_json(h);
  out.close();
  DIACHRON_CHECK(!out.fail(), "cannot write '" << path << "': write failed");
}

namespace detail {

// The numbers of the value of `key` in `text` (a number or nested arrays of numbers), in order.
inline std::vector<double> json_numbers_of(const std::string& text, const std::string& key, const std::string& path) {
  const std::string quoted = "\"" + key + "\"";
  const std::size_t at = text.find(quoted);
  DIACHRON_CHECK(at != std::string::npos, "'" << path << "': no \"" << key << "\" key");
  std::size_t i = text.find(':', at + quoted.size());
  DIACHRON_CHECK(i != std::string::npos, "'" << path << "': \"" << key << "\" has no value");
  ++i;
  std::vector<double> out;
  int depth = 0;
  for (; i < text.size(); ++i) {
    const char c = text[i];
    if (std::isspace(static_cast<unsigned char>(c)) || c == ',') {
      if (depth == 0 && c == ',' && !out.empty()) break;
      continue;
    }
    if (c == '[') {
      ++depth;
      continue;
    }
    if (c == ']') {
      DIACHRON_CHECK(depth > 0, "'" << path << "': unbalanced ']' in \"" << key << "\"");
      if (--depth == 0) break;
      continue;
    }
    if (c == '}' && depth == 0) break;
    const char* start = text.c_str() + i;
    char* end = nullptr;
    const double v = std::strtod(start, &end);
    DIACHRON_CHECK(end != start, "'" << path << "': \"" << key << "\" holds '" << text.substr(i, 12)
                                     << "', not a number");
    out.push_back(v);
    i += static_cast<std::size_t>(end - start) - 1;
    if (depth == 0) break;
  }
  return out;
}

}  // namespace detail

/// Reads a file written by write_helmert_json() (or any JSON object with those three keys).
/// Throws diachron::Error naming the file when it is missing, a key is missing or has the wrong
/// number of values, a value is not finite, the scale is not positive or the rotation is not one
/// (|R^T R - I| or |det R - 1| above 1e-6).
inline Helmert3 read_helmert_json(const std::string& path) {
  std::ifstream in(path);
  DIACHRON_CHECK(in.good(), "cannot read '" << path << "': no such file");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::vector<double> s = detail::json_numbers_of(text, "scale", path);
  const std::vector<double> r = detail::json_numbers_of(text, "rotation", path);
  const std::vector<double> t = detail::json_numbers_of(text, "translation", path);
  DIACHRON_CHECK(s.size() == 1 && r.size() == 9 && t.size() == 3,
                 "'" << path << "': expected 1 scale, 9 rotation and 3 translation values, got " << s.size() << ", "
                     << r.size() << " and " << t.size());
  Helmert3 h;
  h.scale = s[0];
  for (int i = 0; i < 9; ++i) h.rotation(i / 3, i % 3) = r[static_cast<std::size_t>(i)];
  h.translation = Eigen::Vector3d(t[0], t[1], t[2]);
  DIACHRON_CHECK(std::isfinite(h.scale) && h.scale > 0.0 && h.rotation.allFinite() && h.translation.allFinite(),
                 "'" << path << "': the scale must be positive and every value finite");
  const double orthogonality = (h.rotation.transpose() * h.rotation - Eigen::Matrix3d::Identity()).norm();
  DIACHRON_CHECK(orthogonality < 1e-6 && std::abs(h.rotation.determinant() - 1.0) < 1e-6,
                 "'" << path << "': \"rotation\" is not a rotation matrix (|R^T R - I| = " << orthogonality
                     << ", det = " << h.rotation.determinant() << ")");
  return h;
}

}  // namespace diachron
