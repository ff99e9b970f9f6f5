#include <catch2/catch.hpp>

#include <string>

#include <diachron/terrain/crs_kind.hpp>

using diachron::crs_kind;
using diachron::CrsKind;

// Shortened but well-formed WKT of the shapes GDAL and PROJ write (the GDAL-backed oracle test of
// tests/io/dsm_reproject_test.cpp compares crs_kind with OGR on complete ones).
namespace {

const std::string kGeogcs =
    R"(GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],PRIMEM["Greenwich",0],)"
    R"(UNIT["degree",0.0174532925199433],AUTHORITY["EPSG","4326"]])";
const std::string kProjcs =
    R"(PROJCS["WGS 84 / UTM zone 33N",)" + kGeogcs +
    R"(,PROJECTION["Transverse_Mercator"],PARAMETER["central_meridian",15],UNIT["metre",1],AUTHORITY["EPSG","32633"]])";
const std::string kVertCs = R"(VERT_CS["EGM96 height",VERT_DATUM["EGM96",2005],UNIT["metre",1]])";

}  // namespace

TEST_CASE("crs_kind reads WKT1 as GDAL writes it", "[terrain][crs]") {
  CHECK(crs_kind(kGeogcs) == CrsKind::geographic);
  CHECK(crs_kind(kProjcs) == CrsKind::projected);
  CHECK(crs_kind(R"(GEOCCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257]],UNIT["metre",1]])") ==
        CrsKind::geocentric);
  CHECK(crs_kind(R"(LOCAL_CS["sfm model",UNIT["metre",1]])") == CrsKind::engineering);
  // A compound CRS is the kind of its horizontal part, whatever its name says.
  CHECK(crs_kind(R"(COMPD_CS["PROJCS[ in a name",)" + kProjcs + "," + kVertCs + "]") == CrsKind::projected);
  CHECK(crs_kind(R"(COMPD_CS["WGS 84 + EGM96 height",)" + kGeogcs + "," + kVertCs + "]") == CrsKind::geographic);
  // Leading blanks and lower case keywords.
  CHECK(crs_kind("  \n" + std::string("geogcs[\"x\",DATUM[\"d\",SPHEROID[\"s\",1,0]]]")) == CrsKind::geographic);
}

TEST_CASE("crs_kind reads WKT2", "[terrain][crs]") {
  const std::string geog2 =
      R"(GEOGCRS["WGS 84",DATUM["World Geodetic System 1984",ELLIPSOID["WGS 84",6378137,298.257223563]],)"
      R"(CS[ellipsoidal,2],AXIS["latitude",north],AXIS["longitude",east],ANGLEUNIT["degree",0.0174532925199433]])";
  const std::string proj2 =
      R"(PROJCRS["WGS 84 / UTM zone 10N",BASEGEOGCRS["WGS 84",DATUM["WGS 1984",ELLIPSOID["WGS 84",6378137,298.2]]],)"
      R"(CONVERSION["UTM zone 10N",METHOD["Transverse Mercator"]],CS[Cartesian,2],LENGTHUNIT["metre",1]])";
  CHECK(crs_kind(geog2) == CrsKind::geographic);
  CHECK(crs_kind(proj2) == CrsKind::projected);
  CHECK(crs_kind(R"(GEODCRS["WGS 84",DATUM["d",ELLIPSOID["e",6378137,298.2]],CS[ellipsoidal,3]])") ==
        CrsKind::geographic);
  CHECK(crs_kind(R"(GEODCRS["WGS 84",DATUM["d",ELLIPSOID["e",6378137,298.2]],CS[Cartesian,3]])") ==
        CrsKind::geocentric);
  CHECK(crs_kind(R"(ENGCRS["site grid",EDATUM["site"],CS[Cartesian,2]])") == CrsKind::engineering);
  CHECK(crs_kind(R"(COMPOUNDCRS["x",)" + proj2 + R"(,VERTCRS["h",VDATUM["v"],CS[vertical,1]]])") == CrsKind::projected);
  CHECK(crs_kind(R"(BOUNDCRS[SOURCECRS[)" + geog2 + R"(],TARGETCRS[)" + geog2 + R"(],ABRIDGEDTRANSFORMATION["t"]])") ==
        CrsKind::geographic);
}

TEST_CASE("crs_kind says unknown where the text cannot tell", "[terrain][crs]") {
  CHECK(crs_kind("") == CrsKind::unknown);
  CHECK(crs_kind("EPSG:4326") == CrsKind::unknown);  // a code needs a CRS database
  CHECK(crs_kind("local equirectangular") == CrsKind::unknown);
  CHECK(crs_kind("COMPD_CS[") == CrsKind::unknown);  // truncated
  CHECK(crs_kind("BOUNDCRS[TARGETCRS[x]]") == CrsKind::unknown);
  CHECK(std::string(diachron::to_string(CrsKind::geographic)) == "geographic");
  CHECK(std::string(diachron::to_string(CrsKind::unknown)) == "unknown");
}
