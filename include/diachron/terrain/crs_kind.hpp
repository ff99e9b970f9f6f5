#pragma once
/// @file
/// crs_kind(): what kind of coordinate reference system a DSM's CRS text describes, read from its
/// WKT without GDAL, so that the terrain and pipeline modules can refuse frames they cannot use.
///
/// Why it matters: the rough co-registration fits a 3D similarity (one scale for X, Y and Z) to
/// points lifted from the DSMs. In a geographic CRS, X and Y are degrees while heights are metres,
/// so no similarity relates two such DSMs; the fit would still "succeed", on numbers without
/// meaning. Such a DSM has to be reprojected to a projected CRS first (io/dsm_reproject.hpp does
/// it with GDAL, or `gdalwarp -t_srs EPSG:326zz`).
///
/// Recognised: WKT1 (GEOGCS, PROJCS, GEOCCS, LOCAL_CS, COMPD_CS as GDAL writes them) and WKT2
/// (GEOGCRS, GEOGRAPHICCRS, GEODCRS / GEODETICCRS with an ellipsoidal coordinate system, PROJCRS,
/// PROJECTEDCRS, ENGCRS, ENGINEERINGCRS, COMPOUNDCRS, BOUNDCRS). A compound CRS is the kind of its
/// horizontal part. Text that is not WKT (e.g. "EPSG:4326", which only a CRS database can resolve)
/// or is empty gives `unknown`: the caller cannot tell, and nothing is refused.
#include <cctype>
#include <string>

namespace diachron {

/// Kinds of CRS that matter to a 3D similarity between DSMs.
enum class CrsKind {
  unknown,     ///< empty, or not WKT
  geographic,  ///< angles (degrees) horizontally: unusable as is
  projected,   ///< map projection, linear units
  geocentric,  ///< Earth-centred Cartesian
  engineering  ///< a local Cartesian frame (e.g. an SfM model's)
};

/// Readable name of a CrsKind.
inline const char* to_string(CrsKind kind) {
  switch (kind) {
    case CrsKind::geographic: return "geographic";
    case CrsKind::projected: return "projected";
    case CrsKind::geocentric: return "geocentric";
    case CrsKind::engineering: return "engineering";
    case CrsKind::unknown: break;
  }
  return "unknown";
}

namespace detail {

// The upper-cased keyword at `pos` (letters, digits, underscores), `pos` moved past it.
inline std::string wkt_keyword(const std::string& wkt, std::size_t& pos) {
  while (pos < wkt.size() && std::isspace(static_cast<unsigned char>(wkt[pos]))) ++pos;
  std::string word;
  while (pos < wkt.size() && (std::isalnum(static_cast<unsigned char>(wkt[pos])) || wkt[pos] == '_'))
    word += static_cast<char>(std::toupper(static_cast<unsigned char>(wkt[pos++])));
  return word;
}

// Position of the bracket ('[' or '(') that opens the first sub-node of the node whose keyword
// ends at `pos`, quoted names skipped; npos when there is none.
inline std::size_t wkt_first_child(const std::string& wkt, std::size_t pos) {
  bool quoted = false;
  int depth = 0;
  for (; pos < wkt.size(); ++pos) {
    const char c = wkt[pos];
    if (c == '"') quoted = !quoted;
    if (quoted) continue;
    if (c == '[' || c == '(') {
      if (depth == 1) return pos;  // the child's bracket; its keyword is just before it
      ++depth;
    } else if (c == ']' || c == ')') {
      if (--depth <= 0) return std::string::npos;
    }
  }
  return std::string::npos;
}

// Start of the keyword of the first child node that is itself a CRS (skips the name string).
inline std::size_t wkt_first_crs_child(const std::string& wkt, std::size_t after_keyword) {
  const std::size_t bracket = wkt_first_child(wkt, after_keyword);
  if (bracket == std::string::npos) return std::string::npos;
  std::size_t start = bracket;
  while (start > 0 && (std::isalnum(static_cast<unsigned char>(wkt[start - 1])) || wkt[start - 1] == '_')) --start;
  return start;
}

inline CrsKind crs_kind_at(const std::string& wkt, std::size_t pos, int depth) {
  if (depth > 4) return CrsKind::unknown;
  const std::string key = wkt_keyword(wkt, pos);
  if (key == "GEOGCS" || key == "GEOGCRS" || key == "GEOGRAPHICCRS") return CrsKind::geographic;
  if (key == "PROJCS" || key == "PROJCRS" || key == "PROJECTEDCRS") return CrsKind::projected;
  if (key == "GEOCCS") return CrsKind::geocentric;
  if (key == "LOCAL_CS" || key == "ENGCRS" || key == "ENGINEERINGCRS") return CrsKind::engineering;
  if (key == "GEODCRS" || key == "GEODETICCRS") {
    // WKT2 writes both kinds so; the coordinate system says which.
    std::string upper;
    for (std::size_t i = pos; i < wkt.size(); ++i) upper += static_cast<char>(std::toupper(static_cast<unsigned char>(wkt[i])));
    if (upper.find("CS[ELLIPSOIDAL") != std::string::npos) return CrsKind::geographic;
    if (upper.find("CS[CARTESIAN") != std::string::npos) return CrsKind::geocentric;
    return CrsKind::unknown;
  }
  if (key == "COMPD_CS" || key == "COMPOUNDCRS" || key == "BOUNDCRS") {
    // The horizontal CRS is the first component (BOUNDCRS: its SOURCECRS node, whose child is it).
    const std::size_t child = wkt_first_crs_child(wkt, pos);
    if (child == std::string::npos) return CrsKind::unknown;
    if (key == "BOUNDCRS") {
      std::size_t p = child;
      if (wkt_keyword(wkt, p) != "SOURCECRS") return CrsKind::unknown;
      const std::size_t bracket = wkt.find_first_of("[(", p);  // SOURCECRS holds the CRS itself
      if (bracket == std::string::npos) return CrsKind::unknown;
      return crs_kind_at(wkt, bracket + 1, depth + 1);
    }
    return crs_kind_at(wkt, child, depth + 1);
  }
  return CrsKind::unknown;
}

}  // namespace detail

/// The kind of the CRS in `crs` (WKT1 or WKT2; anything else is `unknown`).
inline CrsKind crs_kind(const std::string& crs) { return detail::crs_kind_at(crs, 0, 0); }

}  // namespace diachron
