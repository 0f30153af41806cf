// Self-contained random numbers and band-limited procedural patterns for the synthetic sequence.
//
// Everything here is defined by integer arithmetic and IEEE double operations only, so a seed gives
// bit-identical worlds and images with any standard library (std:: distributions are avoided on
// purpose: their output is implementation-defined).
//
// Anti-aliasing: every pattern takes the width of the pixel footprint in its own coordinates and
// returns the pattern averaged over that width (exact box filtering for pulse trains, octave
// fading for noise), so images do not alias at any distance.
#ifndef DFO_CORE_SYNTHETIC_NOISE_H_
#define DFO_CORE_SYNTHETIC_NOISE_H_

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace dfo::synthetic {

// SplitMix64 (Steele, Lea, Flood 2014; the seeding generator of xoshiro): a 64-bit state advanced
// by a Weyl sequence and scrambled. Good enough statistics for scene layout, trivially portable.
class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) : state_(seed) {}

  // Next 64 random bits.
  uint64_t Next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform double in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(Next() >> 11) * (1.0 / 9007199254740992.0); }
  // Uniform double in [lo, hi).
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Uniform integer in [lo, hi] (inclusive; the tiny modulo bias is irrelevant here).
  int UniformInt(int lo, int hi) {
    return lo + static_cast<int>(Next() % static_cast<uint64_t>(hi - lo + 1));
  }
  // True with probability p.
  bool Bernoulli(double p) { return Uniform() < p; }

 private:
  uint64_t state_;
};

// 32-bit hash of integer lattice coordinates and a seed (murmur3 finaliser over a linear mix).
inline uint32_t HashLattice(int32_t x, int32_t y, int32_t z, uint32_t seed) {
  uint32_t h = seed * 0x9E3779B1u;
  h ^= static_cast<uint32_t>(x) * 0x85EBCA77u;
  h = (h << 13) | (h >> 19);
  h ^= static_cast<uint32_t>(y) * 0xC2B2AE3Du;
  h = (h << 17) | (h >> 15);
  h ^= static_cast<uint32_t>(z) * 0x27D4EB2Fu;
  h ^= h >> 16;
  h *= 0x85EBCA6Bu;
  h ^= h >> 13;
  h *= 0xC2B2AE35u;
  h ^= h >> 16;
  return h;
}

// Hash mapped to [0, 1).
inline double HashUnit(int32_t x, int32_t y, int32_t z, uint32_t seed) {
  return static_cast<double>(HashLattice(x, y, z, seed) >> 8) * (1.0 / 16777216.0);
}

// Value noise in 2D, range [-1, 1], one lattice cell per unit, quintic interpolation (C2). Its
// energy sits below ~1 cycle per unit, which the octave fading of FilteredNoise2 relies on.
inline double ValueNoise2(double x, double y, uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int32_t ix = static_cast<int32_t>(fx), iy = static_cast<int32_t>(fy);
  const double tx = x - fx, ty = y - fy;
  const double sx = tx * tx * tx * (tx * (tx * 6.0 - 15.0) + 10.0);
  const double sy = ty * ty * ty * (ty * (ty * 6.0 - 15.0) + 10.0);
  const double v00 = HashUnit(ix, iy, 0, seed), v10 = HashUnit(ix + 1, iy, 0, seed);
  const double v01 = HashUnit(ix, iy + 1, 0, seed), v11 = HashUnit(ix + 1, iy + 1, 0, seed);
  const double a = v00 + sx * (v10 - v00);
  const double b = v01 + sx * (v11 - v01);
  return 2.0 * (a + sy * (b - a)) - 1.0;
}

// Value noise in 3D, range [-1, 1] (used for sky clouds on the direction sphere).
inline double ValueNoise3(double x, double y, double z, uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int32_t ix = static_cast<int32_t>(fx), iy = static_cast<int32_t>(fy),
                iz = static_cast<int32_t>(fz);
  auto smooth = [](double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); };
  const double sx = smooth(x - fx), sy = smooth(y - fy), sz = smooth(z - fz);
  double plane[2];
  for (int k = 0; k < 2; ++k) {
    const double v00 = HashUnit(ix, iy, iz + k, seed), v10 = HashUnit(ix + 1, iy, iz + k, seed);
    const double v01 = HashUnit(ix, iy + 1, iz + k, seed);
    const double v11 = HashUnit(ix + 1, iy + 1, iz + k, seed);
    const double a = v00 + sx * (v10 - v00);
    const double b = v01 + sx * (v11 - v01);
    plane[k] = a + sy * (b - a);
  }
  return 2.0 * (plane[0] + sz * (plane[1] - plane[0])) - 1.0;
}

// Weight in [0, 1] of a pattern component of `frequency` cycles per unit seen through a pixel
// footprint of `footprint` units: 1 below 0.15 cycles per pixel, fading linearly to 0 at 0.4 cycles
// per pixel, so nothing reaches the image near or above Nyquist (0.5). The margin below Nyquist
// keeps the images smooth enough for bilinear warping between frames (what the warp test and the
// direct tracker do); components in 0.25..0.5 cycles per pixel are what bilinear interpolation
// reproduces worst.
inline double BandLimit(double frequency, double footprint) {
  const double cycles_per_pixel = frequency * footprint;
  if (cycles_per_pixel <= 0.15) return 1.0;
  if (cycles_per_pixel >= 0.4) return 0.0;
  return (0.4 - cycles_per_pixel) * 4.0;
}

// Fractal sum of `octaves` value-noise octaves starting at `base_frequency` cycles per unit, each
// octave `lacunarity` times finer and `gain` times weaker; octaves beyond Nyquist for `footprint`
// are faded out. Range about [-1, 1] times the sum of the amplitudes.
inline double FilteredNoise2(double x, double y, double base_frequency, int octaves, double gain,
                             double footprint, uint32_t seed, double lacunarity = 2.17) {
  double sum = 0.0, amplitude = 1.0, frequency = base_frequency;
  for (int o = 0; o < octaves; ++o) {
    const double w = BandLimit(frequency, footprint);
    if (w <= 0.0) break;
    sum += w * amplitude * ValueNoise2(x * frequency, y * frequency, seed + 7919u * o);
    amplitude *= gain;
    frequency *= lacunarity;
  }
  return sum;
}

// Pulse train of period 1 that is 1 on [0, duty) + k and 0 elsewhere, averaged over the interval
// [x - width/2, x + width/2] (exact box filter, "filteredpulsetrain" of Apodaca & Gritz, Advanced
// RenderMan, ch. 11): uses the integral F(x) = floor(x) * duty + min(frac(x), duty).
inline double FilteredPulseTrain(double x, double duty, double width) {
  if (width < 1e-6) {
    const double f = x - std::floor(x);
    return f < duty ? 1.0 : 0.0;
  }
  auto integral = [duty](double t) {
    const double ft = std::floor(t);
    return ft * duty + std::min(t - ft, duty);
  };
  const double x0 = x - 0.5 * width, x1 = x + 0.5 * width;
  return (integral(x1) - integral(x0)) / width;
}

// Length of the overlap of [a0, a1] and [b0, b1] (0 when disjoint).
inline double Overlap(double a0, double a1, double b0, double b1) {
  const double lo = a0 > b0 ? a0 : b0, hi = a1 < b1 ? a1 : b1;
  return hi > lo ? hi - lo : 0.0;
}

}  // namespace dfo::synthetic

#endif  // DFO_CORE_SYNTHETIC_NOISE_H_
