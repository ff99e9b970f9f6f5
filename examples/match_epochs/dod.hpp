#pragma once
// match_epochs (examples/match_epochs/main.cpp): the DoD maps of the free epochs.

namespace match_epochs {

using namespace diachron;

// The DoD of a free epoch against the reference (eval/dod_map.hpp): its DSM moved into the
// reference's frame, differenced on the reference's grid, with statistics over every cell and
// over stable terrain: the cells within kStableCells reference DSM cells of a final match with the
// reference, ground that looked alike across the decades (the ground filter kept it).
constexpr double kStableCells = 4.0;

struct EpochDod {
  std::size_t epoch = 0;
  std::size_t stable_points = 0;  // matches with the reference placed on its DSM
  DodMapStatistics rough, adjusted;
  bool has_adjusted = false;
  Dsm rough_dz, adjusted_dz;      // the maps (empty: none), kept to draw both in one colour range
  double range_m = 0.0;           // the pictures' colour range
  double nonrigid_rms = std::numeric_limits<double>::quiet_NaN();  // reintersection's bend beyond a similarity
};

// Where the final matches of epoch k with the reference lie on the reference's DSM: the
// reference pixel's ray met with it.
std::vector<Eigen::Vector3d> stable_points(const std::vector<Epoch>& epochs, std::size_t reference,
                                           const std::vector<EpochPair>& pairs, std::size_t k) {
  std::vector<Eigen::Vector3d> out;
  for (const EpochPair& ep : pairs) {
    if (ep.master != k || ep.secondary != reference) continue;
    for (const PrecisePairReport& p : ep.precise.pairs)
      for (const PointMatch& m : p.matches) {
        const std::optional<Ray3> ray = epochs[reference].frames[p.secondary].ray(m.b);
        if (!ray) continue;
        const RayDsmResult hit = intersect_ray_dsm(epochs[reference].folder.dsm, *ray);
        if (hit.success) out.push_back(hit.point);
      }
  }
  return out;
}

// One DoD map: computed, written as DIR/dod/<stem>.tif (float, nodata where either DSM has none),
// kept in `dz`, its statistics returned; `stable` empty: no stable mask (its statistics NaN).
DodMapStatistics compute_dod(const std::string& dir, const std::string& stem, const Dsm& reference, const Dsm& moving,
                             const Helmert3& reference_from_moving, const Raster<std::uint8_t>& stable, Dsm& dz,
                             std::size_t threads) {
  DodMapOptions options;
  options.threads = threads;
  DodMap map = dod_map(reference, moving, reference_from_moving, options);
  if (!map.success) {
    DodMapStatistics none;
    none.reason = map.reason;
    return none;
  }
  write_geotiff_dsm(map.dz, dir + "/" + stem + ".tif");
  dz = std::move(map.dz);
  return dod_map_statistics(dz, stable.empty() ? nullptr : &stable);
}

// The pictures of an epoch's maps, DIR/dod/<name>_rough.png and <name>.png, in one colour range
// (the wider of the two maps' defaults) so that they compare at a glance.
void draw_dods(const std::string& dir, EpochDod& d, const std::string& name, const std::string& reference,
               const Raster<std::uint8_t>& stable) {
  DrawDodOptions picture;
  picture.stable = stable.empty() ? nullptr : &stable;
  d.range_m = 0.0;
  for (const Dsm* dz : {&d.rough_dz, &d.adjusted_dz})
    if (!dz->empty()) d.range_m = std::max(d.range_m, dod_colour_range(*dz, picture));
  picture.range_m = d.range_m;
  if (!d.rough_dz.empty()) {
    picture.title = name + " - " + reference + ", rough co-registration";
    write_dod_png(dir + "/" + name + "_rough.png", d.rough_dz, picture);
  }
  if (!d.adjusted_dz.empty()) {
    picture.title = name + " - " + reference + ", adjusted";
    write_dod_png(dir + "/" + name + ".png", d.adjusted_dz, picture);
  }
}

void dod_statistics_json(std::ostream& o, const ErrorStatistics& e) {
  o << "{\"cells\": " << e.count << ", \"mean\": " << json_number_or_null(e.mean) << ", \"sigma\": "
    << json_number_or_null(e.sigma) << ", \"mean_abs\": " << json_number_or_null(e.mean_abs)
    << ", \"median\": " << json_number_or_null(e.median) << ", \"nmad\": " << json_number_or_null(e.nmad) << "}";
}

// The "dod" section of report.json: per free epoch, the paper's mu, sigma, |mu| plus median and
// NMAD over every valid cell and over stable terrain, rough and adjusted (reference units).
std::string dod_json(const std::vector<EpochDod>& dods, const std::vector<Epoch>& epochs) {
  std::ostringstream o;
  o.precision(6);
  o << "  \"dod\": {\"stable_radius_cells\": " << kStableCells;
  for (const EpochDod& d : dods) {
    o << ",\n    " << quoted(epochs[d.epoch].name) << ": {\"stable_points\": " << d.stable_points
      << ", \"colour_range\": " << json_number_or_null(d.range_m) << ", \"reintersection_nonrigid_rms\": "
      << json_number_or_null(d.nonrigid_rms);
    for (const auto& [name, s] : {std::make_pair("rough", &d.rough), std::make_pair("adjusted", &d.adjusted)}) {
      if (name == std::string("adjusted") && !d.has_adjusted) continue;
      o << ",\n      \"" << name << "\": ";
      if (!s->success) {
        o << "{\"message\": " << quoted(s->reason) << "}";
        continue;
      }
      o << "{\"all\": ";
      dod_statistics_json(o, s->all);
      o << ", \"stable\": ";
      dod_statistics_json(o, s->stable);
      o << "}";
    }
    o << "}";
  }
  o << "},\n";
  return o.str();
}

// The free epochs not tied to the reference through pairs with final matches (a chain of them
// counts), in order; empty when all are.
std::vector<std::size_t> untied_epochs(const std::vector<Epoch>& epochs, std::size_t reference,
                                       const std::vector<EpochPair>& pairs) {
  std::vector<bool> tied(epochs.size(), false);
  tied[reference] = true;
  for (bool grew = true; grew;) {
    grew = false;
    for (const EpochPair& p : pairs)
      if (p.precise.success && tied[p.master] != tied[p.secondary]) tied[p.master] = tied[p.secondary] = grew = true;
  }
  std::vector<std::size_t> out;
  for (std::size_t e = 0; e < epochs.size(); ++e)
    if (!tied[e]) out.push_back(e);
  return out;
}

}  // namespace match_epochs
