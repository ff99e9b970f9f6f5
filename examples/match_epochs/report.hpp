#pragma once
// match_epochs (examples/match_epochs/main.cpp): report.json.

namespace match_epochs {

using namespace diachron;

// The ground filter's threshold (GSD of the secondary image) that `method` uses: correlation matches
// have their own, tighter one (PreciseCorrelationOptions); the descriptor methods the shared one.
template <class Options>
auto& ground_threshold_gsd(Options& options, const std::string& method) {
  return method == "correlation" ? options.correlation.ground_threshold_gsd : options.ground.threshold_gsd;
}


// The rough co-registration of one epoch into the reference, as report.json gives it.
void write_rough_json(std::ostream& out, const Epoch& e) {
  const RoughCoregistrationReport& rough = e.rough;
  const std::string source = e.rough_mode == "auto" ? "dsm" : e.rough_mode == "identity" ? "identity" : "file";
  out << "{\"source\": " << quoted(source) << ", \"via\": " << (e.via.empty() ? "null" : quoted(e.via))
      << ", \"success\": " << (rough.success ? "true" : "false")
      << ", \"message\": " << quoted(rough.message) << ", \"inliers_2d\": " << rough.inliers_2d.size()
      << ", \"inliers_3d\": " << rough.inliers_3d.size() << ", \"rms_3d\": " << rough.rms_3d
      << ", \"trust\": " << quoted(to_string(rough.trust))
      << ", \"correlation_fallback_ran\": " << (rough.correlation_ran ? "true" : "false")
      << ", \"correlation_fallback_used\": " << (rough.correlation_used ? "true" : "false")
      << ", \"seconds_correlation_fallback\": " << rough.seconds.correlation
      << ", \"correlation_fallback_by_tiles\": " << (rough.correlation_used && rough.correlation.by_tiles ? "true" : "false")
      << ", \"surface_refinement\": " << quoted(rough.surface.message)
      << ", \"surface_refinement_accepted\": " << (rough.surface.accepted ? "true" : "false")
      << ", \"correlation_fallback_confirmed_by_surface\": " << (rough.confirmed_by_surface ? "true" : "false")
      << ", \"surface_noise_ratio\": "
      << (rough.agreement.valid && std::isfinite(rough.agreement.noise_ratio) ? std::to_string(rough.agreement.noise_ratio)
                                                                                : std::string("null"))
      << ", \"seconds\": " << rough.seconds.total << "}";
}

// An epoch's input checks (io/epoch_folder_check.hpp) as report.json gives them.
void input_check_json(std::ostream& o, const EpochFolderCheck& c) {
  const ModelDsmAgreement& a = c.agreement;
  double least = 1.0;
  for (double share : c.footprint_share) least = std::min(least, share);
  o << "{\"model_dsm\": {\"verdict\": " << quoted(to_string(a.verdict)) << ", \"message\": " << quoted(a.message)
    << ", \"points\": " << a.points << ", \"on_dsm\": " << a.on_dsm << ", \"tolerance\": " << json_number_or_null(a.tolerance)
    << ", \"median_dz\": " << json_number_or_null(a.median_dz) << ", \"nmad_dz\": " << json_number_or_null(a.nmad_dz)
    << ", \"share_within\": " << json_number_or_null(a.share_within) << ", \"best_offset\": ["
    << json_number_or_null(a.best_offset.x()) << ", " << json_number_or_null(a.best_offset.y()) << ", "
    << json_number_or_null(a.best_offset.z()) << "], \"best_share\": " << json_number_or_null(a.best_share)
    << "}, \"gsd\": " << json_number_or_null(c.gsd) << ", \"least_footprint_share\": "
    << (c.footprint_share.empty() ? std::string("null") : json_number_or_null(least))
    << ", \"unreadable_images\": " << c.unreadable_images << ", \"wrong_size_images\": " << c.wrong_size_images
    << ", \"issues\": [";
  for (std::size_t k = 0; k < c.issues.size(); ++k)
    o << (k ? ", " : "") << "{\"severity\": " << quoted(to_string(c.issues[k].severity)) << ", \"check\": "
      << quoted(c.issues[k].check) << ", \"what\": " << quoted(c.issues[k].what) << ", \"remedy\": "
      << quoted(c.issues[k].remedy) << "}";
  o << "]}";
}

// report.json: per epoch (its co-registration), per epoch pair (overlapping pairs, matches).
// `sections`: further top-level members, each "  \"key\": ...,\n" (the adjustment's).
void write_report(const std::string& path, const std::vector<Epoch>& epochs, std::size_t reference,
                  const std::vector<EpochPair>& pairs, const PreciseMatchingOptions& options, const std::string& method,
                  const std::string& matcher, const std::string& sections = "") {
  std::ofstream out(path);
  DIACHRON_CHECK(out.good(), "cannot write " << path);
  out.precision(10);
  out << "{\n  \"method\": " << quoted(method) << ",\n  \"matcher\": " << quoted(matcher) << ",\n";
  out << sections;
  out << "  \"reference\": " << quoted(epochs[reference].name) << ",\n  \"epochs\": [";
  for (std::size_t k = 0; k < epochs.size(); ++k) {
    const Epoch& e = epochs[k];
    out << (k ? ",\n    " : "\n    ") << "{\"name\": " << quoted(e.name) << ", \"folder\": " << quoted(e.dir)
        << ", \"kind\": " << quoted(e.folder.is_ortho() ? "orthophoto" : "photos") << ", \"images\": "
        << e.folder.images.size() << ", \"masks\": " << e.folder.masks()
        << ", \"reference\": " << (k == reference ? "true" : "false") << ",\n     \"rough_coregistration\": ";
    out << (k == reference ? std::string("null") : e.rough_json);
    out << "}";
  }
  out << "],\n";
  out << "  \"ground_filter\": {\"on\": " << (options.use_ground_filter ? "true" : "false")
      << ", \"threshold_gsd\": " << ground_threshold_gsd(options, method);
  if (method == "correlation") out << ", \"floor_master_gsd\": " << options.correlation.ground_floor_master_gsd;
  out << "},\n";
  if (method == "correlation")
    out << "  \"master_sharpen\": {\"amount\": " << options.correlation.master_sharpen.amount
        << ", \"sigma_px\": " << options.correlation.master_sharpen.sigma_px << "},\n";
  std::size_t tentative = 0, grounded = 0, final_matches = 0;
  double seconds = 0.0;
  for (const EpochPair& p : pairs) {
    tentative += p.precise.tentative;
    grounded += p.precise.grounded;
    final_matches += p.precise.final_matches;
    seconds += p.precise.seconds_total;
  }
  out << "  \"precise_matching\": {\"tentative\": " << tentative << ", \"after_ground_filter\": " << grounded
      << ", \"final\": " << final_matches << ", \"seconds\": " << seconds << "},\n";
  out << "  \"epoch_pairs\": [";
  for (std::size_t q = 0; q < pairs.size(); ++q) {
    const EpochPair& ep = pairs[q];
    const Epoch& a = epochs[ep.master];
    const Epoch& b = epochs[ep.secondary];
    const OverlappingPairsResult& overlap = ep.overlap;
    const PreciseMatchingReport& precise = ep.precise;
    out << (q ? ",\n    " : "\n    ") << "{\"master\": " << quoted(a.name) << ", \"secondary\": " << quoted(b.name)
        << ",\n     \"overlapping_pairs\": {\"candidates\": " << overlap.candidate_pairs
        << ", \"overlapping\": " << overlap.overlapping_pairs << ", \"kept\": " << overlap.pairs.size()
        << ", \"invalid_footprints\": [" << overlap.invalid_master_footprints << ", "
        << overlap.invalid_secondary_footprints << "], \"message\": " << quoted(overlap.message) << "},\n";
    out << "     \"precise_matching\": {\"success\": " << (precise.success ? "true" : "false")
        << ", \"message\": " << quoted(precise.message) << ", \"tentative\": " << precise.tentative
        << ", \"after_ground_filter\": " << precise.grounded << ", \"final\": " << precise.final_matches
        << ", \"seconds_features\": " << precise.seconds_features << ", \"seconds\": " << precise.seconds_total
        << ",\n      \"pairs\": [";
    for (std::size_t k = 0; k < ep.records.size() && k < overlap.pairs.size(); ++k) {
      const PairJobRecord& p = ep.records[k];
      const ImagePairOverlap& o = overlap.pairs[k];
      out << (k ? ",\n        " : "\n        ") << "{\"master\": " << quoted(a.folder.images[p.master].name)
          << ", \"secondary\": " << quoted(b.folder.images[p.secondary].name)
          << ", \"overlap_fraction\": " << o.fraction_of_smaller << ", \"tentative\": " << p.tentative
          << ", \"masked\": " << p.masked << ", \"after_ground_filter\": " << p.grounded
          << ", \"final\": " << p.matches.size() << ", \"message\": " << quoted(p.message)
          << ", \"seconds\": {\"images\": " << p.seconds.images << ", \"tentative\": " << p.seconds.tentative
          << ", \"ground\": " << p.seconds.ground << ", \"ncc\": " << p.seconds.ncc << ", \"total\": " << p.seconds.total
          << "}}";
    }
    out << "]}}";
  }
  out << "]\n}\n";
  out.close();
  DIACHRON_CHECK(!out.fail(), "cannot write " << path);
}

}  // namespace match_epochs
