// MicMac orientations: files laid out as MicMac writes them are read into the values they hold,
// the cameras project as MicMac's own formula (written here independently) does, a write -> read
// round trip keeps poses and calibrations, and every refused input names its file.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <diachron/camera/frame.hpp>
#include <diachron/io/micmac_orientation.hpp>
#include <diachron/io/xml_lite.hpp>

#include "support/temp_folder.hpp"

using namespace diachron;
using Catch::Matchers::Contains;

namespace {

std::string micmacori_folder(const std::string& name) { return diachron::test::fresh_temp_folder("micmacori_" + name); }

void micmacori_write(const std::string& path, const std::string& text) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

std::string micmacori_read(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Numbers as MicMac prints them: enough digits to read back the same double.
std::string micmacori_num(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

// A calibration in MicMac's terms, for writing test files and for MicMac's projection formula.
struct MicmacoriCalib {
  Vec2 pp{1510.25, 990.75};
  double f = 2500.5;
  Vec2 cdist{1510.25, 990.75};
  std::vector<double> radial{-2.1e-8, 3.2e-15, -1.1e-22};
  double p1 = 2.0e-7, p2 = -1.3e-7, b1 = 0.0, b2 = 0.0;
  int width = 3000, height = 2000;
};

// MicMac's projection, written from its documented model: X_cam = M^T (X - C), ideal pixel
// p = PP + F (x, y), then (ModPhgrStd, ideal -> observed) with u = p - CDist, r2 = |u|^2:
// p' = CDist + u (1 + R3 r2 + R5 r2^2 + R7 r2^3) + decentric + affine (on x).
Vec2 micmacori_project(const MicmacoriCalib& c, const Mat3& world_from_cam, const Vec3& centre, const Vec3& x) {
  const Vec3 xc = world_from_cam.transpose() * (x - centre);
  const Vec2 p = c.pp + c.f * Vec2(xc.x() / xc.z(), xc.y() / xc.z());
  const Vec2 u = p - c.cdist;
  const double r2 = u.squaredNorm();
  double radial = 1.0, power = 1.0;
  for (const double k : c.radial) {
    power *= r2;
    radial += k * power;
  }
  Vec2 out = c.cdist + radial * u;
  out.x() += c.p1 * (2.0 * u.x() * u.x() + r2) + 2.0 * c.p2 * u.x() * u.y() + c.b1 * u.x() + c.b2 * u.y();
  out.y() += c.p2 * (2.0 * u.y() * u.y() + r2) + 2.0 * c.p1 * u.x() * u.y();
  return out;
}

// An AutoCal file as Tapas writes it (FraserBasic: ModPhgrStd), or with ModRad.
std::string micmacori_calibration_xml(const MicmacoriCalib& c, bool phgr_std, bool pp_eq_pps) {
  std::ostringstream s;
  s << "<?xml version=\"1.0\" ?>\n<ExportAPERO>\n     <CalibrationInternConique>\n"
    << "          <KnownConv>eConvApero_DistM2C</KnownConv>\n"
    << "          <PP>" << micmacori_num(c.pp.x()) << " " << micmacori_num(c.pp.y()) << "</PP>\n"
    << "          <F>" << micmacori_num(c.f) << "</F>\n"
    << "          <SzIm>" << c.width << " " << c.height << "</SzIm>\n"
    << "          <CalibDistortion>\n";
  const std::string indent = phgr_std ? "                         " : "                    ";
  std::ostringstream radial;
  radial << indent << "<CDist>" << micmacori_num(c.cdist.x()) << " " << micmacori_num(c.cdist.y()) << "</CDist>\n";
  for (const double k : c.radial) radial << indent << "<CoeffDist>" << micmacori_num(k) << "</CoeffDist>\n";
  if (pp_eq_pps) radial << indent << "<PPaEqPPs>true</PPaEqPPs>\n";
  if (phgr_std) {
    s << "               <ModPhgrStd>\n                    <RadialePart>\n"
      << radial.str() << "                    </RadialePart>\n"
      << "                    <P1>" << micmacori_num(c.p1) << "</P1>\n"
      << "                    <P2>" << micmacori_num(c.p2) << "</P2>\n"
      << "                    <b1>" << micmacori_num(c.b1) << "</b1>\n"
      << "                    <b2>" << micmacori_num(c.b2) << "</b2>\n"
      << "               </ModPhgrStd>\n";
  } else {
    s << "               <ModRad>\n" << radial.str() << "               </ModRad>\n";
  }
  s << "          </CalibDistortion>\n     </CalibrationInternConique>\n</ExportAPERO>\n";
  return s.str();
}

// An Orientation file as Tapas writes it, Verif block included (which the reader skips).
std::string micmacori_orientation_xml(const Mat3& m, const Vec3& c, const std::string& file_interne,
                                      const std::string& known_conv = "eConvApero_DistM2C") {
  std::ostringstream s;
  s << "<?xml version=\"1.0\" ?>\n<!-- written by hand, laid out as MicMac writes it -->\n<ExportAPERO>\n"
    << "     <OrientationConique>\n"
    << "          <OrIntImaM2C>\n               <I00>0 0</I00>\n               <V10>1 0</V10>\n"
    << "               <V01>0 1</V01>\n          </OrIntImaM2C>\n"
    << "          <TypeProj>eProjStenope</TypeProj>\n          <ZoneUtileInPixel>true</ZoneUtileInPixel>\n"
    << "          <FileInterne>" << file_interne << "</FileInterne>\n"
    << "          <RelativeNameFI>true</RelativeNameFI>\n          <Externe>\n"
    << "               <AltiSol>102.5</AltiSol>\n               <Profondeur>1397.25</Profondeur>\n"
    << "               <Time>-1.00000000000000002e+30</Time>\n"
    << "               <KnownConv>eConvApero_DistM2C</KnownConv>\n"
    << "               <Centre>" << micmacori_num(c.x()) << " " << micmacori_num(c.y()) << " " << micmacori_num(c.z())
    << "</Centre>\n               <IncCentre>1 1 1</IncCentre>\n"
    << "               <ParamRotation>\n                    <CodageMatr>\n";
  for (int r = 0; r < 3; ++r)
    s << "                         <L" << r + 1 << ">" << micmacori_num(m(r, 0)) << " " << micmacori_num(m(r, 1)) << " "
      << micmacori_num(m(r, 2)) << "</L" << r + 1 << ">\n";
  s << "                    </CodageMatr>\n               </ParamRotation>\n          </Externe>\n"
    << "          <Verif>\n               <Tol>0.001</Tol>\n               <ShowMes>true</ShowMes>\n"
    << "               <Appuis>\n                    <Num>0</Num>\n                    <Im>1 2</Im>\n"
    << "                    <Ter>3 4 5</Ter>\n               </Appuis>\n          </Verif>\n"
    << "          <ConvOri>\n               <KnownConv>" << known_conv << "</KnownConv>\n          </ConvOri>\n"
    << "     </OrientationConique>\n</ExportAPERO>\n";
  return s.str();
}

// An oblique aerial pose (camera -> world as MicMac stores it) and its centre.
Mat3 micmacori_world_from_cam() {
  return Pose::from_yaw_pitch_roll(Vec3::Zero(), 0.7, 0.15, -0.08).cam_from_world_rotation().transpose();
}
const Vec3 kMicmacoriCentre(652341.125, 6862175.5, 1500.25);

// World points seen by the camera: camera-frame points spread over the image at varied depths.
std::vector<Vec3> micmacori_points(const Mat3& world_from_cam, const Vec3& centre) {
  std::vector<Vec3> out;
  for (int i = 0; i < 7; ++i)
    for (int k = 0; k < 7; ++k) {
      const double depth = 900.0 + 60.0 * ((i * 7 + k) % 11);
      const Vec3 xc(depth * (-0.55 + 0.18 * k), depth * (-0.36 + 0.12 * i), depth);
      out.push_back(centre + world_from_cam * xc);
    }
  return out;
}

void micmacori_check_projections(const MicmacOriImage& image, const MicmacoriCalib& c, const Mat3& m, const Vec3& centre,
                                 double tolerance_px) {
  const Frame<FraserAffine> frame(image.camera, image.pose);
  for (const Vec3& x : micmacori_points(m, centre)) {
    const Vec2 expected = micmacori_project(c, m, centre, x);
    const std::optional<Vec2> got = frame.project(x);
    REQUIRE(got);
    INFO("point " << x.transpose() << ": MicMac " << expected.transpose() << ", diachron " << got->transpose());
    CHECK((*got - expected).norm() <= tolerance_px);
  }
}

// A project folder with one image oriented by `calibration_xml`.
std::string micmacori_project_folder(const std::string& name, const std::string& calibration_xml) {
  const std::string dir = micmacori_folder(name);
  micmacori_write(dir + "/Ori-Tapas/AutoCal_Foc-35000_Cam-Test.xml", calibration_xml);
  micmacori_write(dir + "/Ori-Tapas/Orientation-IMG_0001.tif.xml",
                  micmacori_orientation_xml(micmacori_world_from_cam(), kMicmacoriCentre,
                                            "Ori-Tapas/AutoCal_Foc-35000_Cam-Test.xml"));
  return dir;
}

double micmacori_relative(double a, double b) { return std::abs(a - b) / std::max(std::abs(b), 1e-300); }

}  // namespace

TEST_CASE("micmac_orientation: an Orientation and a ModPhgrStd AutoCal read as MicMac wrote them", "[io]") {
  const MicmacoriCalib calib;
  const std::string dir = micmacori_project_folder("phgrstd", micmacori_calibration_xml(calib, true, true));
  const Mat3 m = micmacori_world_from_cam();

  const MicmacOrientation o = read_micmac_orientation(dir + "/Ori-Tapas/Orientation-IMG_0001.tif.xml");
  CHECK(o.centre == kMicmacoriCentre);
  CHECK(o.world_from_cam == m);
  CHECK(o.pose().cam_from_world_rotation().isApprox(m.transpose(), 1e-15));
  REQUIRE(o.alti_sol);
  CHECK(*o.alti_sol == 102.5);
  REQUIRE(o.depth);
  CHECK(*o.depth == 1397.25);
  CHECK(o.file_interne == "Ori-Tapas/AutoCal_Foc-35000_Cam-Test.xml");
  CHECK(o.calibration_file == dir + "/Ori-Tapas/AutoCal_Foc-35000_Cam-Test.xml");
  CHECK_FALSE(o.interne);

  const MicmacCalibration c = read_micmac_calibration(o.calibration_file);
  CHECK(c.distortion_model == "ModPhgrStd");
  CHECK(c.fraser.principal_point == calib.pp);
  CHECK(c.fraser.focal == calib.f);
  CHECK(c.fraser.distortion_centre == calib.cdist);
  CHECK(c.fraser.r3 == calib.radial[0]);
  CHECK(c.fraser.r5 == calib.radial[1]);
  CHECK(c.fraser.r7 == calib.radial[2]);
  CHECK(c.fraser.p1 == calib.p1);
  CHECK(c.fraser.p2 == calib.p2);
  CHECK(c.fraser.b1 == 0.0);
  CHECK(c.fraser.width == 3000);
  CHECK(c.fraser.height == 2000);

  const std::vector<MicmacOriImage> images = read_micmac_ori_folder(dir, "Tapas");
  REQUIRE(images.size() == 1);
  CHECK(images[0].name == "IMG_0001.tif");
  CHECK(images[0].conversion_exact);
  CHECK(images[0].conversion_max_error_px < 1e-9);
  CHECK(images[0].calibration_file == o.calibration_file);
  CHECK(images[0].pose.centre() == kMicmacoriCentre);
  micmacori_check_projections(images[0], calib, m, kMicmacoriCentre, 1e-6);
}

TEST_CASE("micmac_orientation: ModRad calibrations, with the centre tied to PP or free", "[io]") {
  const Mat3 m = micmacori_world_from_cam();
  SECTION("RadialBasic (PPaEqPPs): exact") {
    MicmacoriCalib calib;
    calib.p1 = calib.p2 = 0.0;
    calib.radial = {-1.5e-8, 2.0e-15};
    const std::string dir = micmacori_project_folder("modrad", micmacori_calibration_xml(calib, false, true));
    const MicmacCalibration c = read_micmac_calibration(dir + "/Ori-Tapas/AutoCal_Foc-35000_Cam-Test.xml");
    CHECK(c.distortion_model == "ModRad");
    CHECK(c.fraser.r3 == -1.5e-8);
    CHECK(c.fraser.r5 == 2.0e-15);
    CHECK(c.fraser.r7 == 0.0);
    const std::vector<MicmacOriImage> images = read_micmac_ori_folder(dir, "Ori-Tapas");
    REQUIRE(images.size() == 1);
    CHECK(images[0].conversion_exact);
    micmacori_check_projections(images[0], calib, m, kMicmacoriCentre, 1e-6);
  }
  SECTION("PPaEqPPs true puts the distortion centre on PP whatever CDist says") {
    MicmacoriCalib calib;
    calib.cdist = calib.pp + Vec2(3.0, -2.0);
    const std::string dir = micmacori_folder("modrad_tied");
    micmacori_write(dir + "/c.xml", micmacori_calibration_xml(calib, false, true));
    CHECK(read_micmac_calibration(dir + "/c.xml").fraser.distortion_centre == calib.pp);
  }
  SECTION("RadialStd (free CDist): fitted, within the measured error") {
    MicmacoriCalib calib;
    calib.p1 = calib.p2 = 0.0;
    calib.cdist = calib.pp + Vec2(6.0, -4.5);
    const std::string dir = micmacori_project_folder("modrad_free", micmacori_calibration_xml(calib, false, false));
    const std::vector<MicmacOriImage> images = read_micmac_ori_folder(dir, "Tapas");
    REQUIRE(images.size() == 1);
    CHECK(images[0].micmac.fraser.distortion_centre == calib.cdist);
    CHECK_FALSE(images[0].conversion_exact);
    CHECK(std::isfinite(images[0].conversion_max_error_px));
    // Measured on a 21 x 21 grid; the points between its nodes stay within a small margin of it.
    micmacori_check_projections(images[0], calib, m, kMicmacoriCentre, 2.0 * images[0].conversion_max_error_px + 1e-3);
  }
}

TEST_CASE("micmac_orientation: FileInterne of a renamed Ori folder, absolute names, embedded Interne", "[io]") {
  const MicmacoriCalib calib;
  const Mat3 m = micmacori_world_from_cam();
  const std::string dir = micmacori_folder("resolve");
  // The folder was Ori-Old when MicMac wrote it; the file beside the Orientation is used.
  micmacori_write(dir + "/Ori-New/AutoCal.xml", micmacori_calibration_xml(calib, true, true));
  micmacori_write(dir + "/Ori-New/Orientation-a.tif.xml", micmacori_orientation_xml(m, kMicmacoriCentre, "Ori-Old/AutoCal.xml"));
  CHECK(read_micmac_orientation(dir + "/Ori-New/Orientation-a.tif.xml").calibration_file == dir + "/Ori-New/AutoCal.xml");

  // RelativeNameFI false: the name as is (here absolute).
  std::string text = micmacori_orientation_xml(m, kMicmacoriCentre, dir + "/Ori-New/AutoCal.xml");
  text.replace(text.find("<RelativeNameFI>true"), 20, "<RelativeNameFI>false");
  micmacori_write(dir + "/Ori-Abs/Orientation-b.tif.xml", text);
  CHECK(read_micmac_orientation(dir + "/Ori-Abs/Orientation-b.tif.xml").calibration_file == dir + "/Ori-New/AutoCal.xml");

  // The calibration inside the Orientation file.
  std::string calibration = micmacori_calibration_xml(calib, true, true);
  calibration = calibration.substr(calibration.find("<CalibrationInternConique>"));
  calibration = calibration.substr(0, calibration.find("</ExportAPERO>"));
  for (const char* tag : {"<CalibrationInternConique>", "</CalibrationInternConique>"})
    calibration.replace(calibration.find(tag), std::string(tag).size(),
                        std::string(tag[1] == '/' ? "</" : "<") + "Interne>");
  text = micmacori_orientation_xml(m, kMicmacoriCentre, "x");
  const std::size_t fi = text.find("          <FileInterne>");
  text.replace(fi, text.find("<Externe>") - fi, calibration + "          ");
  micmacori_write(dir + "/Ori-Embedded/Orientation-c.tif.xml", text);
  const MicmacOrientation o = read_micmac_orientation(dir + "/Ori-Embedded/Orientation-c.tif.xml");
  REQUIRE(o.interne);
  CHECK(o.interne->fraser.focal == calib.f);
  CHECK(o.calibration_file.empty());
  const std::vector<MicmacOriImage> images = read_micmac_ori_folder(dir, "Embedded");
  REQUIRE(images.size() == 1);
  CHECK(images[0].calibration_file.empty());
  micmacori_check_projections(images[0], calib, m, kMicmacoriCentre, 1e-6);
}

namespace {

// Five images: three share a camera without affine (epoch e1), two have their own cameras with
// per-image affine (epoch e2).
std::vector<MicmacOriImage> micmacori_images() {
  const Camera<FraserAffine> shared(2450.75, 1499.25, 1001.5, 3000, 2000,
                                    {-0.11, 0.043, -0.0071, 3.5e-4, -2.25e-4, 0.0, 0.0});
  std::vector<MicmacOriImage> out;
  for (int i = 0; i < 5; ++i) {
    MicmacOriImage im;
    const bool affine = i >= 3;
    im.name = std::string(affine ? "OIS-1971_" : "IMG_2014_") + std::to_string(10 - i) + ".tif";
    im.group = affine ? "e2" : "e1";
    im.camera = affine ? Camera<FraserAffine>(3100.0 + 5.0 * i, 1720.5, 1705.25, 3450, 3400,
                                              {-0.02 * i, 0.003, 0.0, 1e-4, 2e-4, 0.35 * i, -0.21})
                       : shared;
    im.pose = Pose::from_yaw_pitch_roll(Vec3(652000.0 + 310.5 * i, 6862000.0 - 95.25 * i, 1450.0 + 12.5 * i),
                                        0.3 * i - 0.5, 0.02 * i, -0.015 * i);
    out.push_back(im);
  }
  return out;
}

}  // namespace

TEST_CASE("micmac_orientation: write then read keeps poses and calibrations", "[io]") {
  const std::string dir = micmacori_folder("roundtrip");
  const std::vector<MicmacOriImage> images = micmacori_images();
  MicmacWriteOptions options;
  options.ground_altitude = 100.0;
  const MicmacWriteReport report = write_micmac_ori_folder(dir, "Adjusted", images, options);

  CHECK(report.ori_folder == dir + "/Ori-Adjusted");
  REQUIRE(report.orientation_files.size() == 5);
  CHECK(report.orientation_files.front() == dir + "/Ori-Adjusted/Orientation-IMG_2014_10.tif.xml");
  REQUIRE(report.calibrations.size() == 3);  // one shared, two per-image (CalibPerPose)
  CHECK(report.calibrations[0].file == "Ori-Adjusted/AutoCal-e1-0.xml");
  CHECK(report.calibrations[0].images ==
        std::vector<std::string>{"IMG_2014_10.tif", "IMG_2014_8.tif", "IMG_2014_9.tif"});
  CHECK(report.calibrations[0].conversion.exact);
  CHECK(report.calibrations[1].file == "Ori-Adjusted/AutoCal-e2-0.xml");
  CHECK(report.calibrations[1].images == std::vector<std::string>{"OIS-1971_6.tif"});
  CHECK(report.calibrations[2].file == "Ori-Adjusted/AutoCal-e2-1.xml");
  CHECK_FALSE(report.calibrations[2].conversion.exact);
  CHECK(report.stale_files.empty());

  // The layout MicMac reads: FileInterne relative to the project, DistM2C, the rotation C2M.
  const std::string text = micmacori_read(report.orientation_files.front());
  CHECK_THAT(text, Contains("<FileInterne>Ori-Adjusted/AutoCal-e1-0.xml</FileInterne>"));
  CHECK_THAT(text, Contains("<RelativeNameFI>true</RelativeNameFI>"));
  CHECK_THAT(text, Contains("<KnownConv>eConvApero_DistM2C</KnownConv>"));
  CHECK_THAT(text, Contains("<AltiSol>100</AltiSol>"));
  CHECK_THAT(micmacori_read(dir + "/Ori-Adjusted/AutoCal-e1-0.xml"), Contains("<PPaEqPPs>true</PPaEqPPs>"));

  const std::vector<MicmacOriImage> back = read_micmac_ori_folder(dir, "Adjusted");
  REQUIRE(back.size() == 5);
  for (const MicmacOriImage& got : back) {
    const auto it = std::find_if(images.begin(), images.end(), [&](const MicmacOriImage& im) { return im.name == got.name; });
    REQUIRE(it != images.end());
    const MicmacOriImage& want = *it;
    INFO("image " << got.name);
    CHECK((got.pose.centre() - want.pose.centre()).cwiseAbs().maxCoeff() <= 1e-6);
    CHECK((got.pose.cam_from_world_rotation() - want.pose.cam_from_world_rotation()).cwiseAbs().maxCoeff() <= 1e-9);
    REQUIRE(got.alti_sol);
    CHECK(*got.alti_sol == 100.0);
    REQUIRE(got.depth);
    // The written depth is that of the plane Z = 100 on the optical axis.
    const Vec3 on_axis = want.pose.centre() + *got.depth * want.pose.viewing_direction();
    CHECK(on_axis.z() == Approx(100.0).margin(1e-6));

    // The MicMac calibration read back is the one written, to the last digit.
    const auto written = std::find_if(report.calibrations.begin(), report.calibrations.end(), [&](const auto& c) {
      return std::find(c.images.begin(), c.images.end(), got.name) != c.images.end();
    });
    REQUIRE(written != report.calibrations.end());
    CHECK(got.calibration_file == dir + "/" + written->file);
    const MicmacFraser& a = got.micmac.fraser;
    const MicmacFraser& b = written->conversion.model;
    CHECK(a.principal_point == b.principal_point);
    CHECK(a.focal == b.focal);
    CHECK(a.r3 == b.r3);
    CHECK(a.r5 == b.r5);
    CHECK(a.r7 == b.r7);
    CHECK(a.p1 == b.p1);
    CHECK(a.p2 == b.p2);
    CHECK(a.b1 == b.b1);
    CHECK(a.b2 == b.b2);

    const Camera<FraserAffine>& cg = got.camera;
    const Camera<FraserAffine>& cw = want.camera;
    CHECK(cg.width() == cw.width());
    CHECK(cg.height() == cw.height());
    if (cw.params()[5] == 0.0 && cw.params()[6] == 0.0) {
      // No affine: exact both ways.
      CHECK(got.conversion_exact);
      CHECK(micmacori_relative(cg.focal(), cw.focal()) <= 1e-6);
      CHECK(micmacori_relative(cg.cx(), cw.cx()) <= 1e-6);
      CHECK(micmacori_relative(cg.cy(), cw.cy()) <= 1e-6);
      for (std::size_t k = 0; k < 5; ++k) CHECK(micmacori_relative(cg.params()[k], cw.params()[k]) <= 1e-6);
      CHECK(cg.params()[5] == 0.0);
      CHECK(cg.params()[6] == 0.0);
    } else {
      // MicMac's affinity acts on the ideal pixel, diachron's on the distorted one: both directions
      // are fitted, and the pixels agree to the sum of the two measured errors.
      CHECK_FALSE(got.conversion_exact);
      const double bound = written->conversion.max_error_px + got.conversion_max_error_px;
      CHECK(bound < 0.05);
      for (int i = 0; i <= 8; ++i)
        for (int k = 0; k <= 8; ++k) {
          const Vec2 pixel(cw.width() * k / 8.0 - 0.5, cw.height() * i / 8.0 - 0.5);
          const std::optional<Vec3> ray = cw.unproject(pixel);
          REQUIRE(ray);
          const std::optional<Vec2> again = cg.project(*ray);
          REQUIRE(again);
          CHECK((*again - pixel).norm() <= 1.5 * bound + 1e-6);
        }
    }
  }
}

TEST_CASE("micmac_orientation: an existing Ori folder is replaced only with overwrite", "[io]") {
  const std::string dir = micmacori_folder("overwrite");
  std::vector<MicmacOriImage> images = micmacori_images();
  MicmacWriteOptions options;
  options.ground_altitude = 100.0;
  write_micmac_ori_folder(dir, "Adjusted", images, options);
  CHECK_THROWS_WITH(write_micmac_ori_folder(dir, "Adjusted", images, options),
                    Contains("Ori-Adjusted") && Contains("overwrite"));
  options.overwrite = true;
  images.pop_back();
  const MicmacWriteReport report = write_micmac_ori_folder(dir, "Ori-Adjusted", images, options);
  // The image left out and its calibration are still in the folder, and said so.
  CHECK(report.stale_files == std::vector<std::string>{dir + "/Ori-Adjusted/AutoCal-e2-1.xml",
                                                       dir + "/Ori-Adjusted/Orientation-OIS-1971_6.tif.xml"});
}

TEST_CASE("micmac_orientation: cameras.json images are written with their epoch as calibration group", "[io]") {
  const std::string dir = micmacori_folder("cameras_json");
  std::vector<CamerasJsonImage> images;
  for (const MicmacOriImage& im : micmacori_images()) {
    CamerasJsonImage c;
    c.name = im.name;
    c.epoch = im.group;
    c.camera = im.camera;
    c.rotation = im.pose.cam_from_world_rotation();
    c.centre = im.pose.centre();
    images.push_back(c);
  }
  MicmacWriteOptions options;
  options.ground_altitude = 100.0;
  const MicmacWriteReport report = write_micmac_ori_folder(dir, "FromJson", images, options);
  REQUIRE(report.calibrations.size() == 3);
  CHECK(report.calibrations[0].file == "Ori-FromJson/AutoCal-e1-0.xml");
  const std::vector<MicmacOriImage> back = read_micmac_ori_folder(dir, "FromJson");
  REQUIRE(back.size() == images.size());
  for (const MicmacOriImage& got : back) {
    const auto it = std::find_if(images.begin(), images.end(), [&](const CamerasJsonImage& c) { return c.name == got.name; });
    REQUIRE(it != images.end());
    CHECK((got.pose.centre() - it->centre).cwiseAbs().maxCoeff() <= 1e-6);
    CHECK((got.pose.cam_from_world_rotation() - it->rotation).cwiseAbs().maxCoeff() <= 1e-9);
  }
}

TEST_CASE("micmac_orientation: refused inputs name their file", "[io]") {
  const MicmacoriCalib calib;
  const Mat3 m = micmacori_world_from_cam();
  const std::string dir = micmacori_folder("errors");
  const std::string good = micmacori_orientation_xml(m, kMicmacoriCentre, "Ori-T/AutoCal.xml");
  const std::string path = dir + "/Ori-T/Orientation-x.tif.xml";
  const std::string calibration = dir + "/Ori-T/AutoCal.xml";
  const auto orientation_error = [&](const std::string& text, const std::string& what) {
    micmacori_write(path, text);
    CHECK_THROWS_WITH(read_micmac_orientation(path), Contains(path) && Contains(what));
  };
  const auto calibration_error = [&](const std::string& text, const std::string& what) {
    micmacori_write(calibration, text);
    CHECK_THROWS_WITH(read_micmac_calibration(calibration), Contains(calibration) && Contains(what));
  };
  const auto replaced = [](std::string text, const std::string& from, const std::string& to) {
    const std::size_t at = text.find(from);
    REQUIRE(at != std::string::npos);
    return text.replace(at, from.size(), to);
  };

  orientation_error(good.substr(0, good.find("</OrientationConique>")), "not closed");
  orientation_error(replaced(good, "</Centre>", "</Center>"), "closes <Centre>");
  {
    const std::size_t a = good.find("               <Centre>");
    std::string text = good;
    text.erase(a, good.find("               <IncCentre>") - a);
    orientation_error(text, "<Externe> has no <Centre>");
  }
  orientation_error(micmacori_orientation_xml(m, kMicmacoriCentre, "Ori-T/AutoCal.xml", "eConvOriLib"), "eConvOriLib");
  orientation_error(replaced(good, "<Centre>", "<Centre>1 2 "), "needs 3 numbers");
  orientation_error(replaced(good, "<V10>1 0</V10>", "<V10>1.001 0</V10>"), "OrIntImaM2C");
  orientation_error(replaced(good, "<L1>", "<L1>2 "), "needs 3 numbers");
  orientation_error(replaced(good, "<CodageMatr>", "<CodageAngulaire>0 0 0</CodageAngulaire><CodageMatr>"),
                    "CodageAngulaire");
  orientation_error(replaced(good, "eProjStenope", "eProjOrthographique"), "eProjOrthographique");
  orientation_error(replaced(good, "<Tol>0.001", "<Tol>&nbsp;"), "unknown entity");

  orientation_error(micmacori_orientation_xml(2.0 * m, kMicmacoriCentre, "Ori-T/AutoCal.xml"), "not a rotation");

  const std::string phgr = micmacori_calibration_xml(calib, true, true);
  calibration_error(replaced(phgr, "<ModPhgrStd>", "<ModUnif><TypeModele>eModele_FishEye_10_5_5</TypeModele>"
                                                   "<Params>1</Params></ModUnif><ModPhgrStd>"),
                    "must hold one model");
  {
    std::string text = phgr;
    const std::size_t a = text.find("<CalibDistortion>"), b = text.find("</CalibDistortion>") + 18;
    text.replace(a, b - a,
                 "<CalibDistortion><ModUnif><TypeModele>eModele_FishEye_10_5_5</TypeModele><Params>2697.5</Params>"
                 "</ModUnif></CalibDistortion>");
    calibration_error(text, "eModele_FishEye_10_5_5");
    text = replaced(text, "<ModUnif><TypeModele>eModele_FishEye_10_5_5</TypeModele><Params>2697.5</Params></ModUnif>",
                    "<ModGrid></ModGrid>");
    calibration_error(text, "ModGrid");
  }
  calibration_error(replaced(phgr, "<PPaEqPPs>", "<CoeffDist>1e-29</CoeffDist><PPaEqPPs>"), "R9");
  calibration_error(replaced(phgr, "<KnownConv>eConvApero_DistM2C", "<KnownConv>eConvApero_DistC2M"),
                    "eConvApero_DistC2M");
  calibration_error(replaced(phgr, "</CalibrationInternConique>",
                             "<CalibDistortion><ModRad><CDist>1 1</CDist><CoeffDist>1e-9</CoeffDist></ModRad>"
                             "</CalibDistortion></CalibrationInternConique>"),
                    "several non-identity");
  calibration_error(replaced(phgr, "<F>", "<F>-"), "F must be > 0");
  calibration_error(replaced(phgr, "<SzIm>3000", "<SzIm>3000.5"), "SzIm");

  // Identity layers are skipped: a second, all-zero layer is accepted.
  micmacori_write(calibration, replaced(phgr, "</CalibrationInternConique>",
                                        "<CalibDistortion><ModNoDist></ModNoDist></CalibDistortion>"
                                        "<CalibDistortion><ModRad><CDist>1 1</CDist><CoeffDist>0</CoeffDist></ModRad>"
                                        "</CalibDistortion></CalibrationInternConique>"));
  CHECK(read_micmac_calibration(calibration).distortion_model == "ModPhgrStd");

  // A calibration file that is not there: the Orientation file is named.
  micmacori_write(path, micmacori_orientation_xml(m, kMicmacoriCentre, "Ori-T/Missing.xml"));
  CHECK_THROWS_WITH(read_micmac_ori_folder(dir, "T"), Contains(path) && Contains("does not exist"));
  CHECK_THROWS_WITH(read_micmac_ori_folder(dir, "Nowhere"), Contains("Ori-Nowhere"));

  // Writing: AltiSol is required, names are unique.
  std::vector<MicmacOriImage> images = micmacori_images();
  CHECK_THROWS_WITH(write_micmac_ori_folder(dir, "W", images), Contains("ground_altitude"));
  MicmacWriteOptions options;
  options.ground_altitude = 0.0;
  images[1].name = images[0].name;
  CHECK_THROWS_WITH(write_micmac_ori_folder(dir, "W", images, options), Contains("twice"));
  images[1].name = "a/b.tif";
  CHECK_THROWS_WITH(write_micmac_ori_folder(dir, "W", images, options), Contains("a/b.tif"));
  CHECK_FALSE(std::filesystem::exists(dir + "/Ori-W"));  // nothing written before the checks pass
}

TEST_CASE("xml_lite: elements, attributes, entities, comments and CDATA; errors give the line", "[io]") {
  const XmlElement root = parse_xml(
      "\xEF\xBB\xBF<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!-- a comment -->\n"
      "<a x=\"1 &amp; 2\" y='&quot;q&apos;'>\n  <b>&lt;3 &gt; 2&#33;&#x41;</b>\n  <!-- <c>not an element</c> -->\n"
      "  <c/><b><![CDATA[<raw & text>]]></b>\n</a>\n<?trailing pi?>\n",
      "doc.xml");
  CHECK(root.name == "a");
  CHECK(root.line == 3);
  REQUIRE(root.attribute("x"));
  CHECK(*root.attribute("x") == "1 & 2");
  CHECK(*root.attribute("y") == "\"q'");
  CHECK(root.attribute("z") == nullptr);
  REQUIRE(root.children.size() == 3);
  CHECK(root.children[0].text == "<3 > 2!A");
  CHECK(root.children[0].line == 4);
  CHECK(root.children[1].name == "c");
  CHECK(root.children[1].children.empty());
  CHECK(root.children_named("b").size() == 2);
  CHECK(root.children[2].text == "<raw & text>");
  CHECK(root.child("d") == nullptr);
  CHECK(xml_escaped("a<b>&\"'") == "a&lt;b&gt;&amp;&quot;&apos;");

  const auto error = [](const std::string& text, const std::string& what) {
    CHECK_THROWS_WITH(parse_xml(text, "doc.xml"), Contains(what));
  };
  error("<a>\n<b>\n</a>", "doc.xml:3: </a> closes <b> opened on line 2");
  error("<a>\n<b>x</b>\n", "doc.xml:3: element <a> opened on line 1 is not closed");
  error("<a>&foo;</a>", "unknown entity '&foo;'");
  error("<a>x & y</a>", "'&'");
  error("<!DOCTYPE a><a/>", "DOCTYPE");
  error("<a/><b/>", "a second root");
  error("<a/>text", "text after the root");
  error("<a x=1/>", "quoted");
  error("<a x=\"1\" x=\"2\"/>", "repeated");
  error("", "no root");
  error("<a><!-- open </a>", "unclosed comment");
  std::string deep;
  for (int i = 0; i < 300; ++i) deep += "<a>";
  error(deep, "nested deeper");
  CHECK_THROWS_WITH(read_xml_file("/nonexistent/x.xml"), Contains("/nonexistent/x.xml"));
}
