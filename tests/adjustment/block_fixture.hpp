// A small two-epoch aerial block built from geometry alone (no rendering): true frames, ground
// points on rolling terrain, and their noisy observations as tie points and inter-epoch matches.
#pragma once

#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <diachron/adjustment/tracks.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/core/random.hpp>

namespace diachron::test {

struct Block {
  std::vector<Frame<FraserAffine>> truth;      // epoch 0 images first, then epoch 1
  std::vector<Frame<FraserAffine>> estimated;  // epoch 0 perturbed, epoch 1 true
  std::vector<int> epoch;
  std::vector<Eigen::Vector3d> ground;         // true points
  std::vector<std::vector<ImagePixel>> tie_points;
  std::vector<ImageMatch> matches;
  int epoch0_images = 0;
};

inline double terrain(double x, double y) { return 18.0 * std::sin(x / 70.0) * std::cos(y / 95.0) + 8.0 * std::sin(y / 33.0 + x / 51.0); }

// rows x columns images per epoch over the same area; epoch 1 flies higher with a longer lens.
inline Block make_block(std::uint64_t seed, int points = 400, double noise_px = 0.3, int rows = 2, int columns = 3) {
  // The library's own stream: std:: distributions differ between standard libraries.
  RandomStream random(seed);
  Block b;
  const Camera<FraserAffine> camera0(265.0, 201.0, 147.5, 400, 300, {-0.025, 0.004, 0.0, 2e-4, -1.5e-4, 0.4, -0.2});
  const Camera<FraserAffine> camera1(420.0, 198.5, 150.5, 400, 300, {-0.01, 0.002, 0.0, -1e-4, 1e-4, -0.3, 0.15});
  const Camera<FraserAffine> estimated0(265.0 * 1.01, 203.0, 146.5, 400, 300, {-0.0125, 0.002, 0.0, 1e-4, -0.75e-4, 0.0, 0.0});
  for (int e = 0; e < 2; ++e) {
    const double height = e == 0 ? 520.0 : 800.0;
    const double base = 0.4 * 400 * height / (e == 0 ? 265.0 : 420.0);
    const double spacing = 0.7 * 300 * height / (e == 0 ? 265.0 : 420.0);
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < columns; ++c) {
        // One draw per statement, the last argument first: the order of a call's arguments is
        // unspecified (core/random.hpp, "Order of draws"); this is the order the block was made with.
        const double cz = height + 3.0 * random.normal(), cy = (r - 0.5 * (rows - 1)) * spacing + 3.0 * random.normal();
        const Vec3 centre((c - 0.5 * (columns - 1)) * base + 3.0 * random.normal(), cy, cz);
        const double roll = 0.017 * random.normal(), pitch = 0.017 * random.normal();
        const Pose pose = Pose::from_yaw_pitch_roll(centre, (e == 0 ? 0.0 : 0.2) + 0.03 * random.normal(), pitch, roll);
        b.truth.emplace_back(e == 0 ? camera0 : camera1, pose);
        b.epoch.push_back(e);
        if (e == 0) {
          // The epoch's own orientation: a few metres and about 0.2 degrees off.
          const double sz = 0.004 * random.normal(), sy = 0.004 * random.normal();
          const Vec3 small(0.004 * random.normal(), sy, sz);
          const Mat3 turn = Eigen::AngleAxisd(small.norm(), small.normalized()).toRotationMatrix();
          const double oz = 3.0 * random.normal(), oy = 4.0 * random.normal();
          const Vec3 offset(4.0 * random.normal(), oy, oz);
          b.estimated.emplace_back(estimated0, Pose(pose.cam_from_world_rotation() * turn, centre + offset));
        } else {
          b.estimated.push_back(b.truth.back());
        }
      }
    if (e == 0) b.epoch0_images = static_cast<int>(b.truth.size());
  }
  const double half_x = 0.5 * (columns - 1) * 0.4 * 400 * 520.0 / 265.0 + 150.0;
  const double half_y = 0.5 * (rows - 1) * 0.7 * 300 * 520.0 / 265.0 + 110.0;
  for (int k = 0; k < points; ++k) {
    const double x = (2.0 * random.uniform01() - 1.0) * half_x, y = (2.0 * random.uniform01() - 1.0) * half_y;
    const Vec3 p(x, y, terrain(x, y));
    std::vector<ImagePixel> seen[2];
    for (std::size_t i = 0; i < b.truth.size(); ++i) {
      const auto px = b.truth[i].project(p);
      if (!px || !b.truth[i].in_image(*px)) continue;
      const double ny = random.normal();  // y before x, as above
      seen[b.epoch[i]].push_back({static_cast<int>(i), *px + noise_px * Vec2(random.normal(), ny)});
    }
    b.ground.push_back(p);
    for (int e = 0; e < 2; ++e)
      if (seen[e].size() >= 2) b.tie_points.push_back(seen[e]);
    // Every other point also gives inter-epoch matches (master in epoch 0, secondary in epoch 1).
    if (k % 2 == 0)
      for (const ImagePixel& a : seen[0])
        for (const ImagePixel& s : seen[1]) b.matches.push_back({a, s});
  }
  return b;
}

}  // namespace diachron::test
