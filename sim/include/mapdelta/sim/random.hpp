#pragma once
// Deterministic random numbers that do not depend on the standard library's distributions
// (those differ between implementations): SplitMix64 for streams and counter-based hashing
// for values that must not depend on evaluation order (per-pixel noise, texture cells).
#include <cmath>
#include <cstdint>

namespace mapdelta::sim {

inline uint64_t Mix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}
inline uint64_t HashCombine(uint64_t a, uint64_t b) {
  return Mix64(a ^ (Mix64(b) + 0x632be59bd9b4e019ULL));
}
// Uniform in [0, 1) from the top 53 bits.
inline double ToUnit(uint64_t x) { return static_cast<double>(x >> 11) * 0x1.0p-53; }

class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(Mix64(seed)) {}
  uint64_t Next() { return Mix64(state_++); }
  double Uniform() { return ToUnit(Next()); }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Integer in [lo, hi].
  int Int(int lo, int hi) { return lo + static_cast<int>(Uniform() * (hi - lo + 1)); }
  bool Chance(double p) { return Uniform() < p; }
  // Standard normal by Box-Muller (one value per call, the pair's second is discarded).
  double Gaussian() {
    const double u1 = 1.0 - Uniform();  // (0, 1]
    const double u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }

 private:
  uint64_t state_;
};

// A standard normal value determined only by `key` (Box-Muller on two hashed uniforms).
inline double HashGaussian(uint64_t key) {
  const uint64_t a = Mix64(key);
  const uint64_t b = Mix64(a ^ 0xd1b54a32d192ed03ULL);
  const double u1 = 1.0 - ToUnit(a);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * ToUnit(b));
}

}  // namespace mapdelta::sim
