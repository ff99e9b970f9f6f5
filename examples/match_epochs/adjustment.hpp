#pragma once
// match_epochs (examples/match_epochs/main.cpp): what the combined adjustment needs and reports.

namespace match_epochs {

using namespace diachron;

#if DIACHRON_MATCH_EPOCHS_ADJUST
// "a,b" -> {"a", "b"}; "" -> none.
std::vector<std::string> comma_list(const std::string& list) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start < list.size()) {
    const std::size_t comma = std::min(list.find(',', start), list.size());
    out.push_back(list.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

// An intrinsic by the name report.json gives it; `option` names the option in the error.
Intrinsic intrinsic_named(const std::string& name, const char* option) {
  int k = 0;
  while (k < 8 && name != intrinsic_name(static_cast<Intrinsic>(k))) ++k;
  DIACHRON_CHECK(k < 8, option << ": unknown intrinsic '" << name << "' (f, cx, cy, K1, K2, K3, P1, P2)");
  return static_cast<Intrinsic>(k);
}

// --hold "K3,P1,P2" -> the intrinsics.
std::vector<Intrinsic> parse_intrinsics(const std::string& list) {
  std::vector<Intrinsic> out;
  for (const std::string& name : comma_list(list)) out.push_back(intrinsic_named(name, "--hold"));
  return out;
}

// --prior "f=2,cx=1" -> the priors.
std::vector<IntrinsicPrior> parse_priors(const std::string& list) {
  std::vector<IntrinsicPrior> out;
  for (const std::string& item : comma_list(list)) {
    const std::size_t eq = item.find('=');
    DIACHRON_CHECK(eq != std::string::npos, "--prior: '" << item << "' is not NAME=SIGMA (e.g. f=2)");
    const std::string name = item.substr(0, eq), value = item.substr(eq + 1);
    const Intrinsic intrinsic = intrinsic_named(name, "--prior");
    double sigma = std::numeric_limits<double>::quiet_NaN();
    try {
      std::size_t used = 0;
      sigma = std::stod(value, &used);
      if (used != value.size()) sigma = std::numeric_limits<double>::quiet_NaN();  // "2px"
    } catch (const std::exception&) {  // not a number: the check below says so
    }
    DIACHRON_CHECK(std::isfinite(sigma) && sigma > 0.0,
                   "--prior: the sigma of " << name << " must be a number > 0, got '" << value << "'");
    out.push_back({intrinsic, sigma});
  }
  return out;
}

// The epoch as the combined adjustment takes it: the frames and the tracks of points3D.txt as
// intra-epoch tie points (pixels in diachron's convention). Images whose cameras hold the same
// values share one (CombinedEpoch::cameras empty), or all do with `one_camera`.
CombinedEpoch combined_epoch(const EpochFolder& e, bool one_camera) {
  CombinedEpoch out;
  std::map<std::uint32_t, int> index;
  for (std::size_t i = 0; i < e.images.size(); ++i) {
    out.frames.push_back(e.images[i].frame);
    index[e.images[i].id] = static_cast<int>(i);
  }
  if (one_camera) out.cameras.assign(out.frames.size(), 0);
  for (const auto& [id, point] : e.model.points3d) {
    std::vector<ImagePixel> tie;
    for (const ColmapTrackElement& t : point.track) {
      const ColmapImage& image = e.model.images.at(t.image_id);
      tie.push_back({index.at(t.image_id), diachron_pixel_from_colmap(image.points2d.at(t.point2d_index).xy)});
    }
    if (tie.size() >= 2) out.tie_points.push_back(std::move(tie));
  }
  return out;
}

std::string json_rms(const ResidualRms& r) {
  std::ostringstream o;
  o.precision(6);
  o << "{\"rms_px\": ";
  if (std::isfinite(r.rms_px)) o << r.rms_px;
  else o << "null";
  o << ", \"observations\": " << r.observations << "}";
  return o.str();
}



// `images` (cameras.json's, named as images.txt names them) under their Homol names: one name per
// image over all epochs, as MicMac wants them.
std::vector<CamerasJsonImage> images_homol_named(std::vector<CamerasJsonImage> images, const std::vector<Epoch>& epochs) {
  std::size_t k = 0;
  for (const Epoch& e : epochs)
    for (std::size_t i = 0; i < e.folder.images.size() && !e.folder.is_ortho(); ++i, ++k) images.at(k).name = e.homol[i];
  return images;
}

struct MicmacExport {
  MicmacWriteReport written;
  double max_conversion_error_px = 0.0;
};

// DIR/adjusted/micmac/: Ori-diachron/ (every image of the photo epochs, AltiSol the reference DSM's
// mean height), a link per image named as in Homol/, and Homol -> ../../Homol.
MicmacExport write_micmac_export(const std::string& project, const std::vector<Epoch>& epochs,
                                 const std::vector<CamerasJsonImage>& images, double ground) {
  make_folders(project, "adjusted/micmac");
  MicmacWriteOptions options;
  options.ground_altitude = ground;
  MicmacExport out;
  out.written = write_micmac_ori_folder(project, "diachron", images, options);
  for (const MicmacWrittenCalibration& c : out.written.calibrations)
    out.max_conversion_error_px = std::max(out.max_conversion_error_px, c.conversion.exact ? 0.0 : c.conversion.max_error_px);
  for (const Epoch& e : epochs) {
    if (e.folder.is_ortho()) continue;
    for (std::size_t i = 0; i < e.folder.images.size(); ++i)
      std::filesystem::create_symlink(std::filesystem::absolute(e.folder.images[i].path), project + "/" + e.homol[i]);
  }
  std::filesystem::create_directory_symlink("../../Homol", project + "/Homol");
  return out;
}

// The control points of a control-point file with their image names resolved in the epochs:
// each name must be an image of exactly one epoch (orthophoto tiles are no images here).
// `what` names them in messages ("control point", "check point").
std::vector<EpochsControlPoint> epochs_control_points(const std::vector<ControlPointRecord>& records,
                                                      const std::vector<Epoch>& epochs, const char* what) {
  constexpr std::size_t kShared = std::numeric_limits<std::size_t>::max();
  std::map<std::string, std::pair<std::size_t, int>> where;  // name -> (epoch, index)
  for (std::size_t e = 0; e < epochs.size(); ++e) {
    if (epochs[e].folder.is_ortho()) continue;
    for (std::size_t i = 0; i < epochs[e].folder.images.size(); ++i) {
      const auto [it, inserted] = where.emplace(epochs[e].folder.images[i].name, std::make_pair(e, static_cast<int>(i)));
      if (!inserted && it->second.first != e) it->second.first = kShared;
    }
  }
  std::vector<EpochsControlPoint> out;
  for (const ControlPointRecord& r : records) {
    EpochsControlPoint g{r.position, r.sigma, std::vector<std::vector<ImagePixel>>(epochs.size())};
    for (const auto& [image, pixel] : r.observations) {
      const auto it = where.find(image);
      DIACHRON_CHECK(it != where.end(), what << " " << r.name << ": no image '" << image << "' in any epoch");
      DIACHRON_CHECK(it->second.first != kShared,
                     what << " " << r.name << ": image '" << image << "' is in two epochs; rename one of them");
      g.observations[it->second.first].push_back({it->second.second, pixel});
    }
    out.push_back(std::move(g));
  }
  return out;
}

// Per axis mu, sigma, |mu| (mean of |e|) and RMS of e = triangulated - given, reference units.
void check_point_json(std::ostream& o, const CheckPointReport& c) {
  o << "{\"used\": " << c.num_used << ", \"failed\": " << c.num_failed << ", \"rms_3d\": "
    << json_number_or_null(c.rms_3d_m);
  const char* axis[3] = {"x", "y", "z"};
  for (std::size_t k = 0; k < 3; ++k) {
    const ErrorStatistics& e = c.axes_m[k];
    o << ", \"" << axis[k] << "\": {\"mean\": " << json_number_or_null(e.mean) << ", \"sigma\": "
      << json_number_or_null(e.sigma) << ", \"mean_abs\": " << json_number_or_null(e.mean_abs)
      << ", \"rms\": " << json_number_or_null(e.rms) << "}";
  }
  o << "}";
}

// A free epoch's check points after the rough co-registration alone and after the adjustment.
struct EpochCheckPoints {
  std::size_t epoch = 0;
  CheckPointReport rough, adjusted;
};

// The "adjustment" section of report.json.
// `image_epoch`, `names`: per image of the adjustment (CombinedEpochsResult::image_camera's
// order), its epoch and its name.
std::string adjustment_json(const CombinedEpochsResult& a, const std::vector<Epoch>& epochs,
                            const std::vector<std::size_t>& image_epoch, const std::vector<std::string>& names,
                            const AdjustedExportReport* exported, AffineScope affine_scope,
                            const std::vector<ControlPointRecord>& control, const std::vector<EpochCheckPoints>& checked) {
  const BundleReport& r = a.report;
  std::ostringstream o;
  o << "  \"adjustment\": {\"success\": " << (r.success ? "true" : "false") << ", \"message\": " << quoted(r.message)
    << ", \"affine_scope\": " << quoted(affine_scope == AffineScope::per_camera ? "per_camera" : "per_image")
    << ",\n    \"tracks\": {\"input\": " << r.tracks_input << ", \"used\": " << r.tracks_used
    << ", \"inter_epoch\": " << r.inter_epoch_tracks << ", \"rejected\": " << r.tracks_rejected
    << ", \"dropped_conflicting\": " << a.tracks.dropped_conflicting << "}, \"observations\": {\"used\": "
    << r.observations_used << ", \"rejected\": " << r.observations_rejected << "},\n    \"epoch_links\": [";
  // Tracks shared by every two epochs (before the adjustment): what ties each epoch to the others.
  bool first_link = true;
  for (std::size_t x = 0; x < epochs.size(); ++x)
    for (std::size_t y = x + 1; y < epochs.size(); ++y) {
      const auto n = static_cast<Eigen::Index>(epochs.size());
      const std::size_t tracks = a.epoch_links.rows() == n ? a.epoch_links(static_cast<Eigen::Index>(x), static_cast<Eigen::Index>(y)) : 0;
      o << (first_link ? "" : ", ") << "{\"epochs\": [" << quoted(epochs[x].name) << ", " << quoted(epochs[y].name)
        << "], \"tracks\": " << tracks << "}";
      first_link = false;
    }
  o << "],\n    \"before\": {\"all\": " << json_rms(r.before.all) << ", \"intra_epoch\": " << json_rms(r.before.intra_epoch)
    << ", \"inter_epoch\": " << json_rms(r.before.inter_epoch) << "},\n    \"after\": {\"all\": "
    << json_rms(r.after.all) << ", \"intra_epoch\": " << json_rms(r.after.intra_epoch)
    << ", \"inter_epoch\": " << json_rms(r.after.inter_epoch) << "},\n    \"sigma0\": " << json_number_or_null(r.sigma0)
    << ", \"covariance\": " << quoted(r.covariance_available ? "available" : r.covariance_message)
    << ",\n    \"cameras\": [";
  for (std::size_t c = 0; c < r.cameras.size(); ++c) {
    // The camera's first image, in the adjustment's order.
    const auto at = std::find(a.image_camera.begin(), a.image_camera.end(), r.cameras[c].camera);
    const auto first = static_cast<std::size_t>(at - a.image_camera.begin());
    const std::size_t epoch = first < image_epoch.size() ? image_epoch[first] : 0;
    o << (c ? ",\n      " : "\n      ") << "{\"camera\": " << r.cameras[c].camera << ", \"free\": "
      << (r.cameras[c].free ? "true" : "false") << ", \"values\": {";
    for (std::size_t k = 0; k < r.cameras[c].values.size(); ++k) {
      const ParameterChange& p = r.cameras[c].values[k];
      o << (k ? ", " : "") << quoted(p.name) << ": {\"before\": " << json_number_or_null(p.before)
        << ", \"after\": " << json_number_or_null(p.after) << ", \"sigma\": " << json_number_or_null(p.sigma) << "}";
    }
    o << "}, \"held\": [";
    for (std::size_t k = 0; k < r.cameras[c].held.size(); ++k) o << (k ? ", " : "") << quoted(r.cameras[c].held[k]);
    o << "], \"priors\": {";
    for (std::size_t k = 0; k < r.cameras[c].priors.size(); ++k)
      o << (k ? ", " : "") << quoted(r.cameras[c].priors[k]) << ": " << json_number_or_null(r.cameras[c].prior_sigmas[k]);
    o << "}, \"epoch\": " << quoted(epochs[epoch].name) << ", \"images\": [";
    for (std::size_t i = 0, k = 0; i < a.image_camera.size(); ++i)
      if (a.image_camera[i] == r.cameras[c].camera) o << (k++ ? ", " : "") << quoted(names[i]);
    o << "], \"distortion_sigma\": ";
    // The covariance carried to the distortion over the image (eval/distortion_precision.hpp): what
    // the block determines, without the truth.
    const Frame<FraserAffine>* frame =
        first < image_epoch.size() ? &a.epochs[epoch][first - a.first_image[epoch]] : nullptr;
    const DistortionPrecision precision = !r.cameras[c].covariance.empty() && frame
                                              ? distortion_precision(frame->camera(), r.cameras[c].covariance)
                                              : DistortionPrecision{};
    if (precision.valid)
      o << "{\"worst_px\": " << json_number_or_null(precision.max_sigma_px) << ", \"rms_px\": "
        << json_number_or_null(precision.rms_sigma_px) << ", \"worst_pixel\": [" << precision.worst_pixel.x() << ", "
        << precision.worst_pixel.y() << "]}";
    else
      o << "null";
    o << "}";
  }
  o << "],\n    \"solves\": [";
  for (std::size_t k = 0; k < r.solves.size(); ++k)
    o << (k ? ", " : "") << "{\"stage\": " << quoted(r.solves[k].stage) << ", \"termination\": "
      << quoted(r.solves[k].termination) << ", \"iterations\": " << r.solves[k].iterations
      << ", \"seconds\": " << r.solves[k].seconds << "}";
  // The control points: used or not, and their adjusted point minus their given position.
  o << "],\n    \"control_points\": [";
  for (std::size_t k = 0; k < control.size() && k < a.control_points.size(); ++k) {
    const ControlPointOutcome& g = a.control_points[k];
    o << (k ? ",\n      " : "\n      ") << "{\"name\": " << quoted(control[k].name)
      << ", \"observations\": " << control[k].observations.size() << ", \"used\": " << (g.used ? "true" : "false")
      << ", \"error\": ";
    if (g.used)
      o << "[" << json_number_or_null(g.error.x()) << ", " << json_number_or_null(g.error.y()) << ", "
        << json_number_or_null(g.error.z()) << "]";
    else
      o << "null";
    o << "}";
  }
  o << "],\n    \"check_points\": ";
  if (!checked.empty()) {
    o << "{";
    for (std::size_t k = 0; k < checked.size(); ++k) {
      o << (k ? ",\n      " : "\n      ") << quoted(epochs[checked[k].epoch].name) << ": {\"rough\": ";
      check_point_json(o, checked[k].rough);
      o << ",\n        \"adjusted\": ";
      check_point_json(o, checked[k].adjusted);
      o << "}";
    }
    o << "}";
  } else {
    o << "null";
  }
  o << ",\n    \"max_conversion_error_px\": "
    << (exported ? json_number_or_null(exported->max_conversion_error_px) : std::string("null"))
    << ", \"seconds\": " << r.seconds << "},\n";
  return o.str();
}

// One picture per image of a free epoch: its tie-point observations and their reprojection
// residuals after the adjustment (observed - projected), magnified; named after its Homol name.
void write_residual_pictures(const std::string& dir, const std::vector<Epoch>& epochs, std::size_t reference,
                             const CombinedEpochsResult& a) {
  make_folder(dir, "match_epochs");
  for (std::size_t e = 0; e < epochs.size(); ++e) {
    if (e == reference || epochs[e].folder.is_ortho()) continue;
    const std::size_t n = epochs[e].folder.images.size(), first = a.first_image[e];
    std::vector<std::vector<Vec2>> pixels(n), residuals(n);
    for (std::size_t t = 0; t < a.track_list.size(); ++t) {
      if (!a.track_used[t]) continue;
      for (const TrackObservation& o : a.track_list[t].observations) {
        if (o.image < 0 || static_cast<std::size_t>(o.image) < first || static_cast<std::size_t>(o.image) >= first + n)
          continue;
        const std::size_t i = static_cast<std::size_t>(o.image) - first;
        const std::optional<Vec2> p = a.epochs[e][i].project(a.points[t]);
        if (!p) continue;
        pixels[i].push_back(o.pixel);  // image px; the picture's below
        residuals[i].push_back(o.pixel - *p);
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      std::string name = safe(epochs[e].homol[i]);
      const std::size_t dot = name.find_last_of('.');
      if (dot != std::string::npos && dot > 0) name.erase(dot);  // "a.tif" -> "a.png"
      const Picture picture = picture_of(epochs[e].folder.load_image(i));
      for (Vec2& p : pixels[i]) p = picture.at(p);
      write_residuals_png(dir + "/" + name + ".png", picture.image, pixels[i], residuals[i]);
    }
  }
}
#endif

}  // namespace match_epochs
