#pragma once
/// @file
/// MicMac orientations: reads and writes `Ori-<name>/Orientation-<image>.xml` (OrientationConique)
/// with their `AutoCal*.xml` calibrations (CalibrationInternConique), so that a MicMac project
/// (Tapas / Campari) can be brought into diachron and an adjusted result handed back to Malt,
/// C3DC or Campari. Standard library and Eigen only (XML through io/xml_lite.hpp); folders through
/// POSIX calls (io/folders.hpp). docs/micmac-orientation.md.
///
/// Conventions (eConvApero_DistM2C, the one Tapas / Campari write; others are refused):
/// - Externe/Centre is the projection centre C in the world frame; ParamRotation/CodageMatr holds,
///   row by row (L1 L2 L3), M = world_from_cam (MicMac stores the exterior orientation camera to
///   world, "C2M"). The camera frame is diachron's (x right, y down, z forward), so
///   R = cam_from_world = M^T and X_cam = M^T (X - C).
/// - The ideal pixel is p = PP + F (X_cam.x / X_cam.z, X_cam.y / X_cam.z), then the distortion maps
///   it to the observed pixel (ideal -> observed, "DistM2C"; formulas in camera/micmac_conversion.hpp).
/// - MicMac pixels = diachron pixels + kMicmacPixelShift (0: both index pixel centres).
/// Checked against files written by MicMac itself: the `Verif` control points that MicMac stores
/// in an Orientation file (terrain point and the pixel MicMac projects it to) are reproduced to
/// 5e-12 px by this formula, for a ModPhgrStd calibration with P1, P2, b1, b2 all non-zero and for
/// a ModRad one (MicMac's test data, micmacIGN/micmac MMVII/MMVII-TestDir/Input/Ori-MMV1 and
/// Saisies-MMV1/Ori-Ground_mm3d); M instead of M^T puts them behind the camera. MicMac's schema
/// (include/XML_GEN/ParamChantierPhotogram.xml, eConventionsOrientation) says the same: the
/// exterior orientation is always stored C2M, DistM2C being the distortion's direction.

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <fstream>
#include <initializer_list>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/conversion.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/micmac_conversion.hpp>
#include <diachron/camera/pose.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>
#include <diachron/io/cameras_json.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/io/xml_lite.hpp>

namespace diachron {

/// A MicMac calibration (CalibrationInternConique) as read, in MicMac's own terms (pixels,
/// MicMac's pixel convention, DistM2C).
struct MicmacCalibration {
  MicmacFraser fraser;  ///< PP, F, CDist, R3 R5 R7, P1 P2, b1 b2, SzIm
  /// The distortion layer it came from: "ModPhgrStd", "ModRad", "ModUnif eModele_Fraser_PPaEqPPs",
  /// "ModUnif eModele_DRad_PPaEqPPs", or "none" (only identity layers).
  std::string distortion_model;
  std::string path;  ///< the file read (the Orientation file for an embedded Interne)
};

/// A MicMac OrientationConique as read. Units: the world frame's (metres for aerial work).
struct MicmacOrientation {
  std::string path;                          ///< the Orientation file read
  Mat3 world_from_cam = Mat3::Identity();    ///< CodageMatr rows L1 L2 L3: camera -> world
  Vec3 centre = Vec3::Zero();                ///< Externe/Centre, world frame
  std::optional<double> alti_sol;            ///< Externe/AltiSol: ground Z MicMac assumed, world units
  std::optional<double> depth;               ///< Externe/Profondeur: scene depth on the axis, world units
  std::string file_interne;                  ///< FileInterne as written ("" when absent)
  /// FileInterne resolved to a path to read ("" when the calibration is embedded).
  std::string calibration_file;
  std::optional<MicmacCalibration> interne;  ///< the embedded Interne calibration, when present

  /// The diachron pose X_cam = R (X - C), R = world_from_cam^T.
  Pose pose() const { return Pose(world_from_cam.transpose(), centre); }
};

/// One image of an Ori folder with diachron's camera and pose; what read_micmac_ori_folder returns
/// and write_micmac_ori_folder takes.
struct MicmacOriImage {
  std::string name;  ///< image file name, e.g. "OIS-Reech_1971_0012.tif" (no '/')
  Camera<FraserAffine> camera{1.0, 0.0, 0.0, 1, 1};  ///< diachron camera (px, diachron pixels)
  Pose pose;                                        ///< X_cam = R (X - C)
  std::optional<double> alti_sol;  ///< AltiSol, world Z units (read: as stored; write: see options)
  std::optional<double> depth;     ///< Profondeur, world units (write: computed when absent)
  /// Write only: calibration files are named "AutoCal-<group>-<k>.xml" ("AutoCal-<k>.xml" when
  /// empty), k counting the distinct cameras of the group; cameras.json images use their epoch.
  std::string group;

  // Filled by read_micmac_ori_folder, ignored by write_micmac_ori_folder.
  std::string orientation_file;  ///< the Orientation file read
  std::string calibration_file;  ///< the calibration file read ("" when embedded)
  MicmacCalibration micmac;      ///< the calibration as MicMac holds it
  bool conversion_exact = true;  ///< camera_from_micmac was closed-form (CDist = PP, b1 = b2 = 0)
  double conversion_max_error_px = 0.0;  ///< measured MicMac -> diachron error, px
  double conversion_rms_error_px = 0.0;  ///< its RMS, px
};

/// Options of read_micmac_ori_folder.
struct MicmacReadOptions {
  ConversionOptions conversion;                 ///< grid and fit of camera_from_micmac
  double pixel_shift_px = kMicmacPixelShift;    ///< MicMac pixel minus diachron pixel, px

  /// Precondition: a valid `conversion` and a finite shift, else throws diachron::Error.
  void check() const {
    conversion.check();
    DIACHRON_CHECK(std::isfinite(pixel_shift_px), "MicmacReadOptions::pixel_shift_px must be finite");
  }
};

/// Options of write_micmac_ori_folder.
struct MicmacWriteOptions {
  /// Write into an Ori folder that already holds files (the files written are replaced, the others
  /// kept and listed in MicmacWriteReport::stale_files). Off: such a folder is refused.
  bool overwrite = false;
  /// AltiSol (the ground Z MicMac's Malt and C3DC start from, world units) of the images without
  /// their own alti_sol. MicMac requires AltiSol in an OrientationConique, so an image with neither
  /// is refused. Profondeur, when an image has none, is the depth on the optical axis of the plane
  /// Z = AltiSol (left out when that plane is not in front of the camera).
  std::optional<double> ground_altitude;
  ConversionOptions conversion;               ///< grid and fit of micmac_from_camera
  double pixel_shift_px = kMicmacPixelShift;  ///< MicMac pixel minus diachron pixel, px

  /// Precondition: finite ground_altitude and shift, valid `conversion`, else throws.
  void check() const {
    conversion.check();
    DIACHRON_CHECK(std::isfinite(pixel_shift_px), "MicmacWriteOptions::pixel_shift_px must be finite");
    DIACHRON_CHECK(!ground_altitude || std::isfinite(*ground_altitude),
                   "MicmacWriteOptions::ground_altitude must be finite");
  }
};

/// One calibration file written and how well MicMac's model holds the camera.
struct MicmacWrittenCalibration {
  std::string file;                 ///< relative to the project folder, e.g. "Ori-Adj/AutoCal-e1-0.xml"
  std::vector<std::string> images;  ///< the images that use it, sorted
  /// micmac_from_camera's result: the MicMac model written and its measured error (exact when the
  /// camera has no affine B1, B2; fitted, with max_error_px > 0, otherwise).
  ConversionResult<MicmacFraser> conversion;
};

/// What write_micmac_ori_folder wrote.
struct MicmacWriteReport {
  std::string ori_folder;                              ///< <project>/Ori-<name>
  std::vector<std::string> orientation_files;          ///< written, sorted by image name
  std::vector<MicmacWrittenCalibration> calibrations;  ///< one per distinct camera
  /// Files that were in the folder before and were not rewritten (overwrite only): an
  /// Orientation-*.xml among them is an image MicMac will still see.
  std::vector<std::string> stale_files;
};

/// `<project_dir>/Ori-<ori_name>`; `ori_name` may be given with or without its "Ori-" prefix
/// ("Adjusted" or "Ori-Adjusted"). Throws diachron::Error for an empty name or one with a '/'.
inline std::string micmac_ori_folder(const std::string& project_dir, const std::string& ori_name);

/// Reads a CalibrationInternConique (the root, or the one child of the root, as MicMac's
/// <ExportAPERO> wraps it). Accepts the distortion layers ModPhgrStd (Fraser), ModRad (radial) and
/// their ModUnif forms eModele_Fraser_PPaEqPPs / eModele_DRad_PPaEqPPs; identity layers (ModNoDist,
/// all-zero coefficients, all-zero ModUnif polynomials) are skipped. With PPaEqPPs true the
/// distortion centre is PP, as MicMac takes it. Throws diachron::Error naming the file and line for
/// malformed XML, missing or non-finite PP / F / SzIm, F <= 0, a KnownConv other than
/// eConvApero_DistM2C, another model (ModUnif fish-eye or other, ModGrid, ModGridDef), radial
/// coefficients beyond R7 that are not zero, several non-identity layers, a non-identity OrIntGlob,
/// non-zero ParamAF or a CorrectionRefractionAPosteriori.
inline MicmacCalibration read_micmac_calibration(const std::string& xml_path);

/// Reads an OrientationConique (root or the root's child). `project_dir` is the folder FileInterne
/// is relative to when RelativeNameFI is true; empty means the parent of the file's folder (the
/// folder holding Ori-<name>). With RelativeNameFI false the name is taken as is. When that file
/// does not exist but one of the same name lies beside the Orientation file (an Ori folder copied
/// or renamed after MicMac wrote it), that one is used. Throws diachron::Error naming the file and
/// line for malformed XML, a missing Externe / Centre / CodageMatr, a rotation that is not one
/// (1e-6 per entry), ConvOri or Externe KnownConv other than eConvApero_DistM2C (or a
/// ConvExplicite), a rotation given by CodageAngulaire / CodageSymbolique or TrueRot false, a
/// TypeProj other than eProjStenope, a ModuleOrientationFile (grid), neither or both of Interne
/// and FileInterne, and a non-identity OrIntImaM2C: an image-to-camera affinity (a crop, a scan's
/// fiducial transform) is refused rather than folded into the camera, since FraserAffine cannot
/// hold a rotation or a y scale of the image; resample the image (MicMac's ReSampFid) first.
inline MicmacOrientation read_micmac_orientation(const std::string& xml_path, const std::string& project_dir = "");

/// Every image of `<project_dir>/Ori-<ori_name>` (each `Orientation-<image>.xml`), sorted by image
/// name, with its calibration (each file read once) converted by camera_from_micmac and the
/// measured conversion error. Throws diachron::Error when the folder is missing or holds no
/// Orientation file, and as read_micmac_orientation / read_micmac_calibration.
inline std::vector<MicmacOriImage> read_micmac_ori_folder(const std::string& project_dir, const std::string& ori_name,
                                                          const MicmacReadOptions& options = {});

/// Writes `Ori-<ori_name>/Orientation-<image>.xml` for every image and one calibration file per
/// distinct camera (cameras equal in every parameter share one; an image whose camera differs, as
/// a per-image affine makes it, gets its own: MicMac's CalibPerPose), in eConvApero_DistM2C, the
/// calibration as ModPhgrStd with CDist = PP (PPaEqPPs, Tapas' FraserBasic form) through
/// micmac_from_camera, FileInterne relative to the project folder (RelativeNameFI true), numbers
/// with 17 significant digits. Creates the folders as needed. Everything is checked before a file
/// is written. Throws diachron::Error for no images, an empty, duplicate or '/'-holding image name,
/// an image without AltiSol (see MicmacWriteOptions::ground_altitude), a camera MicMac's model
/// cannot hold (non-finite conversion error), an existing non-empty Ori folder without
/// `overwrite`, or a file that cannot be written.
inline MicmacWriteReport write_micmac_ori_folder(const std::string& project_dir, const std::string& ori_name,
                                                 const std::vector<MicmacOriImage>& images,
                                                 const MicmacWriteOptions& options = {});

/// The same for the images of a cameras.json (io/cameras_json.hpp): name, camera, pose, and the
/// epoch as the calibration group.
inline MicmacWriteReport write_micmac_ori_folder(const std::string& project_dir, const std::string& ori_name,
                                                 const std::vector<CamerasJsonImage>& images,
                                                 const MicmacWriteOptions& options = {});

// Implementation ----------------------------------------------------------------------------------

namespace detail {

inline constexpr const char* kMicmacDistM2C = "eConvApero_DistM2C";
inline constexpr std::string_view kMicmacOrientationPrefix = "Orientation-";
inline constexpr std::string_view kMicmacXmlSuffix = ".xml";

// The folder of a path ("." when it has none).
inline std::string micmac_parent_folder(std::string path) {
  while (path.size() > 1 && path.back() == '/') path.pop_back();
  const std::size_t slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

inline std::string micmac_file_name(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

inline std::string micmac_join(const std::string& folder, const std::string& name) {
  if (!name.empty() && name.front() == '/') return name;
  if (folder.empty()) return name;
  return folder.back() == '/' ? folder + name : folder + "/" + name;
}

// Reads the elements of one MicMac file, naming the file and the element's line in every error.
class MicmacXmlReader {
 public:
  explicit MicmacXmlReader(const std::string& file) : file_(file) {}

  [[noreturn]] void fail(const XmlElement& at, const std::string& what) const {
    throw Error("diachron: " + file_ + ":" + std::to_string(at.line) + ": " + what);
  }

  const XmlElement& required(const XmlElement& parent, const char* name) const {
    const XmlElement* c = parent.child(name);
    if (!c) fail(parent, "<" + parent.name + "> has no <" + name + ">");
    if (parent.children_named(name).size() > 1) fail(parent, "<" + parent.name + "> has several <" + name + ">");
    return *c;
  }

  static std::string trimmed(const std::string& s) {
    const std::size_t b = s.find_first_not_of(" \t\r\n");
    if (b == std::string::npos) return "";
    return s.substr(b, s.find_last_not_of(" \t\r\n") - b + 1);
  }

  // The element's text as `n` finite numbers separated by blanks.
  std::vector<double> numbers(const XmlElement& e, std::size_t n) const {
    std::vector<double> out;
    const std::string& t = e.text;
    std::size_t i = 0;
    for (;;) {
      while (i < t.size() && (t[i] == ' ' || t[i] == '\t' || t[i] == '\r' || t[i] == '\n')) ++i;
      if (i >= t.size()) break;
      std::size_t j = i;
      while (j < t.size() && !(t[j] == ' ' || t[j] == '\t' || t[j] == '\r' || t[j] == '\n')) ++j;
      double v = 0.0;
      const char* first = t.data() + i;
      if (*first == '+') ++first;  // from_chars refuses a leading '+', which C's strtod reads
      const auto [end, error] = std::from_chars(first, t.data() + j, v);
      if (error != std::errc() || end != t.data() + j || !std::isfinite(v))
        fail(e, "<" + e.name + "> holds '" + t.substr(i, j - i) + "', not a finite number");
      out.push_back(v);
      i = j;
    }
    if (out.size() != n)
      fail(e, "<" + e.name + "> needs " + std::to_string(n) + " number" + (n > 1 ? "s" : "") + ", has " +
                  std::to_string(out.size()));
    return out;
  }

  double number(const XmlElement& e) const { return numbers(e, 1)[0]; }
  Vec2 vec2(const XmlElement& e) const {
    const std::vector<double> v = numbers(e, 2);
    return Vec2(v[0], v[1]);
  }
  Vec3 vec3(const XmlElement& e) const {
    const std::vector<double> v = numbers(e, 3);
    return Vec3(v[0], v[1], v[2]);
  }

  bool boolean(const XmlElement& e) const {
    const std::string t = trimmed(e.text);
    if (t == "true" || t == "1") return true;
    if (t == "false" || t == "0") return false;
    fail(e, "<" + e.name + "> holds '" + t + "', expected true or false");
  }

  std::optional<bool> optional_boolean(const XmlElement& parent, const char* name) const {
    const XmlElement* c = parent.child(name);
    if (!c) return std::nullopt;
    return boolean(*c);
  }

  double optional_number(const XmlElement& parent, const char* name, double fallback) const {
    const XmlElement* c = parent.child(name);
    return c ? number(*c) : fallback;
  }

  // A KnownConv element, when present, must be DistM2C.
  void check_known_conv(const XmlElement& parent) const {
    const XmlElement* c = parent.child("KnownConv");
    if (!c) return;
    const std::string conv = trimmed(c->text);
    if (conv != kMicmacDistM2C)
      fail(*c, "<" + parent.name + "><KnownConv> is '" + conv + "': only " + kMicmacDistM2C +
                   " (what Tapas and Campari write) is read; convert the orientation with MicMac first");
  }

  // The element itself when named `name`, else the one such child of the root (<ExportAPERO>).
  const XmlElement& document(const XmlElement& root, const char* name) const {
    if (root.name == name) return root;
    const std::vector<const XmlElement*> found = root.children_named(name);
    if (found.size() != 1) fail(root, std::string("expected one <") + name + "> in <" + root.name + ">");
    return *found.front();
  }

  // An AffinitePlane (I00, V10, V01) that must be the identity: a pixel offset of 1e-9 px, a
  // vector component of 1e-12.
  void check_identity_affinity(const XmlElement& a, const std::string& what) const {
    const Vec2 i00 = vec2(required(a, "I00"));
    const Vec2 v10 = vec2(required(a, "V10"));
    const Vec2 v01 = vec2(required(a, "V01"));
    if (i00.cwiseAbs().maxCoeff() > 1e-9 || (v10 - Vec2(1.0, 0.0)).cwiseAbs().maxCoeff() > 1e-12 ||
        (v01 - Vec2(0.0, 1.0)).cwiseAbs().maxCoeff() > 1e-12)
      fail(a, what);
  }

  const std::string& file() const { return file_; }

 private:
  const std::string& file_;
};

// One CalibDistortion layer: whether it is the identity and, when not, the model it sets.
struct MicmacDistortionLayer {
  bool identity = true;
  std::string model;
  Vec2 centre = Vec2::Zero();  // CDist (PP when PPaEqPPs)
  std::vector<double> radial;  // R3, R5, R7, ...
  double p1 = 0.0, p2 = 0.0, b1 = 0.0, b2 = 0.0;
};

inline void read_micmac_radial(const MicmacXmlReader& r, const XmlElement& e, const Vec2& pp,
                               MicmacDistortionLayer& layer) {
  const Vec2 cdist = r.vec2(r.required(e, "CDist"));
  for (const XmlElement* c : e.children_named("CoeffDist")) layer.radial.push_back(r.number(*c));
  // PPaEqPPs ties the distortion centre to PP: MicMac then evaluates the model about PP
  // (AdaptDist2PPaEqPPs), whatever CDist says.
  layer.centre = r.optional_boolean(e, "PPaEqPPs").value_or(false) ? pp : cdist;
}

inline MicmacDistortionLayer read_micmac_layer(const MicmacXmlReader& r, const XmlElement& cd, const Vec2& pp) {
  if (cd.children.size() != 1)
    r.fail(cd, "<CalibDistortion> must hold one model, holds " + std::to_string(cd.children.size()) + " elements");
  const XmlElement& m = cd.children.front();
  MicmacDistortionLayer layer;
  layer.model = m.name;
  layer.centre = pp;
  if (m.name == "ModNoDist") return layer;
  if (m.name == "ModRad") {
    read_micmac_radial(r, m, pp, layer);
  } else if (m.name == "ModPhgrStd") {
    read_micmac_radial(r, r.required(m, "RadialePart"), pp, layer);
    layer.p1 = r.optional_number(m, "P1", 0.0);
    layer.p2 = r.optional_number(m, "P2", 0.0);
    layer.b1 = r.optional_number(m, "b1", 0.0);
    layer.b2 = r.optional_number(m, "b2", 0.0);
  } else if (m.name == "ModUnif") {
    const std::string type = MicmacXmlReader::trimmed(r.required(m, "TypeModele").text);
    std::vector<double> params;
    for (const XmlElement* c : m.children_named("Params")) params.push_back(r.number(*c));
    layer.model = "ModUnif " + type;
    const bool all_zero = std::all_of(params.begin(), params.end(), [](double v) { return v == 0.0; });
    if (type == "eModele_DRad_PPaEqPPs") {
      layer.radial = params;
    } else if (type == "eModele_Fraser_PPaEqPPs") {
      // MicMac's layout (AdaptDist2PPaEqPPs): five radial terms R3..R11, then P1 P2 b1 b2.
      if (params.size() != 9)
        r.fail(m, "ModUnif eModele_Fraser_PPaEqPPs needs 9 Params (R3 R5 R7 R9 R11 P1 P2 b1 b2), has " +
                      std::to_string(params.size()));
      layer.radial.assign(params.begin(), params.begin() + 5);
      layer.p1 = params[5];
      layer.p2 = params[6];
      layer.b1 = params[7];
      layer.b2 = params[8];
    } else if (type.rfind("eModelePolyDeg", 0) == 0 && all_zero) {
      return layer;  // a polynomial correction at zero: the identity
    } else {
      r.fail(m, "distortion model ModUnif " + type +
                    " is not read (only Fraser and radial models: Tapas Fraser, FraserBasic, RadialBasic, "
                    "RadialStd; fish-eye and polynomial models are not)");
    }
  } else {
    r.fail(m, "distortion model <" + m.name +
                  "> is not read (only ModPhgrStd, ModRad, ModNoDist and their ModUnif PPaEqPPs forms)");
  }
  layer.identity = layer.p1 == 0.0 && layer.p2 == 0.0 && layer.b1 == 0.0 && layer.b2 == 0.0 &&
                   std::all_of(layer.radial.begin(), layer.radial.end(), [](double v) { return v == 0.0; });
  for (std::size_t k = 3; k < layer.radial.size(); ++k)
    if (layer.radial[k] != 0.0)
      r.fail(m, layer.model + " has a non-zero radial coefficient R" + std::to_string(2 * k + 3) + " = " +
                    std::to_string(layer.radial[k]) +
                    ": only R3, R5, R7 are held (calibrate with Tapas Fraser / FraserBasic / RadialStd)");
  return layer;
}

inline MicmacCalibration micmac_calibration_from_xml(const MicmacXmlReader& r, const XmlElement& cic) {
  r.check_known_conv(cic);
  MicmacCalibration out;
  out.path = r.file();
  MicmacFraser& f = out.fraser;
  f.principal_point = r.vec2(r.required(cic, "PP"));
  const XmlElement& focal = r.required(cic, "F");
  f.focal = r.number(focal);
  if (!(f.focal > 0.0)) r.fail(focal, "F must be > 0 px");
  const XmlElement& size = r.required(cic, "SzIm");
  const Vec2 sz = r.vec2(size);
  if (!(sz.x() >= 1.0 && sz.y() >= 1.0 && sz.x() <= 1e9 && sz.y() <= 1e9 && sz.x() == std::floor(sz.x()) &&
        sz.y() == std::floor(sz.y())))
    r.fail(size, "SzIm must be two positive integers (px)");
  f.width = static_cast<int>(sz.x());
  f.height = static_cast<int>(sz.y());

  if (const XmlElement* g = cic.child("OrIntGlob"))
    r.check_identity_affinity(r.required(*g, "Affinite"),
                              "a non-identity OrIntGlob (global image-to-camera affinity) is not read");
  for (const XmlElement* p : cic.children_named("ParamAF"))
    if (r.number(*p) != 0.0) r.fail(*p, "non-zero ParamAF are not read");
  if (const XmlElement* c = cic.child("CorrectionRefractionAPosteriori"))
    r.fail(*c, "CorrectionRefractionAPosteriori is not read");

  const std::vector<const XmlElement*> layers = cic.children_named("CalibDistortion");
  if (layers.empty()) r.fail(cic, "<CalibrationInternConique> has no <CalibDistortion>");
  std::optional<MicmacDistortionLayer> active;
  for (const XmlElement* cd : layers) {
    MicmacDistortionLayer layer = read_micmac_layer(r, *cd, f.principal_point);
    if (layer.identity) continue;
    if (active)
      r.fail(*cd, "several non-identity <CalibDistortion> layers (" + active->model + " and " + layer.model +
                      "): their composition is not read");
    active = std::move(layer);
  }
  f.distortion_centre = f.principal_point;
  out.distortion_model = "none";
  if (active) {
    out.distortion_model = active->model;
    f.distortion_centre = active->centre;
    const std::size_t n = active->radial.size();
    f.r3 = n > 0 ? active->radial[0] : 0.0;
    f.r5 = n > 1 ? active->radial[1] : 0.0;
    f.r7 = n > 2 ? active->radial[2] : 0.0;
    f.p1 = active->p1;
    f.p2 = active->p2;
    f.b1 = active->b1;
    f.b2 = active->b2;
  }
  return out;
}

// Doubles with 17 significant digits, in the C locale whatever the program's.
inline std::string micmac_number(double v) {
  char buffer[40];
  const auto [end, error] = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::general, 17);
  DIACHRON_CHECK(error == std::errc(), "cannot format " << v);
  return std::string(buffer, end);
}

inline std::string micmac_numbers(std::initializer_list<double> values) {
  std::string out;
  for (const double v : values) out += (out.empty() ? "" : " ") + micmac_number(v);
  return out;
}

// MicMac's layout: five spaces per level, under <ExportAPERO>.
inline std::string micmac_line(int level, const std::string& tag, const std::string& text) {
  return std::string(static_cast<std::size_t>(5 * level), ' ') + "<" + tag + ">" + text + "</" + tag + ">\n";
}
inline std::string micmac_open(int level, const std::string& tag) {
  return std::string(static_cast<std::size_t>(5 * level), ' ') + "<" + tag + ">\n";
}
inline std::string micmac_close(int level, const std::string& tag) {
  return std::string(static_cast<std::size_t>(5 * level), ' ') + "</" + tag + ">\n";
}

inline std::string micmac_calibration_xml(const MicmacFraser& m) {
  std::string s = "<?xml version=\"1.0\" ?>\n<ExportAPERO>\n";
  s += micmac_open(1, "CalibrationInternConique");
  s += micmac_line(2, "KnownConv", kMicmacDistM2C);
  s += micmac_line(2, "PP", micmac_numbers({m.principal_point.x(), m.principal_point.y()}));
  s += micmac_line(2, "F", micmac_number(m.focal));
  s += micmac_line(2, "SzIm", std::to_string(m.width) + " " + std::to_string(m.height));
  s += micmac_open(2, "CalibDistortion");
  s += micmac_open(3, "ModPhgrStd");
  s += micmac_open(4, "RadialePart");
  s += micmac_line(5, "CDist", micmac_numbers({m.distortion_centre.x(), m.distortion_centre.y()}));
  for (const double r : {m.r3, m.r5, m.r7}) s += micmac_line(5, "CoeffDist", micmac_number(r));
  s += micmac_line(5, "PPaEqPPs", m.distortion_centre == m.principal_point ? "true" : "false");
  s += micmac_close(4, "RadialePart");
  s += micmac_line(4, "P1", micmac_number(m.p1));
  s += micmac_line(4, "P2", micmac_number(m.p2));
  s += micmac_line(4, "b1", micmac_number(m.b1));
  s += micmac_line(4, "b2", micmac_number(m.b2));
  s += micmac_close(3, "ModPhgrStd");
  s += micmac_close(2, "CalibDistortion");
  s += micmac_close(1, "CalibrationInternConique");
  return s + "</ExportAPERO>\n";
}

inline std::string micmac_orientation_xml(const Pose& pose, double alti_sol, const std::optional<double>& depth,
                                          const std::string& file_interne) {
  const Mat3 m = pose.cam_from_world_rotation().transpose();  // world_from_cam, MicMac's C2M
  const Vec3& c = pose.centre();
  std::string s = "<?xml version=\"1.0\" ?>\n<ExportAPERO>\n";
  s += micmac_open(1, "OrientationConique");
  s += micmac_open(2, "OrIntImaM2C");
  s += micmac_line(3, "I00", "0 0");
  s += micmac_line(3, "V10", "1 0");
  s += micmac_line(3, "V01", "0 1");
  s += micmac_close(2, "OrIntImaM2C");
  s += micmac_line(2, "TypeProj", "eProjStenope");
  s += micmac_line(2, "FileInterne", xml_escaped(file_interne));
  s += micmac_line(2, "RelativeNameFI", "true");
  s += micmac_open(2, "Externe");
  s += micmac_line(3, "AltiSol", micmac_number(alti_sol));
  if (depth) s += micmac_line(3, "Profondeur", micmac_number(*depth));
  s += micmac_line(3, "KnownConv", kMicmacDistM2C);
  s += micmac_line(3, "Centre", micmac_numbers({c.x(), c.y(), c.z()}));
  s += micmac_open(3, "ParamRotation");
  s += micmac_open(4, "CodageMatr");
  for (int row = 0; row < 3; ++row)
    s += micmac_line(5, "L" + std::to_string(row + 1), micmac_numbers({m(row, 0), m(row, 1), m(row, 2)}));
  s += micmac_close(4, "CodageMatr");
  s += micmac_close(3, "ParamRotation");
  s += micmac_close(2, "Externe");
  s += micmac_open(2, "ConvOri");
  s += micmac_line(3, "KnownConv", kMicmacDistM2C);
  s += micmac_close(2, "ConvOri");
  s += micmac_close(1, "OrientationConique");
  return s + "</ExportAPERO>\n";
}

inline void write_micmac_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  DIACHRON_CHECK(out.good(), "cannot write '" << path << "': the file cannot be created");
  out << text;
  out.close();
  DIACHRON_CHECK(!out.fail(), "cannot write '" << path << "': writing failed");
}

inline bool same_micmac_camera(const Camera<FraserAffine>& a, const Camera<FraserAffine>& b) {
  return a.width() == b.width() && a.height() == b.height() && a.focal() == b.focal() && a.cx() == b.cx() &&
         a.cy() == b.cy() && a.params() == b.params();
}

inline void check_micmac_image_name(const std::string& name, const char* who) {
  DIACHRON_CHECK(!name.empty() && name.find('/') == std::string::npos,
                 who << ": image name '" << name << "' must be non-empty and contain no '/'");
}

}  // namespace detail

inline std::string micmac_ori_folder(const std::string& project_dir, const std::string& ori_name) {
  DIACHRON_CHECK(!ori_name.empty() && ori_name != "Ori-" && ori_name.find('/') == std::string::npos,
                 "MicMac orientation name '" << ori_name << "' must be non-empty and contain no '/'");
  const std::string folder = ori_name.rfind("Ori-", 0) == 0 ? ori_name : "Ori-" + ori_name;
  return detail::micmac_join(project_dir.empty() ? "." : project_dir, folder);
}

inline MicmacCalibration read_micmac_calibration(const std::string& xml_path) {
  const XmlElement root = read_xml_file(xml_path);
  const detail::MicmacXmlReader r(xml_path);
  return detail::micmac_calibration_from_xml(r, r.document(root, "CalibrationInternConique"));
}

inline MicmacOrientation read_micmac_orientation(const std::string& xml_path, const std::string& project_dir) {
  const XmlElement root = read_xml_file(xml_path);
  const detail::MicmacXmlReader r(xml_path);
  const XmlElement& oc = r.document(root, "OrientationConique");
  MicmacOrientation out;
  out.path = xml_path;

  if (const XmlElement* m = oc.child("ModuleOrientationFile"))
    r.fail(*m, "ModuleOrientationFile (a grid orientation) is not read");
  if (const XmlElement* t = oc.child("TypeProj")) {
    const std::string type = detail::MicmacXmlReader::trimmed(t->text);
    if (type != "eProjStenope") r.fail(*t, "TypeProj '" + type + "' is not read (only eProjStenope)");
  }
  if (const XmlElement* a = oc.child("OrIntImaM2C"))
    r.check_identity_affinity(*a,
                              "a non-identity OrIntImaM2C (image-to-camera affinity: crop, scan fiducials) is not "
                              "read; resample the image first (MicMac's ReSampFid) so that it is the identity");
  const XmlElement& conv = r.required(oc, "ConvOri");
  if (const XmlElement* e = conv.child("ConvExplicite"))
    r.fail(*e, "ConvOri/ConvExplicite is not read (only KnownConv eConvApero_DistM2C)");
  r.required(conv, "KnownConv");
  r.check_known_conv(conv);

  const XmlElement& ext = r.required(oc, "Externe");
  r.check_known_conv(ext);
  out.centre = r.vec3(r.required(ext, "Centre"));
  if (const XmlElement* a = ext.child("AltiSol")) out.alti_sol = r.number(*a);
  if (const XmlElement* d = ext.child("Profondeur")) out.depth = r.number(*d);
  const XmlElement& rot = r.required(ext, "ParamRotation");
  for (const char* other : {"CodageAngulaire", "CodageSymbolique"})
    if (const XmlElement* e = rot.child(other))
      r.fail(*e, std::string("ParamRotation/") + other + " is not read (only CodageMatr)");
  const XmlElement& matrix = r.required(rot, "CodageMatr");
  if (!r.optional_boolean(matrix, "TrueRot").value_or(true))
    r.fail(matrix, "CodageMatr with TrueRot false (not a rotation) is not read");
  const char* rows[] = {"L1", "L2", "L3"};
  for (int i = 0; i < 3; ++i) out.world_from_cam.row(i) = r.vec3(r.required(matrix, rows[i])).transpose();
  const Mat3& w = out.world_from_cam;
  const double error = (w.transpose() * w - Mat3::Identity()).cwiseAbs().maxCoeff();
  if (!(error <= 1e-6 && w.determinant() > 0.0))
    r.fail(matrix, "CodageMatr is not a rotation (|M^T M - I|max = " + std::to_string(error) +
                       ", det = " + std::to_string(w.determinant()) + ")");

  const XmlElement* interne = oc.child("Interne");
  const XmlElement* file_interne = oc.child("FileInterne");
  if (!interne && !file_interne) r.fail(oc, "<OrientationConique> has neither <Interne> nor <FileInterne>");
  if (interne && file_interne) r.fail(oc, "<OrientationConique> has both <Interne> and <FileInterne>");
  if (interne) {
    out.interne = detail::micmac_calibration_from_xml(r, *interne);
    return out;
  }
  out.file_interne = detail::MicmacXmlReader::trimmed(file_interne->text);
  if (out.file_interne.empty()) r.fail(*file_interne, "<FileInterne> is empty");
  const bool relative = r.optional_boolean(oc, "RelativeNameFI").value_or(false);
  const std::string file_folder = detail::micmac_parent_folder(xml_path);
  const std::string project = project_dir.empty() ? detail::micmac_parent_folder(file_folder) : project_dir;
  out.calibration_file = relative ? detail::micmac_join(project, out.file_interne) : out.file_interne;
  if (!is_regular_file(out.calibration_file)) {
    const std::string beside = detail::micmac_join(file_folder, detail::micmac_file_name(out.file_interne));
    if (is_regular_file(beside)) out.calibration_file = beside;
  }
  return out;
}

inline std::vector<MicmacOriImage> read_micmac_ori_folder(const std::string& project_dir, const std::string& ori_name,
                                                          const MicmacReadOptions& options) {
  options.check();
  const std::string folder = micmac_ori_folder(project_dir, ori_name);
  DIACHRON_CHECK(is_folder(folder), "read_micmac_ori_folder: '" << folder << "' is not a folder");
  std::vector<std::pair<std::string, std::string>> files;  // (image, file)
  for (const std::string& entry : folder_entries(folder)) {
    const std::size_t prefix = detail::kMicmacOrientationPrefix.size();
    const std::size_t suffix = detail::kMicmacXmlSuffix.size();
    if (entry.size() <= prefix + suffix || entry.compare(0, prefix, detail::kMicmacOrientationPrefix) != 0 ||
        entry.compare(entry.size() - suffix, suffix, detail::kMicmacXmlSuffix) != 0)
      continue;
    files.emplace_back(entry.substr(prefix, entry.size() - prefix - suffix), detail::micmac_join(folder, entry));
  }
  DIACHRON_CHECK(!files.empty(), "read_micmac_ori_folder: no Orientation-<image>.xml in '" << folder << "'");
  std::sort(files.begin(), files.end());

  struct Converted {
    MicmacCalibration micmac;
    ConversionResult<Camera<FraserAffine>> conversion;
  };
  std::map<std::string, Converted> by_file;  // each calibration file read and converted once
  const auto convert = [&options](const MicmacCalibration& c) {
    try {
      return Converted{c, camera_from_micmac(c.fraser, options.conversion, options.pixel_shift_px)};
    } catch (const Error& e) {
      throw Error("diachron: " + c.path + ": the calibration cannot be converted: " + e.what());
    }
  };

  std::vector<MicmacOriImage> out;
  out.reserve(files.size());
  for (const auto& [image, file] : files) {
    const MicmacOrientation o = read_micmac_orientation(file, project_dir.empty() ? "." : project_dir);
    MicmacOriImage im;
    im.name = image;
    im.orientation_file = file;
    im.pose = o.pose();
    im.alti_sol = o.alti_sol;
    im.depth = o.depth;
    std::optional<Converted> embedded;
    const Converted* converted = nullptr;
    if (o.interne) {
      embedded.emplace(convert(*o.interne));
      converted = &*embedded;
    } else {
      auto it = by_file.find(o.calibration_file);
      if (it == by_file.end()) {
        if (!is_regular_file(o.calibration_file))
          throw Error("diachron: " + file + ": FileInterne '" + o.file_interne + "' (read as '" +
                      o.calibration_file + "') does not exist");
        it = by_file.emplace(o.calibration_file, convert(read_micmac_calibration(o.calibration_file))).first;
      }
      converted = &it->second;
      im.calibration_file = o.calibration_file;
    }
    im.micmac = converted->micmac;
    im.camera = converted->conversion.model;
    im.conversion_exact = converted->conversion.exact;
    im.conversion_max_error_px = converted->conversion.max_error_px;
    im.conversion_rms_error_px = converted->conversion.rms_error_px;
    out.push_back(std::move(im));
  }
  return out;
}

inline MicmacWriteReport write_micmac_ori_folder(const std::string& project_dir, const std::string& ori_name,
                                                 const std::vector<MicmacOriImage>& images,
                                                 const MicmacWriteOptions& options) {
  options.check();
  const std::string folder = micmac_ori_folder(project_dir, ori_name);
  const std::string folder_name = detail::micmac_file_name(folder);
  DIACHRON_CHECK(!images.empty(), "write_micmac_ori_folder: no images to write");

  // Everything is checked and converted before the first file is written.
  std::vector<std::size_t> order(images.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&images](std::size_t a, std::size_t b) { return images[a].name < images[b].name; });
  for (std::size_t k = 0; k < order.size(); ++k) {
    const MicmacOriImage& im = images[order[k]];
    detail::check_micmac_image_name(im.name, "write_micmac_ori_folder");
    DIACHRON_CHECK(k == 0 || images[order[k - 1]].name != im.name,
                   "write_micmac_ori_folder: image '" << im.name << "' is given twice");
    DIACHRON_CHECK(!im.alti_sol || std::isfinite(*im.alti_sol),
                   "write_micmac_ori_folder: image '" << im.name << "' has a non-finite alti_sol");
    DIACHRON_CHECK(!im.depth || (std::isfinite(*im.depth) && *im.depth > 0.0),
                   "write_micmac_ori_folder: image '" << im.name << "' has a depth that is not finite and > 0");
    DIACHRON_CHECK(im.alti_sol || options.ground_altitude,
                   "write_micmac_ori_folder: image '"
                       << im.name << "' has no alti_sol and MicmacWriteOptions::ground_altitude is not set "
                       << "(MicMac needs AltiSol, the ground Z its matching starts from)");
  }

  // Distinct cameras, numbered per group in the order of the sorted image names.
  struct Calibration {
    std::size_t first_image;
    std::string file;  // relative to the project
    std::vector<std::string> images;
  };
  std::vector<Calibration> calibrations;
  std::vector<std::size_t> calibration_of(images.size());
  std::map<std::string, int> count_of_group;
  for (const std::size_t i : order) {
    const MicmacOriImage& im = images[i];
    std::size_t c = 0;
    while (c < calibrations.size() && !(images[calibrations[c].first_image].group == im.group &&
                                        detail::same_micmac_camera(images[calibrations[c].first_image].camera, im.camera)))
      ++c;
    if (c == calibrations.size()) {
      DIACHRON_CHECK(im.group.find('/') == std::string::npos,
                     "write_micmac_ori_folder: group '" << im.group << "' contains a '/'");
      const int k = count_of_group[im.group]++;
      const std::string label = im.group.empty() ? std::to_string(k) : im.group + "-" + std::to_string(k);
      calibrations.push_back({i, folder_name + "/AutoCal-" + label + ".xml", {}});
    }
    calibrations[c].images.push_back(im.name);
    calibration_of[i] = c;
  }

  MicmacWriteReport report;
  report.ori_folder = folder;
  for (const Calibration& c : calibrations) {
    const Camera<FraserAffine>& camera = images[c.first_image].camera;
    ConversionResult<MicmacFraser> conversion =
        micmac_from_camera(camera, options.conversion, options.pixel_shift_px);
    DIACHRON_CHECK(std::isfinite(conversion.max_error_px),
                   "write_micmac_ori_folder: the camera of image '" << c.images.front()
                       << "' cannot be written in MicMac's model (the conversion failed)");
    report.calibrations.push_back({c.file, c.images, conversion});
  }

  struct Orientation {
    std::string file;
    std::string text;
  };
  std::vector<Orientation> orientations;
  for (const std::size_t i : order) {
    const MicmacOriImage& im = images[i];
    const double alti = im.alti_sol ? *im.alti_sol : *options.ground_altitude;
    std::optional<double> depth = im.depth;
    if (!depth) {
      // The depth on the optical axis of the plane Z = AltiSol: X_cam.z of C + t d is t.
      const Vec3 d = im.pose.viewing_direction();
      const double t = (alti - im.pose.centre().z()) / d.z();
      if (std::isfinite(t) && t > 0.0) depth = t;
    }
    const std::string file = folder + "/" + std::string(detail::kMicmacOrientationPrefix) + im.name +
                             std::string(detail::kMicmacXmlSuffix);
    orientations.push_back(
        {file, detail::micmac_orientation_xml(im.pose, alti, depth, calibrations[calibration_of[i]].file)});
    report.orientation_files.push_back(file);
  }

  const std::vector<std::string> before = folder_entries(folder);
  DIACHRON_CHECK(before.empty() || options.overwrite,
                 "write_micmac_ori_folder: '" << folder << "' already holds " << before.size()
                     << " files; set MicmacWriteOptions::overwrite to replace them");
  make_folders(folder, "write_micmac_ori_folder");
  for (const MicmacWrittenCalibration& c : report.calibrations)
    detail::write_micmac_text(detail::micmac_join(project_dir.empty() ? "." : project_dir, c.file),
                              detail::micmac_calibration_xml(c.conversion.model));
  for (const Orientation& o : orientations) detail::write_micmac_text(o.file, o.text);

  for (const std::string& entry : before) {
    const std::string path = folder + "/" + entry;
    const bool written =
        std::find(report.orientation_files.begin(), report.orientation_files.end(), path) != report.orientation_files.end() ||
        std::any_of(report.calibrations.begin(), report.calibrations.end(),
                    [&](const MicmacWrittenCalibration& c) { return folder_name + "/" + entry == c.file; });
    if (!written) report.stale_files.push_back(path);
  }
  return report;
}

inline MicmacWriteReport write_micmac_ori_folder(const std::string& project_dir, const std::string& ori_name,
                                                 const std::vector<CamerasJsonImage>& images,
                                                 const MicmacWriteOptions& options) {
  std::vector<MicmacOriImage> converted;
  converted.reserve(images.size());
  for (const CamerasJsonImage& image : images) {
    MicmacOriImage im;
    im.name = image.name;
    im.camera = image.camera;
    try {
      im.pose = image.pose();
    } catch (const Error& e) {
      throw Error("diachron: write_micmac_ori_folder: image '" + image.name + "': " + e.what());
    }
    im.group = image.epoch;
    converted.push_back(std::move(im));
  }
  return write_micmac_ori_folder(project_dir, ori_name, converted, options);
}

}  // namespace diachron
