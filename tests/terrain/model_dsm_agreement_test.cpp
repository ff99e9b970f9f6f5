// model_dsm_agreement on an analytic hilly DSM and points sampled on its surface with noise: in one
// frame they agree; a vertical offset beyond three tolerances is gross, with the offset found; a
// horizontal one on sloped ground is found and graded; points off the DSM, too few points and bad
// input.

#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/terrain/model_dsm_agreement.hpp>

using namespace diachron;

namespace {

double model_surface(double x, double y) { return 30.0 * std::sin(x / 40.0) + 20.0 * std::cos(y / 25.0); }

// 300 x 300 cells of 1 unit.
Dsm model_hills() {
  Raster<float> z(300, 300);
  for (int y = 0; y < 300; ++y)
    for (int x = 0; x < 300; ++x) z(x, y) = static_cast<float>(model_surface(x, 300.0 - y));
  return Dsm(z, GeoTransform::north_up(-0.5, 300.5, 1.0));
}

// 1000 points on the surface inside the DSM, 0.3 units of height noise, moved by `offset`.
std::vector<Eigen::Vector3d> model_points(const Eigen::Vector3d& offset = Eigen::Vector3d::Zero()) {
  RandomStream random(7);
  std::vector<Eigen::Vector3d> out;
  for (int k = 0; k < 1000; ++k) {
    const double y = random.uniform(30.0, 270.0);  // y before x (core/random.hpp, "Order of draws")
    const double x = random.uniform(30.0, 270.0);
    out.push_back(Eigen::Vector3d(x, y, model_surface(x, y) + random.normal(0.0, 0.3)) + offset);
  }
  return out;
}

}  // namespace

TEST_CASE("model_dsm_agreement: points on the DSM agree", "[terrain]") {
  const ModelDsmAgreement r = model_dsm_agreement(model_points(), model_hills(), /*gsd=*/0.5);
  INFO(r.message);
  CHECK(r.verdict == ModelDsmVerdict::agree);
  CHECK(r.on_dsm == 1000);
  CHECK(r.tolerance == 3.0);  // 3 cells of 1 unit beat 3 GSD of 0.5
  CHECK(std::abs(r.median_dz) < 0.05);
  CHECK(std::abs(r.nmad_dz - 0.3) < 0.05);
  CHECK(r.share_within > 0.99);
  CHECK(r.best_offset.head<2>().norm() == 0.0);
}

TEST_CASE("model_dsm_agreement: a model high above its DSM is a gross disagreement, the offset named",
          "[terrain]") {
  const ModelDsmAgreement r = model_dsm_agreement(model_points(Eigen::Vector3d(0, 0, 130.0)), model_hills(), 0.5);
  INFO(r.message);
  CHECK(r.verdict == ModelDsmVerdict::gross);
  CHECK(std::abs(r.median_dz - 130.0) < 0.1);
  CHECK(r.share_within == 0.0);
  CHECK((r.best_offset - Eigen::Vector3d(0, 0, -130.0)).norm() < 0.1);
  CHECK(r.best_share > 0.99);
  CHECK(r.message.find("the best shift of the points found is (0, 0, -130") != std::string::npos);
  // Between one and three tolerances: a warning, not a refusal.
  CHECK(model_dsm_agreement(model_points(Eigen::Vector3d(0, 0, 5.0)), model_hills(), 0.5).verdict == ModelDsmVerdict::mild);
}

TEST_CASE("model_dsm_agreement: a horizontal offset on sloped ground is found and graded", "[terrain]") {
  // 4 units east: the heights disagree by up to 3 units on the slopes; the search puts it back.
  const ModelDsmAgreement small = model_dsm_agreement(model_points(Eigen::Vector3d(4.0, 0, 0)), model_hills(), 0.5);
  INFO(small.message);
  CHECK((small.best_offset.head<2>() - Eigen::Vector2d(-4.0, 0.0)).norm() < 1e-9);
  CHECK(small.best_nmad_dz < 0.5 * small.nmad_dz);
  CHECK(small.verdict == ModelDsmVerdict::mild);
  // 12 units, more than 3 tolerances: refused.
  const ModelDsmAgreement far = model_dsm_agreement(model_points(Eigen::Vector3d(0.0, 12.0, 0)), model_hills(), 0.5);
  INFO(far.message);
  CHECK(far.verdict == ModelDsmVerdict::gross);
  // Beyond the search (25 cells): the edge is said, and it is refused.
  const ModelDsmAgreement beyond = model_dsm_agreement(model_points(Eigen::Vector3d(40.0, 0.0, 0)), model_hills(), 0.5);
  INFO(beyond.message);
  CHECK(beyond.verdict == ModelDsmVerdict::gross);
}

TEST_CASE("model_dsm_agreement: points off the DSM, too few points, bad input", "[terrain]") {
  const ModelDsmAgreement off = model_dsm_agreement(model_points(Eigen::Vector3d(5000.0, 0, 0)), model_hills(), 0.5);
  CHECK(off.verdict == ModelDsmVerdict::gross);
  CHECK(off.on_dsm == 0);
  CHECK(off.message.find("0 of 1000 model points lie over the DSM") != std::string::npos);
  std::vector<Eigen::Vector3d> few = model_points();
  few.resize(10);
  CHECK(model_dsm_agreement(few, model_hills(), 0.5).verdict == ModelDsmVerdict::unknown);
  CHECK_THROWS_AS(model_dsm_agreement(model_points(), Dsm{}, 0.5), Error);
  CHECK_THROWS_AS(model_dsm_agreement(model_points(), model_hills(), -1.0), Error);
  std::vector<Eigen::Vector3d> bad = model_points();
  bad[3].x() = std::nan("");
  CHECK_THROWS_AS(model_dsm_agreement(bad, model_hills(), 0.5), Error);
  ModelDsmAgreementOptions options;
  options.gross_share = 0.9;  // above agree_share
  CHECK_THROWS_AS(model_dsm_agreement(model_points(), model_hills(), 0.5, options), Error);
}
