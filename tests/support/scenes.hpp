#pragma once
/// @file
/// The small synthetic scene several test files generate: the plain generator's two epochs, each a
/// single flight line of 2 images of 400 x 300 px.

#include <cstdint>

#include <diachron/synth/scene.hpp>

namespace diachron::test {

/// SceneOptions of a small two-epoch scene: 1 x 2 images per epoch, `tie_points` intra-epoch tie
/// points per epoch and `check_points` check points, everything else the generator's defaults.
inline SceneOptions small_scene_options(std::uint64_t seed, int tie_points, int check_points) {
  SceneOptions o;
  o.seed = seed;
  for (EpochOptions& e : o.epochs) {
    e.rows = 1;
    e.columns = 2;
    e.tie_points = tie_points;
  }
  o.check_points = check_points;
  return o;
}

}  // namespace diachron::test
