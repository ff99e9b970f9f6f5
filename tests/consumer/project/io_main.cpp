// An outside project that asked for COMPONENTS core io: writes a small DSM as a GeoTIFF through
// diachron::io and reads it back.
#include <cmath>
#include <cstdio>
#include <string>

#include <diachron/io/geotiff.hpp>

int main(int argc, char** argv) {
  const std::string path = std::string(argc > 1 ? argv[1] : ".") + "/consumer_dsm.tif";
  diachron::Raster<float> heights(4, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) heights(x, y) = static_cast<float>(10 * y + x);
  heights(2, 1) = std::nanf("");
  const diachron::Dsm dsm(heights, diachron::GeoTransform::north_up(500000.0, 5000000.0, 2.0), "EPSG:32632");
  diachron::write_geotiff_dsm(dsm, path);
  const diachron::Dsm back = diachron::read_geotiff_dsm(path);
  bool same = back.width() == 4 && back.height() == 3 && !back.valid(2, 1);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x)
      if (!(x == 2 && y == 1)) same = same && back.heights()(x, y) == heights(x, y);
  std::printf("GeoTIFF round trip %s\n", same ? "exact" : "differs");
  return same ? 0 : 1;
}
