// draw_scan_frame (synth/scan_frame.hpp): the band and only the band is drawn and masked, its marks
// are there, and bad bands are errors.

#include <cstdint>

#include <catch2/catch.hpp>

#include <diachron/synth/scan_frame.hpp>

#include "support/rasters.hpp"

using namespace diachron;

TEST_CASE("draw_scan_frame: a masked band with marks, the ground inside untouched", "[synth][scan_frame]") {
  const Raster<std::uint8_t> ground = diachron::test::uniform_noise_image(200, 150, 3);
  Raster<std::uint8_t> image = ground;
  ScanFrameOptions options;
  options.band_px = 24;
  const Raster<std::uint8_t> mask = draw_scan_frame(image, options);
  REQUIRE(mask.width() == 200);
  REQUIRE(mask.height() == 150);
  int marks = 0;
  for (int y = 0; y < 150; ++y)
    for (int x = 0; x < 200; ++x) {
      const bool band = x < 24 || y < 24 || x >= 176 || y >= 126;
      INFO("pixel " << x << ", " << y);
      REQUIRE((mask(x, y) == 0) == band);
      if (!band) {
        REQUIRE(mask(x, y) == 255);
        REQUIRE(image(x, y) == ground(x, y));
      } else {
        REQUIRE((image(x, y) == options.band_grey || image(x, y) == options.mark_grey));
        marks += image(x, y) == options.mark_grey;
      }
    }
  // Eight fiducial marks and the data strip.
  CHECK(marks > 8 * 20);
  // The centre of the top-left mark is its cross.
  CHECK(image(12, 12) == options.mark_grey);

  Raster<std::uint8_t> untouched = ground;
  options.band_px = 0;
  const Raster<std::uint8_t> none = draw_scan_frame(untouched, options);
  for (int y = 0; y < 150; ++y)
    for (int x = 0; x < 200; ++x) REQUIRE((none(x, y) == 255 && untouched(x, y) == ground(x, y)));

  options.band_px = 51;
  CHECK_THROWS_WITH(draw_scan_frame(untouched, options), Catch::Contains("leaves nothing of a 200 x 150 px image"));
  options.band_px = -1;
  CHECK_THROWS_WITH(draw_scan_frame(untouched, options), Catch::Contains("band_px must be >= 0"));
}
