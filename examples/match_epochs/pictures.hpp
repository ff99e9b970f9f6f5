#pragma once
// match_epochs (examples/match_epochs/main.cpp): the pictures of the pairs, drawn from shrunk copies of the images.

namespace match_epochs {

using namespace diachron;

// The pictures are drawn from copies of the images at most kPictureSidePx on their longer side
// (the pictures themselves are at most 1600 px). Images up to that size are kept as they are.
// Each picture's image is read when it is drawn and dropped after it: memory does not grow with
// the number of images.
constexpr int kPictureSidePx = 2000;

struct Picture {
  Raster<std::uint8_t> image;
  Vec2 scale = Vec2::Ones();  // picture px per image px, per axis
  /// An image pixel (centre convention) in the picture.
  Vec2 at(const Vec2& p) const { return (p + Vec2::Constant(0.5)).cwiseProduct(scale) - Vec2::Constant(0.5); }
};

// `image` shrunk for a picture.
Picture picture_of(const Raster<std::uint8_t>& image) {
  Picture p;
  const int w = image.width(), h = image.height();
  const double s = std::min(1.0, static_cast<double>(kPictureSidePx) / std::max(w, h));
  if (s >= 1.0) {
    p.image = image;
    return p;
  }
  const int pw = std::max(1, static_cast<int>(std::lround(w * s))), ph = std::max(1, static_cast<int>(std::lround(h * s)));
  cv::Mat small;
  cv::resize(as_mat(image), small, cv::Size(pw, ph), 0.0, 0.0, cv::INTER_AREA);
  p.image = to_raster<std::uint8_t>(small);
  p.scale = Vec2(static_cast<double>(pw) / w, static_cast<double>(ph) / h);
  return p;
}

// A pair's picture (vision/draw_pair_overlay.hpp): the secondary image warped onto the master's
// through the homography that best maps its final matches (least squares over all of them, in the
// pictures' pixels; over relief that is the plane the matches share, good enough to see whether
// the two images line up), the matches as dots coloured by their correlation score or, for the
// descriptor methods, by their distance to that homography (relief parallax included). Fewer than
// 4 matches draw no picture: they hold no homography.
void write_pair_picture(const std::string& path, const Picture& pa, const Picture& pb, const PointMatches& matches,
                        bool scores, const std::string& title) {
  std::vector<PointPair2> pairs;
  for (const PointMatch& m : matches) pairs.push_back({pb.at(m.b), pa.at(m.a)});
  const std::optional<Homography2> h = estimate_homography(pairs);
  if (!h) return;
  std::vector<Vec2> points;
  std::vector<double> values;
  for (std::size_t k = 0; k < matches.size(); ++k) {
    points.push_back(pairs[k].target);
    const std::optional<Vec2> mapped = (*h)(pairs[k].source);
    values.push_back(scores ? matches[k].score
                            : mapped ? (*mapped - pairs[k].target).norm() / pa.scale.x()
                                     : 1e9);  // off the scale: drawn as the worst
  }
  DrawPairOverlayOptions o;
  o.title = title;
  if (!scores) {
    o.values = PairOverlayValues::ResidualPx;
    o.value_low = 0.0;
    o.value_high = 10.0;
    o.value_name = "distance to the homography (master px)";
  } else {
    o.value_name = "correlation score";
  }
  write_pair_overlay_jpg(path, pa.image, pb.image, h->matrix, points, values, o);
}

}  // namespace match_epochs
