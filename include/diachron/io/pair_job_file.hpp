#pragma once
/// @file
/// The result of one pair job (match_epochs run-pair, docs/scaling.md): what precise matching found
/// for one image pair of two epochs, as a JSON file that the merge reads back exactly (doubles with
/// 17 significant digits). It keeps what the outputs need (the final matches, the counts of each
/// stage, the message, the seconds), not the tentative lists: a merge of thousands of pairs holds
/// only their final matches.
///
/// @code
/// {"format": "diachron pair job 1", "plan_id": "...", "index": 17,
///  "master_epoch": "1954", "secondary_epoch": "2015", "master_image": "a.tif", "secondary_image": "b.tif",
///  "master": 3, "secondary": 5, "success": true, "message": "...",
///  "tentative": 512, "masked": 0, "after_ground_filter": 180,
///  "seconds": {"images": 0.4, "tentative": 9.1, "ground": 0.2, "ncc": 1.0, "total": 10.7},
///  "matches": [[xa, ya, xb, yb, score], ...]}
/// @endcode
/// Pixels in diachron's convention (docs/conventions.md), master image first.

#include <cmath>
#include <cstddef>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include <diachron/core/error.hpp>
#include <diachron/io/atomic_file.hpp>
#include <diachron/io/json.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/pipeline/precise_matching.hpp>

namespace diachron {

/// One pair job's result. Default: no job ran (index and plan unset, no success).
struct PairJobRecord {
  std::string plan_id;  ///< the plan it belongs to (a merge refuses results of another plan)
  std::size_t index = 0;  ///< the job's index in the plan
  std::string master_epoch, secondary_epoch;  ///< the epochs' names
  std::string master_image, secondary_image;  ///< the images' names (as their models name them)
  std::size_t master = 0, secondary = 0;      ///< the images' indices in their epochs
  bool success = false;                       ///< at least one final match
  std::string message;
  std::size_t tentative = 0, masked = 0, grounded = 0;  ///< counts of PrecisePairReport's lists
  PointMatches matches;                                 ///< the final matches
  PrecisePairSeconds seconds;
};

/// The record of `report` for job `index` of plan `plan_id` (the names are the caller's).
inline PairJobRecord pair_job_record(const PrecisePairReport& report, const std::string& plan_id, std::size_t index) {
  PairJobRecord r;
  r.plan_id = plan_id;
  r.index = index;
  r.master = report.master;
  r.secondary = report.secondary;
  r.success = report.success;
  r.message = report.message;
  r.tentative = report.tentative.size();
  r.masked = report.masked;
  r.grounded = report.grounded.size();
  r.matches = report.matches;
  r.seconds = report.seconds;
  return r;
}

/// The report `r` was made from, as far as the record keeps it: the final matches, the message,
/// the masked count and the seconds; the tentative and grounded lists are empty (their sizes are
/// `r.tentative` and `r.grounded`). What combined_epochs' epoch_pair_matches() and the orthophoto
/// reference read.
inline PrecisePairReport precise_pair_report(const PairJobRecord& r) {
  PrecisePairReport p;
  p.master = r.master;
  p.secondary = r.secondary;
  p.success = r.success;
  p.message = r.message;
  p.masked = r.masked;
  p.matches = r.matches;
  p.seconds = r.seconds;
  return p;
}

/// The JSON text of `r` (the layout in the file comment).
inline std::string pair_job_json(const PairJobRecord& r) {
  std::ostringstream o;
  o << "{\"format\": \"diachron pair job 1\", \"plan_id\": " << json_quoted(r.plan_id) << ", \"index\": " << r.index
    << ",\n \"master_epoch\": " << json_quoted(r.master_epoch) << ", \"secondary_epoch\": " << json_quoted(r.secondary_epoch)
    << ", \"master_image\": " << json_quoted(r.master_image) << ", \"secondary_image\": " << json_quoted(r.secondary_image)
    << ",\n \"master\": " << r.master << ", \"secondary\": " << r.secondary
    << ", \"success\": " << (r.success ? "true" : "false") << ", \"message\": " << json_quoted(r.message)
    << ",\n \"tentative\": " << r.tentative << ", \"masked\": " << r.masked << ", \"after_ground_filter\": " << r.grounded
    << ",\n \"seconds\": {\"images\": " << json_number(r.seconds.images) << ", \"tentative\": "
    << json_number(r.seconds.tentative) << ", \"ground\": " << json_number(r.seconds.ground)
    << ", \"ncc\": " << json_number(r.seconds.ncc) << ", \"total\": " << json_number(r.seconds.total)
    << "},\n \"matches\": [";
  for (std::size_t k = 0; k < r.matches.size(); ++k) {
    const PointMatch& m = r.matches[k];
    o << (k ? ",\n  [" : "\n  [") << json_number(m.a.x()) << ", " << json_number(m.a.y()) << ", "
      << json_number(m.b.x()) << ", " << json_number(m.b.y()) << ", " << json_number(m.score) << "]";
  }
  o << "]}\n";
  return o.str();
}

/// Writes `r` to `path` atomically (io/atomic_file.hpp): a reader never sees half a result.
inline void write_pair_job(const std::string& path, const PairJobRecord& r) { write_file_atomically(path, pair_job_json(r)); }

namespace detail {

inline const JsonValue& pair_job_member(const JsonValue& v, const char* key, JsonValue::Type type,
                                        const std::string& path) {
  const JsonValue* m = v.find(key);
  DIACHRON_CHECK(m != nullptr, "'" << path << "': no \"" << key << "\": not a complete pair job result");
  DIACHRON_CHECK(m->type == type, "'" << path << "': \"" << key << "\" is a " << json_type_name(m->type) << ", not a "
                                      << json_type_name(type));
  return *m;
}

inline std::size_t pair_job_count(const JsonValue& v, const char* key, const std::string& path) {
  const double x = pair_job_member(v, key, JsonValue::Type::number, path).number;
  DIACHRON_CHECK(x >= 0.0 && x <= 9.007199254740992e15 && x == static_cast<double>(static_cast<std::size_t>(x)),
                 "'" << path << "': \"" << key << "\" is " << x << ", not a count");
  return static_cast<std::size_t>(x);
}

inline double pair_job_number(const JsonValue& v, const char* key, const std::string& path) {
  const double x = pair_job_member(v, key, JsonValue::Type::number, path).number;
  DIACHRON_CHECK(std::isfinite(x), "'" << path << "': \"" << key << "\" is not finite");
  return x;
}

}  // namespace detail

/// Reads a file written by write_pair_job(). Throws diachron::Error naming the file when it is
/// missing, is not JSON, is of another format, or misses a member.
inline PairJobRecord read_pair_job(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  DIACHRON_CHECK(in.good(), "cannot read '" << path << "'");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const JsonValue v = parse_json(text, path);
  using T = JsonValue::Type;
  DIACHRON_CHECK(v.type == T::object, "'" << path << "' is not a pair job result (not a JSON object)");
  DIACHRON_CHECK(detail::pair_job_member(v, "format", T::string, path).string == "diachron pair job 1",
                 "'" << path << "' is of another format (\"" << v.find("format")->string << "\")");
  PairJobRecord r;
  r.plan_id = detail::pair_job_member(v, "plan_id", T::string, path).string;
  r.index = detail::pair_job_count(v, "index", path);
  r.master_epoch = detail::pair_job_member(v, "master_epoch", T::string, path).string;
  r.secondary_epoch = detail::pair_job_member(v, "secondary_epoch", T::string, path).string;
  r.master_image = detail::pair_job_member(v, "master_image", T::string, path).string;
  r.secondary_image = detail::pair_job_member(v, "secondary_image", T::string, path).string;
  r.master = detail::pair_job_count(v, "master", path);
  r.secondary = detail::pair_job_count(v, "secondary", path);
  r.success = detail::pair_job_member(v, "success", T::boolean, path).boolean;
  r.message = detail::pair_job_member(v, "message", T::string, path).string;
  r.tentative = detail::pair_job_count(v, "tentative", path);
  r.masked = detail::pair_job_count(v, "masked", path);
  r.grounded = detail::pair_job_count(v, "after_ground_filter", path);
  const JsonValue& s = detail::pair_job_member(v, "seconds", T::object, path);
  r.seconds.images = detail::pair_job_number(s, "images", path);
  r.seconds.tentative = detail::pair_job_number(s, "tentative", path);
  r.seconds.ground = detail::pair_job_number(s, "ground", path);
  r.seconds.ncc = detail::pair_job_number(s, "ncc", path);
  r.seconds.total = detail::pair_job_number(s, "total", path);
  const JsonValue& matches = detail::pair_job_member(v, "matches", T::array, path);
  r.matches.reserve(matches.array.size());
  for (const JsonValue& m : matches.array) {
    DIACHRON_CHECK(m.type == T::array && m.array.size() == 5,
                   "'" << path << "': a match is not [xa, ya, xb, yb, score]");
    double x[5];
    for (int k = 0; k < 5; ++k) {
      DIACHRON_CHECK(m.array[k].type == T::number && std::isfinite(m.array[k].number),
                     "'" << path << "': a match holds a value that is not a finite number");
      x[k] = m.array[k].number;
    }
    r.matches.push_back({Eigen::Vector2d(x[0], x[1]), Eigen::Vector2d(x[2], x[3]), x[4]});
  }
  DIACHRON_CHECK(r.success == !r.matches.empty(),
                 "'" << path << "': \"success\" says " << (r.success ? "true" : "false") << " with "
                     << r.matches.size() << " matches");
  return r;
}

}  // namespace diachron
