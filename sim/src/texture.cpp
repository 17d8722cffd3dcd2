#include "mapdelta/sim/texture.hpp"

#include <algorithm>
#include <cmath>

namespace mapdelta::sim {
namespace {

inline uint32_t Hash32(int32_t x, int32_t y, uint32_t seed) {
  uint32_t h = static_cast<uint32_t>(x) * 0x8da6b343u ^ static_cast<uint32_t>(y) * 0xd8163841u ^
               seed * 0xcb1ab31fu;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}
inline float Unit(uint32_t h) { return static_cast<float>(h >> 8) * (1.0f / 16777216.0f); }
inline float Smooth(float t) { return t * t * t * (t * (t * 6.f - 15.f) + 10.f); }
inline float Clamp01(float v) { return std::min(1.f, std::max(0.f, v)); }
inline float SmoothStep(float a, float b, float x) {
  const float t = Clamp01((x - a) / (b - a));
  return t * t * (3.f - 2.f * t);
}
// Weight of a feature with `freq` cycles/m at this footprint: 1 well below Nyquist, 0 above it.
inline float Resolve(float freq, float footprint) {
  return 1.f - SmoothStep(0.2f, 0.5f, freq * footprint);
}
// A per-cell random value that fades to `mean` once the cell is smaller than two pixels.
inline float CellValue(int32_t cx, int32_t cy, uint32_t seed, float cell, float footprint) {
  return (Unit(Hash32(cx, cy, seed)) - 0.5f) * Resolve(1.f / cell, footprint);
}
inline int32_t Cell(float x, float size) { return static_cast<int32_t>(std::floor(x / size)); }

// Box-filtered periodic pulse (see FilteredPulse); inline because facades call it ~10 times.
inline float Pulse(float x, float period, float on, float w) {
  const float inv = 1.f / period;
  if (w < 1e-4f * period) {
    const float t = x - std::floor(x * inv) * period;
    return t < on ? 1.f : 0.f;
  }
  const float a = x - 0.5f * w, b = x + 0.5f * w;
  const float na = std::floor(a * inv), nb = std::floor(b * inv);
  const float ia = na * on + std::min(a - na * period, on);
  const float ib = nb * on + std::min(b - nb * period, on);
  return Clamp01((ib - ia) / w);
}

float Asphalt(float x, float y, float fp) {
  return 0.24f + 0.30f * BandLimitedNoise(x, y, 0.35f, 6, 0.62f, fp, 11u) +
         0.10f * CellValue(Cell(x, 2.3f), Cell(y, 1.7f), 12u, 2.0f, fp);  // patched surface
}

float Paving(float x, float y, float fp) {
  const float tile = 0.6f;
  const float grout = std::max(Pulse(x, tile, 0.04f, fp), Pulse(y, tile, 0.04f, fp));
  const float t = 0.56f + 0.16f * CellValue(Cell(x, tile), Cell(y, tile), 21u, tile, fp) +
                  0.15f * BandLimitedNoise(x, y, 0.5f, 5, 0.55f, fp, 22u);
  return t * (1.f - 0.45f * grout);
}

float Grass(float x, float y, float fp) {
  return 0.30f + 0.40f * BandLimitedNoise(x, y, 0.15f, 7, 0.7f, fp, 31u);
}

float Ground(const Scene& s, float x, float y, float fp) {
  const StreetGrid& g = s.streets;
  const float hw = static_cast<float>(0.5 * g.width), road = hw - static_cast<float>(g.sidewalk);
  float dx = 1e9f, dy = 1e9f, sx = 0.f, sy = 0.f;  // distance and signed offset to the nearest line
  for (double v : g.xs)
    if (std::abs(x - v) < dx) {
      dx = std::abs(x - static_cast<float>(v));
      sx = x - static_cast<float>(v);
    }
  for (double v : g.ys)
    if (std::abs(y - v) < dy) {
      dy = std::abs(y - static_cast<float>(v));
      sy = y - static_cast<float>(v);
    }
  const bool in_x = x > g.xs.front() - hw && x < g.xs.back() + hw;
  const bool in_y = y > g.ys.front() - hw && y < g.ys.back() + hw;
  const bool street_y = dx < hw && in_y;  // street running along y
  const bool street_x = dy < hw && in_x;
  if (!street_x && !street_y) return Grass(x, y, fp);
  const bool road_y = street_y && dx < road, road_x = street_x && dy < road;
  if (!road_x && !road_y) return Paving(x, y, fp);
  float a = Asphalt(x, y, fp);
  float paint = 0.f;
  if (road_y && !road_x && dy > hw) {
    // Dashed centre line, edge lines, and a zebra crossing in front of each intersection.
    paint = std::max(paint, Pulse(sx + 0.075f, 1e3f, 0.15f, fp) * Pulse(y, 6.f, 3.f, fp));
    paint = std::max(paint, Pulse(dx - road + 0.45f, 1e3f, 0.15f, fp));
    if (dy < hw + 3.f) paint = std::max(paint, Pulse(sx + 50.f, 1.0f, 0.5f, fp));
  } else if (road_x && !road_y && dx > hw) {
    paint = std::max(paint, Pulse(sy + 0.075f, 1e3f, 0.15f, fp) * Pulse(x, 6.f, 3.f, fp));
    paint = std::max(paint, Pulse(dy - road + 0.45f, 1e3f, 0.15f, fp));
    if (dx < hw + 3.f) paint = std::max(paint, Pulse(sy + 50.f, 1.0f, 0.5f, fp));
  }
  return a + (0.85f - a) * paint;
}

// Facade: wall material plus a grid of windows (floors 3.2 m), per-window glass brightness.
float Facade(const Object& o, float u, float v, float fp) {
  const uint32_t seed = o.texture_seed;
  const float h = static_cast<float>(o.albedo);
  float wall = h;
  if (o.material == Material::kBrick) {
    const float bw = 0.25f, bh = 0.075f;
    const int32_t row = Cell(v, bh);
    const float shift = (row & 1) ? 0.5f * bw : 0.f;
    const float mortar = std::max(Pulse(v, bh, 0.012f, fp), Pulse(u + shift, bw, 0.012f, fp));
    wall = h * (1.f + 0.25f * CellValue(Cell(u + shift, bw), row, seed, bh, fp)) *
           (1.f - 0.3f * mortar);
    wall *= 1.f + 0.5f * BandLimitedNoise(u, v, 0.4f, 4, 0.5f, fp, seed + 1);
  } else if (o.material == Material::kConcrete) {
    const float joint = std::max(Pulse(u, 1.5f, 0.03f, fp), Pulse(v, 1.6f, 0.03f, fp));
    wall = h * (1.f + 0.35f * CellValue(Cell(u, 1.5f), Cell(v, 1.6f), seed, 1.5f, fp)) *
           (1.f - 0.4f * joint);
    wall *= 1.f + 0.6f * BandLimitedNoise(u, v, 0.6f, 5, 0.6f, fp, seed + 1);
  } else {
    wall = h * (1.f + 0.8f * BandLimitedNoise(u, v, 0.5f, 6, 0.65f, fp, seed + 1));
  }
  // Cornice line at each floor.
  const float floor_h = 3.2f;
  wall *= 1.f - 0.25f * Pulse(v - 0.1f, floor_h, 0.2f, fp);
  // Windows: column pitch and size vary per building.
  const float pitch = 2.6f + 1.2f * Unit(Hash32(1, 2, seed));
  const float ww = pitch * (0.45f + 0.2f * Unit(Hash32(3, 4, seed)));
  const float wh = 1.4f + 0.5f * Unit(Hash32(5, 6, seed));
  const float sill = 0.9f;
  if (v < 2.5f) return wall;  // no windows at street level: doors would need their own pattern
  const float cu = Pulse(u - 0.5f * (pitch - ww), pitch, ww, fp);
  const float cv = Pulse(v - sill, floor_h, wh, fp);
  const float frame_u = Pulse(u - 0.5f * (pitch - ww) + 0.08f, pitch, ww + 0.16f, fp);
  const float frame_v = Pulse(v - sill + 0.08f, floor_h, wh + 0.16f, fp);
  const float glass = 0.10f +
                      0.22f * Unit(Hash32(Cell(u - 0.5f * (pitch - ww), pitch),
                                          Cell(v - sill, floor_h), seed + 7)) +
                      0.08f * Clamp01((std::fmod(std::abs(v - sill), floor_h)) / wh);
  const float frame = 0.8f;
  float a = wall;
  a += (frame - a) * frame_u * frame_v;
  a += (glass - a) * cu * cv;
  return a;
}

}  // namespace

float ValueNoise(float x, float y, uint32_t seed) {
  const float fx = std::floor(x), fy = std::floor(y);
  const int32_t ix = static_cast<int32_t>(fx), iy = static_cast<int32_t>(fy);
  const float tx = Smooth(x - fx), ty = Smooth(y - fy);
  const float a = Unit(Hash32(ix, iy, seed)), b = Unit(Hash32(ix + 1, iy, seed));
  const float c = Unit(Hash32(ix, iy + 1, seed)), d = Unit(Hash32(ix + 1, iy + 1, seed));
  return a + (b - a) * tx + (c - a) * ty + (a - b - c + d) * tx * ty;
}

float BandLimitedNoise(float x, float y, float base_freq, int octaves, float gain, float footprint,
                       uint32_t seed) {
  float sum = 0.f, amp = 1.f, freq = base_freq, norm = 0.f;
  for (int k = 0; k < octaves; ++k) {
    const float w = Resolve(freq, footprint);
    norm += amp;
    if (w <= 0.f) break;  // higher octaves are even less resolvable
    sum +=
        amp * w * (ValueNoise(x * freq, y * freq, seed + 101u * static_cast<uint32_t>(k)) - 0.5f);
    amp *= gain;
    freq *= 2.03f;  // not exactly 2: octaves do not line up on lattice points
  }
  return norm > 0.f ? sum / norm * 1.6f : 0.f;
}

float FilteredPulse(float x, float period, float on, float w) { return Pulse(x, period, on, w); }

float SurfaceAlbedo(const Scene& s, const Hit& hit, const Eigen::Vector3f& p, float fp) {
  if (hit.object < 0) return Clamp01(Ground(s, p.x(), p.y(), fp));
  const Object& o = s.objects[static_cast<size_t>(hit.object)];
  const uint32_t seed = o.texture_seed;
  const bool vertical = std::abs(hit.normal.z()) < 0.5f;
  // Face coordinates: horizontal along the face, vertical up; roofs use x, y.
  const float u = std::abs(hit.normal.x()) > 0.5f ? p.y() : p.x();
  const float v = p.z();
  switch (o.material) {
    case Material::kBrick:
    case Material::kPlaster:
    case Material::kConcrete:
      if (o.kind != "building")
        return Clamp01(o.albedo * (1.f + 0.7f * BandLimitedNoise(u, v, 1.f, 5, 0.6f, fp, seed)));
      if (!vertical) {
        // Flat roof: gravel with a parapet band near the edges.
        return Clamp01(0.42f +
                       0.35f * BandLimitedNoise(p.x(), p.y(), 0.3f, 7, 0.65f, fp, seed + 3));
      }
      return Clamp01(Facade(o, u, v, fp));
    case Material::kCar: {
      const float glass = Pulse(v - 0.95f, 10.f, 0.4f, fp);
      const float body = o.albedo * (1.f + 0.2f * BandLimitedNoise(u, v, 2.f, 3, 0.5f, fp, seed));
      return Clamp01(body + (0.12f - body) * glass);
    }
    case Material::kFoliage:
      if (hit.box == 0)
        return Clamp01(0.22f + 0.3f * BandLimitedNoise(u, v, 2.f, 4, 0.6f, fp, seed));  // trunk
      return Clamp01(0.28f + 0.6f * BandLimitedNoise(vertical ? u : p.x(), vertical ? v : p.y(),
                                                     1.2f, 5, 0.75f, fp, seed));
    case Material::kTrunk:
      return Clamp01(0.22f + 0.3f * BandLimitedNoise(u, v, 2.f, 4, 0.6f, fp, seed));
    case Material::kMetal:
      return Clamp01(o.albedo + 0.2f * BandLimitedNoise(u, v, 1.f, 4, 0.5f, fp, seed));
    case Material::kMirror:
      return o.albedo;
  }
  return 0.5f;
}

}  // namespace mapdelta::sim
