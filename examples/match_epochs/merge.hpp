#pragma once
// match_epochs (examples/match_epochs/main.cpp): the merge. Every pair job's result read back (all
// of them, of this plan, or a refusal that names the missing ones and the commands that make them),
// then the outputs: Homol/, the pair pictures, the DoD maps, and with --adjust the combined
// adjustment and its exports. Writes into `work` (the caller moves it into place).

namespace match_epochs {

using namespace diachron;
using diachron::programs::Progress;

// Reads every job's result into the pairs (PrecisePairReport without tentative lists, as
// precise matching would have reported them). Throws diachron::Error naming the missing jobs and
// the command for each range of them, or a result of another plan.
void read_job_results(Run& run, const std::string& plan_dir, const std::string& plan_path) {
  std::vector<std::size_t> missing;
  std::vector<std::string> foreign;
  for (EpochPair& ep : run.pairs) {
    ep.records.clear();
    ep.precise = PreciseMatchingReport{};
    for (std::size_t k = 0; k < ep.overlap.pairs.size(); ++k) {
      const std::size_t index = ep.first_job + k;
      const std::string path = job_stem(plan_dir, index) + ".json";
      if (!is_regular_file(path)) {
        missing.push_back(index);
        continue;
      }
      PairJobRecord r = read_pair_job(path);
      const ImagePairOverlap& o = ep.overlap.pairs[k];
      if (r.plan_id != run.plan_id || r.index != index || r.master != o.master || r.secondary != o.secondary) {
        foreign.push_back(path);
        continue;
      }
      ep.precise.pairs.push_back(precise_pair_report(r));
      ep.records.push_back(std::move(r));
    }
  }
  if (!foreign.empty())
    DIACHRON_CHECK(false, foreign.size() << " pair job result(s) belong to another plan or job (e.g. '" << foreign.front()
                                         << "'): remove them and run their jobs again (match_epochs run-pair --plan "
                                         << plan_path << " --index I)");
  if (!missing.empty()) {
    const std::vector<IndexRange> ranges = index_ranges(missing);
    std::ostringstream m;
    m << missing.size() << " of " << run.jobs << " pair jobs have no result in " << plan_dir << "/jobs ("
      << index_ranges_text(ranges, 8) << "): run them, then merge again:";
    for (std::size_t k = 0; k < ranges.size() && k < 8; ++k)
      m << "\n  match_epochs run-pair --plan " << plan_path << " --range " << ranges[k].first << "-" << ranges[k].last;
    if (ranges.size() > 8) m << "\n  ...";
    DIACHRON_CHECK(false, m.str());
  }
  // The totals of each epoch pair, as precise matching gives them (seconds: the sum over its pairs).
  for (EpochPair& ep : run.pairs) {
    PreciseMatchingReport& out = ep.precise;
    std::size_t with_matches = 0;
    for (const PairJobRecord& r : ep.records) {
      out.tentative += r.tentative;
      out.grounded += r.grounded;
      out.final_matches += r.matches.size();
      out.seconds_total += r.seconds.total;
      with_matches += r.success;
    }
    out.success = with_matches > 0;
    out.message = ep.records.empty() ? std::string("no overlapping pair")
                                     : std::to_string(with_matches) + " of " + std::to_string(ep.records.size()) +
                                           " pairs with matches, " + std::to_string(out.final_matches) + " final matches";
  }
}

// Links (or copies) `from` to `to`.
void link_or_copy(const std::string& from, const std::string& to) {
  std::error_code error;
  std::filesystem::create_hard_link(from, to, error);
  if (error) std::filesystem::copy_file(from, to, std::filesystem::copy_options::overwrite_existing);
}

// The merge: 0 success, 2 no answer (no match tying an epoch, no adjustment: said on stdout).
int merge_stage(Run& run, const std::string& plan_dir, const std::string& plan_path, const std::string& work,
                const std::string& out_dir, Reporter& reporter, std::size_t threads) {
  const Settings& s = run.settings;
  for (std::size_t k = 0; k < run.epochs.size(); ++k) load_epoch(run, k, plan_path);
  const bool renamed = set_homol_names(run.epochs);
  read_job_results(run, plan_dir, plan_path);
  std::vector<Epoch>& epochs = run.epochs;
  const std::size_t reference = run.reference;
  std::vector<EpochPair>& pairs = run.pairs;
  std::vector<std::string>& warnings = run.warnings;
  std::string& trust = reporter.trust;
  std::vector<std::string>& trust_reasons = reporter.trust_reasons;
  RunClock& run_clock = reporter.clock;
  const auto report = [&](const std::string& sections) { reporter.write(work, sections); };
  const auto finish = [](int status) { return status; };
  const bool pictures = s.pictures;
  run_clock.stage("reading the pair jobs' results");
  for (std::size_t k = 0; k < reference; ++k)
    write_helmert_json(epochs[k].reference_from_epoch, work + "/rough_helmert_" + epochs[k].name + ".json");

  // 4. Outputs.
  report("");
  const std::string homol = work + "/Homol";
  make_folder(homol, "match_epochs");
  if (renamed) write_homol_names(work + "/homol_names.txt", epochs);
  if (pictures) make_folder(work + "/pairs", "match_epochs");
  for (const EpochPair& ep : pairs) {
    const Epoch& ea = epochs[ep.master];
    const Epoch& eb = epochs[ep.secondary];
    for (std::size_t k = 0; k < ep.records.size(); ++k) {
      const PairJobRecord& p = ep.records[k];
      const std::string& a = ea.homol[p.master];
      const std::string& b = eb.homol[p.secondary];
      std::printf("%s -- %s: %zu tentative, %zu after the ground filter, %zu final\n",
                  ea.folder.images[p.master].name.c_str(), eb.folder.images[p.secondary].name.c_str(), p.tentative,
                  p.grounded, p.matches.size());
      if (p.matches.empty()) continue;
      write_homol(homol, a, b, p.matches);
      const std::string jpg = job_stem(plan_dir, ep.first_job + k) + ".jpg";
      if (pictures && is_regular_file(jpg)) link_or_copy(jpg, work + "/pairs/" + safe(a) + "__" + safe(b) + ".jpg");
    }
    std::printf("%s -- %s: %s (%.1f s)\n", ea.name.c_str(), eb.name.c_str(), ep.precise.message.c_str(),
                ep.precise.seconds_total);
  }
  run_clock.stage("tie points and pictures");
  // Every free epoch must be tied to the reference by matches, directly or through other epochs.
  const std::vector<std::size_t> untied = untied_epochs(epochs, reference, pairs);
  if (!untied.empty()) {
    std::string names, why;
    for (std::size_t k : untied) names += (names.empty() ? "" : ", ") + epochs[k].name;
    for (const EpochPair& p : pairs)
      if (p.master == untied.front() || p.secondary == untied.front())
        why += (why.empty() ? "" : "; ") + epochs[p.master].name + " -- " + epochs[p.secondary].name + ": " +
               (p.overlap.pairs.empty() ? std::string("no overlapping pair") : p.precise.message);
    std::printf("no inter-epoch match tying %s to the reference %s: %s\n", names.c_str(),
                epochs[reference].name.c_str(), why.c_str());
    return finish(2);
  }

#if DIACHRON_MATCH_EPOCHS_ADJUST
  const std::string& affine = s.affine;
  const std::string& colmap_format = s.colmap_format;
  const std::vector<Intrinsic> held = parse_intrinsics(s.hold);
  const std::vector<IntrinsicPrior> priors = parse_priors(s.prior);
  const std::vector<ControlPointRecord>& control = s.control;
  const std::vector<EpochsControlPoint> control_points = epochs_control_points(s.control, epochs, "control point");
  const std::vector<EpochsControlPoint> check_points = epochs_control_points(s.check_records, epochs, "check point");
  const bool adjust = s.adjust, one_camera = s.one_camera;
#endif
  // 5. The DoD of every free epoch after the rough co-registration: DIR/dod/<epoch>_rough.*.
  const std::string dod_dir = work + "/dod";
  make_folder(dod_dir, "match_epochs");
  const Dsm& reference_dsm = epochs[reference].folder.dsm;
  std::vector<EpochDod> dods;
  std::vector<Raster<std::uint8_t>> stable_masks(epochs.size());
  for (std::size_t k = 0; k < reference; ++k) {
    EpochDod d;
    d.epoch = k;
    const std::vector<Eigen::Vector3d> points = stable_points(epochs, reference, pairs, k);
    d.stable_points = points.size();
    // An epoch tied to the reference only through other epochs has no such points: all cells then.
    if (!points.empty())
      stable_masks[k] = stable_mask_near_points(reference_dsm, points, kStableCells * reference_dsm.min_cell_size());
    d.rough = compute_dod(dod_dir, epochs[k].name + "_rough", reference_dsm, epochs[k].folder.dsm,
                          epochs[k].reference_from_epoch, stable_masks[k], d.rough_dz, threads);
    draw_dods(dod_dir, d, epochs[k].name, epochs[reference].name, stable_masks[k]);
    if (d.rough.success)
      std::printf("DoD %s - %s, rough: median %.3f, NMAD %.3f on stable terrain (%zu cells), %.3f, %.3f on all\n",
                  epochs[k].name.c_str(), epochs[reference].name.c_str(), d.rough.stable.median, d.rough.stable.nmad,
                  d.rough.stable.count, d.rough.all.median, d.rough.all.nmad);
    else
      std::printf("DoD %s - %s, rough: none (%s)\n", epochs[k].name.c_str(), epochs[reference].name.c_str(),
                  d.rough.reason.c_str());
    dods.push_back(std::move(d));
  }
  run_clock.stage("DoD maps");
  // The tie points' trust: what the input checks warned about (a run with --adjust adds the
  // adjustment's grade below).
  for (const std::string& w : warnings) trust_reasons.push_back("input: " + w);
  trust = trust_reasons.empty() ? "high" : "low";
  report(dod_json(dods, epochs));
#if DIACHRON_MATCH_EPOCHS_ADJUST
  if (adjust) {
    // 6. The combined adjustment of all epochs, the reference held.
    CombinedAdjustmentOptions adjustment_options;
    if (affine == "camera") adjustment_options.bundle.affine_scope = AffineScope::per_camera;
    EpochFreedom free_epoch = EpochFreedom::all_free();
    free_epoch.fixed_intrinsics = held;
    free_epoch.intrinsic_priors = priors;
    adjustment_options.bundle.epochs.assign(epochs.size(), free_epoch);
    adjustment_options.bundle.epochs[reference] = EpochFreedom::all_fixed();
    const bool ortho_reference = epochs[reference].folder.is_ortho();
    // An orthophoto reference is no image of the adjustment (an epoch without images): its
    // matches become control points observed in the free epochs' images
    // (pipeline/orthophoto_reference.hpp).
    std::vector<CombinedEpoch> combined;
    std::vector<Helmert3> reference_from_epoch;
    for (std::size_t k = 0; k < epochs.size(); ++k) {
      combined.push_back(k == reference && ortho_reference ? CombinedEpoch{}
                                                           : combined_epoch(epochs[k].folder, one_camera && k != reference));
      reference_from_epoch.push_back(k == reference ? Helmert3::identity() : epochs[k].reference_from_epoch);
    }
    std::vector<EpochsControlPoint> all_control = control_points;
    std::vector<EpochLinkMatches> links;
    for (const EpochPair& ep : pairs) {
      if (!ep.precise.success) continue;
      if (ep.secondary == reference && ortho_reference) {
        std::vector<OrthoFrame> tiles;
        for (const EpochImage& t : epochs[reference].folder.images) tiles.push_back(*t.ortho);
        const double sigma = orthophoto_control_sigma(
            combined[ep.master].frames, epochs[ep.master].reference_from_epoch, epochs[reference].folder.dsm.statistics().mean,
            epochs[reference].folder.ortho.cell_size(), adjustment_options.bundle.inter_epoch_sigma_px);
        const OrthophotoControlPoints from_ortho =
            orthophoto_control_points(ep.precise.pairs, tiles, epochs[reference].folder.dsm, sigma);
        for (const CombinedControlPoint& g : from_ortho.points) {
          EpochsControlPoint c{g.position, g.sigma, std::vector<std::vector<ImagePixel>>(epochs.size())};
          c.observations[ep.master] = g.epoch1;
          all_control.push_back(std::move(c));
        }
        std::printf("orthophoto reference: %zu of %zu matches of %s as control points (sigma %.3g reference units), "
                    "%zu without DSM height\n",
                    from_ortho.points.size(), from_ortho.matches, epochs[ep.master].name.c_str(), sigma,
                    from_ortho.off_dsm);
        continue;
      }
      links.push_back({ep.master, ep.secondary, epoch_pair_matches(ep.precise.pairs)});
    }
    const CombinedEpochsResult adjusted = combined_epochs_adjustment(combined, reference_from_epoch, reference, links,
                                                                     adjustment_options, all_control);
    std::vector<std::string> names;
    std::vector<std::size_t> image_epoch;
    for (std::size_t k = 0; k < epochs.size(); ++k)
      for (std::size_t i = 0; i < combined[k].frames.size(); ++i) {
        names.push_back(epochs[k].folder.images[i].name);
        image_epoch.push_back(k);
      }
    const BundleReport& r = adjusted.report;
    run_clock.stage("adjustment");
    std::printf("adjustment: %s\n", r.message.c_str());
    if (!control.empty()) {
      std::size_t used = 0;
      double worst = 0.0;
      for (const ControlPointOutcome& g : adjusted.control_points)
        if (g.used) {
          ++used;
          worst = std::max(worst, g.error.norm());
        }
      std::printf("control points: %zu of %zu used, largest error %.3f (reference units; report.json lists them)\n",
                  used, control.size(), worst);
    }
    // Each free epoch's check points triangulated in its images, after the rough co-registration
    // alone and after the adjustment: the paper's check-point table.
    std::vector<EpochCheckPoints> checked;
    for (std::size_t k = 0; k < reference && !check_points.empty(); ++k) {
      std::vector<ObservedCheckPoint> observed;
      for (const EpochsControlPoint& c : check_points) {
        ObservedCheckPoint p{c.position, {}};
        for (const ImagePixel& o : c.observations[k]) p.observations.push_back({static_cast<std::size_t>(o.image), o.pixel});
        observed.push_back(std::move(p));
      }
      const std::vector<Frame<FraserAffine>> moved = transformed_frames(combined[k].frames, reference_from_epoch[k]);
      EpochCheckPoints c{k, evaluate_check_points(observed, FrameTriangulator<FraserAffine>(moved)), {}};
      if (r.success) c.adjusted = evaluate_check_points(observed, FrameTriangulator<FraserAffine>(adjusted.epochs[k]));
      std::printf("check points of %s (reference units), %zu of %zu triangulated in its images:\n",
                  epochs[k].name.c_str(), c.rough.num_used, observed.size());
      std::printf("| orientation    | axis |    mean |  sigma | mean |e| |    RMS |\n");
      for (const auto& [name, report] : {std::make_pair("rough only", &c.rough), std::make_pair("adjusted", &c.adjusted)}) {
        if (!report->success) continue;
        const char* axis[3] = {"x", "y", "z"};
        for (std::size_t a = 0; a < 3; ++a)
          std::printf("| %-14s | %s    | %7.3f | %6.3f | %8.3f | %6.3f |\n", a == 0 ? name : "", axis[a],
                      report->axes_m[a].mean, report->axes_m[a].sigma, report->axes_m[a].mean_abs,
                      report->axes_m[a].rms);
      }
      if (c.rough.success && c.adjusted.success)
        std::printf("3D RMS of %s: rough only %.3f, adjusted %.3f\n", epochs[k].name.c_str(), c.rough.rms_3d_m,
                    c.adjusted.rms_3d_m);
      checked.push_back(std::move(c));
    }
    if (!r.success) {
      trust = "none";
      trust_reasons.push_back("the adjustment failed: " + r.message);
      report(adjustment_json(adjusted, epochs, image_epoch, names, nullptr,
                                   adjustment_options.bundle.affine_scope, control, checked) +
                       dod_json(dods, epochs));
      std::printf("no adjustment: %s\n", r.message.c_str());
      return finish(2);
    }
    std::vector<CamerasJsonImage> images;
    for (std::size_t k = 0; k < epochs.size(); ++k)
      for (std::size_t i = 0; i < adjusted.epochs[k].size(); ++i)  // none for an orthophoto reference
        images.push_back(CamerasJsonImage::from_frame(epochs[k].folder.images[i].name, epochs[k].name,
                                                      adjusted.epochs[k][i]));
    AdjustedExportOptions export_options;
    for (const Epoch& e : epochs) export_options.protected_folders.push_back(e.dir);
    const AdjustedExportReport exported = write_adjusted_export(images, work, export_options);
    // All epochs in one COLMAP model with the tracks as points3D (io/adjusted_export.hpp):
    // DIR/adjusted/colmap/sparse/ and images/ (links named <epoch>/<image>), for COLMAP's
    // model_analyzer, image_undistorter and dense stereo.
    std::vector<CamerasJsonImage> colmap_images = images;
    std::vector<std::string> colmap_paths;
    {
      std::size_t i = 0;
      for (std::size_t k = 0; k < epochs.size(); ++k)
        for (std::size_t j = 0; j < adjusted.epochs[k].size(); ++j, ++i) {
          colmap_images[i].name = epochs[k].name + "/" + colmap_images[i].name;
          colmap_paths.push_back(epochs[k].folder.images[j].path);
        }
    }
    std::vector<ExportTrack> tracks;
    for (std::size_t t = 0; t < adjusted.track_list.size(); ++t) {
      if (!adjusted.track_used[t] || !adjusted.points[t].allFinite()) continue;
      ExportTrack track{adjusted.points[t], {}};
      for (const TrackObservation& o : adjusted.track_list[t].observations)
        if (o.image >= 0 && static_cast<std::size_t>(o.image) < colmap_images.size())
          track.observations.push_back({static_cast<std::size_t>(o.image), o.pixel});
      if (track.observations.size() >= 2) tracks.push_back(std::move(track));
    }
    AdjustedColmapOptions colmap_options;
    colmap_options.format = colmap_format == "binary" ? ColmapFormat::binary : ColmapFormat::text;
    colmap_options.protected_folders = export_options.protected_folders;
    const AdjustedColmapReport colmap = write_adjusted_colmap(colmap_images, colmap_paths, tracks, work, colmap_options);
    // The same orientation for MicMac (io/micmac_orientation.hpp): DIR/adjusted/micmac/ is a MicMac
    // project with Ori-diachron/, links to the images under their Homol names (the names MicMac's
    // Homol/ and Ori- use) and to DIR/Homol, so that Malt, C3DC or Campari run in it as they are.
    const MicmacExport micmac = write_micmac_export(work + "/adjusted/micmac", epochs, images_homol_named(images, epochs),
                                                    epochs[reference].folder.dsm.statistics().mean);
    if (pictures) write_residual_pictures(work + "/adjusted/residuals", epochs, reference, adjusted);
    // The DoD after the adjustment: each free epoch's DSM placed by the similarity that best maps
    // its points onto where the adjusted orientation puts them (eval/dsm_reintersection.hpp):
    // DIR/dod/<epoch>.*, in the rough one's colours.
    for (EpochDod& d : dods) {
      const std::size_t k = d.epoch;
      DsmReintersectionOptions reintersection;
      reintersection.threads = threads;
      const DsmReintersection placed =
          reintersect_dsm(epochs[k].folder.dsm, combined[k].frames, adjusted.epochs[k], reintersection);
      d.has_adjusted = true;
      if (!placed.success) {
        d.adjusted.reason = placed.reason;
        std::printf("DoD %s - %s, adjusted: none (%s)\n", epochs[k].name.c_str(), epochs[reference].name.c_str(),
                    placed.reason.c_str());
        continue;
      }
      d.nonrigid_rms = placed.rms_nonrigid;
      write_helmert_json(placed.reference_from_epoch, dod_dir + "/" + epochs[k].name + "_helmert.json");
      d.adjusted = compute_dod(dod_dir, epochs[k].name, reference_dsm, epochs[k].folder.dsm,
                               placed.reference_from_epoch, stable_masks[k], d.adjusted_dz, threads);
      draw_dods(dod_dir, d, epochs[k].name, epochs[reference].name, stable_masks[k]);
      if (d.adjusted.success)
        std::printf("DoD %s - %s, adjusted: median %.3f, NMAD %.3f on stable terrain, %.3f, %.3f on all\n",
                    epochs[k].name.c_str(), epochs[reference].name.c_str(), d.adjusted.stable.median,
                    d.adjusted.stable.nmad, d.adjusted.all.median, d.adjusted.all.nmad);
    }
    run_clock.stage("export and DoD maps after the adjustment");
    // The grade: a camera that moved too far, an undetermined one, a wild export (adjustment/
    // adjustment_grade.hpp). A success graded low is reported as such, never as trusted.
    const AdjustmentGrade grade =
        grade_adjustment(r, std::max(exported.max_conversion_error_px, colmap.max_conversion_error_px));
    for (const std::string& reason : grade.reasons) {
      warn(warnings, "adjustment: " + reason);
      trust_reasons.push_back("adjustment: " + reason);
    }
    trust = trust_reasons.empty() ? "high" : "low";
    std::ostringstream exports;
    exports << "  \"colmap_export\": {\"model\": " << quoted("adjusted/colmap/sparse") << ", \"format\": "
            << quoted(colmap_format) << ", \"images\": " << colmap.images << ", \"points\": " << colmap.points
            << ", \"observations\": " << colmap.observations << ", \"cameras\": " << colmap.cameras.size()
            << ", \"max_conversion_error_px\": " << json_number_or_null(colmap.max_conversion_error_px)
            << ", \"mean_reprojection_error_px\": " << json_number_or_null(colmap.mean_reprojection_error_px) << "},\n";
    exports << "  \"micmac_export\": {\"ori\": " << quoted("adjusted/micmac/Ori-diachron") << ", \"calibrations\": "
            << micmac.written.calibrations.size() << ", \"max_conversion_error_px\": "
            << json_number_or_null(micmac.max_conversion_error_px) << "},\n";
    report(adjustment_json(adjusted, epochs, image_epoch, names, &exported, adjustment_options.bundle.affine_scope,
                           control, checked) +
           exports.str() + dod_json(dods, epochs));
    // Against an orthophoto the reference's ties are control points: no inter-epoch RMS of them.
    char inter[96];
    if (ortho_reference && links.empty())
      std::snprintf(inter, sizeof inter, "the orthophoto's matches as control points");
    else
      std::snprintf(inter, sizeof inter, "inter-epoch %.3f -> %.3f px", r.before.inter_epoch.rms_px,
                    r.after.inter_epoch.rms_px);
    std::printf("reprojection RMS %.3f -> %.3f px (%s); wrote %s and %s (largest COLMAP conversion error %.3f px)\n",
                r.before.all.rms_px, r.after.all.rms_px, inter, (out_dir + "/adjusted/cameras.json").c_str(),
                (out_dir + "/adjusted/<epoch>").c_str(), exported.max_conversion_error_px);
  }
#endif
  std::printf("trust: %s%s\n", trust.c_str(), trust_reasons.empty() ? "" : " (report.json's \"trust\" says why)");
  return 0;
}

}  // namespace match_epochs
