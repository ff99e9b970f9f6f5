#pragma once
/// @file
/// Smooth deterministic noise for the synthetic scene generator: lattice value noise and its
/// multi-octave sum (fractal Brownian motion), a pure function of (seed, X, Y).
///
/// A hash of the lattice coordinates rather than a stored table keeps the field unbounded in
/// extent and identical whatever the order or thread in which samples are taken.

#include <cmath>
#include <cstdint>

#include <diachron/core/random.hpp>

namespace diachron::detail {

/// Uniform value in [-1, 1) attached to the integer lattice node (ix, iy) of the field `seed`.
/// One multiply-xorshift round over a linear combination of the coordinates: the finaliser is
/// bijective and mixes every input bit, which is all a texture needs, at a third of the cost of
/// chained full mixes (the generator evaluates this millions of times).
inline double lattice_value(std::uint64_t seed, std::int64_t ix, std::int64_t iy) {
  const std::uint64_t h = mix64(seed ^ (static_cast<std::uint64_t>(ix) * 0xd1b54a32d192ed03ULL) ^
                                (static_cast<std::uint64_t>(iy) * 0x8cb92ba72f3d8dd7ULL));
  return static_cast<double>(h >> 11) * 0x1.0p-52 - 1.0;
}

/// Uniform value in [0, 1) attached to the lattice node (ix, iy): a per-cell random draw.
inline double lattice_uniform(std::uint64_t seed, std::int64_t ix, std::int64_t iy) {
  return 0.5 * (lattice_value(seed, ix, iy) + 1.0);
}

/// Quintic fade 6t^5 - 15t^4 + 10t^3: C2-continuous, so shaded relief shows no lattice creases.
inline double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

/// Value noise in [-1, 1] with one lattice cell per unit of (x, y).
inline double value_noise(std::uint64_t seed, double x, double y) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy);
  const double tx = fade(x - fx), ty = fade(y - fy);
  const double v00 = lattice_value(seed, ix, iy), v10 = lattice_value(seed, ix + 1, iy);
  const double v01 = lattice_value(seed, ix, iy + 1), v11 = lattice_value(seed, ix + 1, iy + 1);
  const double a = v00 + (v10 - v00) * tx;
  const double b = v01 + (v11 - v01) * tx;
  return a + (b - a) * ty;
}

/// Sum of `octaves` value-noise layers, the first with wavelength `wavelength` (units of x, y),
/// each next one half the wavelength and `persistence` times the amplitude; normalised so that
/// the result stays in [-1, 1]. Every octave has its own sub-seed so layers do not align.
inline double fbm(std::uint64_t seed, double x, double y, double wavelength, int octaves,
                  double persistence = 0.5) {
  double sum = 0.0, norm = 0.0, amplitude = 1.0, frequency = 1.0 / wavelength;
  for (int o = 0; o < octaves; ++o) {
    const std::uint64_t s = mix64(seed + static_cast<std::uint64_t>(o) * 0x2545f4914f6cdd1dULL);
    // An irrational offset per octave keeps lattice nodes of different octaves from coinciding.
    sum += amplitude * value_noise(s, x * frequency + 0.318 * o, y * frequency + 0.571 * o);
    norm += amplitude;
    amplitude *= persistence;
    frequency *= 2.0;
  }
  return norm > 0.0 ? sum / norm : 0.0;
}

}  // namespace diachron::detail
