#pragma once
/// @file
/// PointMatch: one tentative correspondence between two images, as PairMatchers return them.

#include <cstddef>
#include <vector>

#include <Eigen/Core>

namespace diachron {

/// A correspondence between pixel `a` of image A (the master) and pixel `b` of image B (the
/// secondary), in each image's pixel convention (docs/conventions.md). `score` is the matcher's
/// confidence, higher is better (e.g. cosine similarity, or minus a descriptor distance); matchers
/// that have none leave it at 0.
struct PointMatch {
  Eigen::Vector2d a = Eigen::Vector2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  double score = 0.0;
};

using PointMatches = std::vector<PointMatch>;

}  // namespace diachron
