// Procedural city: street grid -> blocks -> lots -> buildings (box or L-shape), then small
// objects on sidewalks and streets. All randomness comes from one seeded Rng, consumed in a
// fixed order, so a seed always gives the same city.
#include <algorithm>
#include <cmath>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/sim/random.hpp"
#include "mapdelta/sim/scene.hpp"

namespace mapdelta::sim {
namespace {

// Street centre lines: n blocks of `block` between n+1 streets, centred on the origin.
std::vector<double> StreetLines(double extent, double block, double street) {
  const double pitch = block + street;
  const int n = std::max(1, static_cast<int>(std::floor((extent - street) / pitch)));
  const double first = -0.5 * n * pitch;
  std::vector<double> lines;
  for (int k = 0; k <= n; ++k) lines.push_back(first + k * pitch);
  return lines;
}

Box MakeBox(double x0, double y0, double x1, double y1, double z1) {
  Box b;
  b.min = {std::min(x0, x1), std::min(y0, y1), 0.0};
  b.max = {std::max(x0, x1), std::max(y0, y1), z1};
  return b;
}

// A building on the lot [x0,x1]x[y0,y1]: a box with setbacks, sometimes an L or a tower on a base.
Object MakeBuilding(Rng& rng, double x0, double y0, double x1, double y1, const SimConfig& c) {
  Object o;
  o.kind = "building";
  const double setback = std::min(2.5, 0.15 * std::min(x1 - x0, y1 - y0));
  x0 += rng.Uniform(0.8, 1.0) * setback;
  y0 += rng.Uniform(0.8, 1.0) * setback;
  x1 -= rng.Uniform(0.8, 1.0) * setback;
  y1 -= rng.Uniform(0.8, 1.0) * setback;
  // Heights skewed towards the low end: most buildings are mid-rise, a few are towers.
  const double u = rng.Uniform();
  const double h = c.min_height + (c.max_height - c.min_height) * u * u;
  const double shape = rng.Uniform();
  if (shape < 0.55) {
    o.boxes.push_back(MakeBox(x0, y0, x1, y1, h));
  } else if (shape < 0.8) {
    // L-shape: full-height wing along one side plus a lower wing along the other.
    const double fx = rng.Uniform(0.45, 0.6), fy = rng.Uniform(0.45, 0.6);
    const double xm = x0 + fx * (x1 - x0), ym = y0 + fy * (y1 - y0);
    o.boxes.push_back(MakeBox(x0, y0, xm, y1, h));
    o.boxes.push_back(MakeBox(x0, y0, x1, ym, std::max(c.min_height, h * rng.Uniform(0.5, 0.8))));
  } else {
    // Tower on a podium.
    const double podium = std::max(4.0, std::min(h * 0.35, 8.0));
    o.boxes.push_back(MakeBox(x0, y0, x1, y1, podium));
    const double ix = 0.2 * (x1 - x0), iy = 0.2 * (y1 - y0);
    o.boxes.push_back(MakeBox(x0 + ix, y0 + iy, x1 - ix, y1 - iy, std::max(h, podium + 4.0)));
  }
  const double m = rng.Uniform();
  o.material = m < 0.5 ? Material::kBrick : (m < 0.8 ? Material::kPlaster : Material::kConcrete);
  o.albedo = static_cast<float>(rng.Uniform(0.35, 0.75));
  o.texture_seed = static_cast<uint32_t>(rng.Next());
  return o;
}

void AddSmallObjects(Rng& rng, const SimConfig& c, Scene* s) {
  const StreetGrid& g = s->streets;
  const double lo_x = g.xs.front(), hi_x = g.xs.back(), lo_y = g.ys.front(), hi_y = g.ys.back();
  for (int k = 0; k < c.small_objects; ++k) {
    Object o;
    o.texture_seed = static_cast<uint32_t>(rng.Next());
    // Along a random street, at a random position between intersections.
    const bool along_x = rng.Chance(0.5);
    const double line = along_x ? g.ys[rng.Int(0, static_cast<int>(g.ys.size()) - 1)]
                                : g.xs[rng.Int(0, static_cast<int>(g.xs.size()) - 1)];
    double along = along_x ? rng.Uniform(lo_x, hi_x) : rng.Uniform(lo_y, hi_y);
    // Keep intersections clear so the flight path around corners is free.
    const auto& cross = along_x ? g.xs : g.ys;
    bool near_crossing = false;
    for (double x : cross) near_crossing |= std::abs(along - x) < 0.5 * g.width + 3.0;
    if (near_crossing) continue;
    const double side = rng.Chance(0.5) ? 1.0 : -1.0;
    const double kind = rng.Uniform();
    double off = 0, lx = 0, ly = 0, h = 0;  // lateral offset from the centre line, sizes
    if (kind < 0.45) {
      o.kind = "car";
      o.material = Material::kCar;
      off = 0.5 * g.width - g.sidewalk - 1.3;
      lx = 4.4;
      ly = 1.8;
      h = 1.5;
      o.albedo = static_cast<float>(rng.Uniform(0.15, 0.9));
    } else if (kind < 0.8) {
      o.kind = "tree";
      o.material = Material::kFoliage;
      off = 0.5 * g.width - 0.5 * g.sidewalk;
      lx = ly = 0.4;
      h = rng.Uniform(2.5, 3.5);
      o.albedo = 0.35f;
    } else if (kind < 0.93) {
      o.kind = "lamp";
      o.material = Material::kMetal;
      off = 0.5 * g.width - 0.6;
      lx = ly = 0.25;
      h = 6.0;
      o.albedo = 0.45f;
    } else {
      o.kind = "kiosk";
      o.material = Material::kPlaster;
      off = 0.5 * g.width - 0.5 * g.sidewalk;
      lx = ly = 1.6;
      h = 2.6;
      o.albedo = static_cast<float>(rng.Uniform(0.4, 0.8));
    }
    if (!along_x) std::swap(lx, ly);
    const double cx = along_x ? along : line + side * off;
    const double cy = along_x ? line + side * off : along;
    o.boxes.push_back(MakeBox(cx - lx / 2, cy - ly / 2, cx + lx / 2, cy + ly / 2, h));
    if (o.kind == "tree") {
      // Trunk plus a crown of two stacked boxes, wider than the trunk.
      o.boxes.front().max.z() = h - 1.2;
      const double r = rng.Uniform(1.2, 1.8);
      o.boxes.push_back(MakeBox(cx - r, cy - r, cx + r, cy + r, h + 1.5));
      o.boxes.back().min.z() = h - 1.2;
      o.boxes.push_back(MakeBox(cx - 0.6 * r, cy - 0.6 * r, cx + 0.6 * r, cy + 0.6 * r, h + 2.5));
      o.boxes.back().min.z() = h + 1.5;
    }
    o.id = s->next_id++;
    s->objects.push_back(std::move(o));
  }
}

}  // namespace

Box Object::Bounds() const {
  Box b;
  if (boxes.empty()) return b;
  b = boxes.front();
  for (const Box& x : boxes) {
    b.min = b.min.cwiseMin(x.min);
    b.max = b.max.cwiseMax(x.max);
  }
  return b;
}

const Object* Scene::Find(int id) const {
  for (const Object& o : objects) {
    if (o.id == id) return &o;
  }
  return nullptr;
}

Lighting DarkLighting() {
  Lighting l;
  l.sun_dir = Eigen::Vector3d(-0.7, 0.62, 0.14).normalized();  // about 8 degrees high
  l.sun = 0.22;
  l.ambient = 0.07;
  return l;
}

Scene GenerateCity(const SimConfig& c, uint64_t seed) {
  Validate(c);
  Rng rng(HashCombine(seed, 0x5ce7e));
  Scene s;
  s.extent_x = c.extent_x;
  s.extent_y = c.extent_y;
  s.streets.width = c.street_width;
  s.streets.sidewalk = std::min(2.5, 0.2 * c.street_width);
  s.streets.xs = StreetLines(c.extent_x, c.block_size, c.street_width);
  s.streets.ys = StreetLines(c.extent_y, c.block_size, c.street_width);
  const double hw = 0.5 * c.street_width;
  // Blocks between streets, each split into 1..2 x 1..2 lots.
  for (size_t bi = 0; bi + 1 < s.streets.xs.size(); ++bi) {
    for (size_t bj = 0; bj + 1 < s.streets.ys.size(); ++bj) {
      const double x0 = s.streets.xs[bi] + hw, x1 = s.streets.xs[bi + 1] - hw;
      const double y0 = s.streets.ys[bj] + hw, y1 = s.streets.ys[bj + 1] - hw;
      const int nx = (x1 - x0) > 18.0 && rng.Chance(0.7) ? 2 : 1;
      const int ny = (y1 - y0) > 18.0 && rng.Chance(0.7) ? 2 : 1;
      for (int a = 0; a < nx; ++a) {
        for (int b = 0; b < ny; ++b) {
          const double lx0 = x0 + (x1 - x0) * a / nx, lx1 = x0 + (x1 - x0) * (a + 1) / nx;
          const double ly0 = y0 + (y1 - y0) * b / ny, ly1 = y0 + (y1 - y0) * (b + 1) / ny;
          if (rng.Chance(0.2)) {
            s.empty_lots.push_back(
                {MakeBox(lx0, ly0, lx1, ly1, 0.0), static_cast<int>(bi), static_cast<int>(bj)});
            continue;
          }
          Object o = MakeBuilding(rng, lx0, ly0, lx1, ly1, c);
          o.id = s.next_id++;
          s.objects.push_back(std::move(o));
        }
      }
    }
  }
  // Outskirts: the strips between the outer streets and the scene border get a row of
  // buildings too, so views across the city end at facades rather than an empty horizon.
  {
    const double ex = 0.5 * c.extent_x, ey = 0.5 * c.extent_y;
    const double gx0 = s.streets.xs.front() - hw, gx1 = s.streets.xs.back() + hw;
    const double gy0 = s.streets.ys.front() - hw, gy1 = s.streets.ys.back() + hw;
    const double lot_len = 0.5 * (c.block_size + c.street_width);
    SimConfig tall = c;  // a taller backdrop: upper half of the height range
    tall.min_height = 0.5 * (c.min_height + c.max_height);
    struct Strip {
      double x0, y0, x1, y1;
      bool along_y;
    };
    const Strip strips[4] = {{-ex, -ey, gx0, ey, true},
                             {gx1, -ey, ex, ey, true},
                             {gx0, -ey, gx1, gy0, false},
                             {gx0, gy1, gx1, ey, false}};
    for (const Strip& st : strips) {
      if ((st.along_y ? st.x1 - st.x0 : st.y1 - st.y0) < 6.0) continue;
      const double len = st.along_y ? st.y1 - st.y0 : st.x1 - st.x0;
      const int n = std::max(1, static_cast<int>(std::round(len / lot_len)));
      for (int k = 0; k < n; ++k) {
        const double a = k * len / n, b = (k + 1) * len / n;
        if (rng.Chance(0.15)) continue;
        Object o = st.along_y ? MakeBuilding(rng, st.x0, st.y0 + a, st.x1, st.y0 + b, tall)
                              : MakeBuilding(rng, st.x0 + a, st.y0, st.x0 + b, st.y1, tall);
        o.id = s.next_id++;
        s.objects.push_back(std::move(o));
      }
    }
  }
  // Changed scenes need two empty lots; free buildings (last generated first) if there are fewer.
  while (s.empty_lots.size() < 2) {
    auto it = std::find_if(s.objects.rbegin(), s.objects.rend(),
                           [](const Object& o) { return o.kind == "building"; });
    if (it == s.objects.rend() || s.objects.size() < 3) {
      throw Error(ErrorCode::kInvalidArgument, "scene too small for two changes: enlarge extent");
    }
    const Box b = it->Bounds();
    s.empty_lots.push_back(
        {MakeBox(b.min.x() - 1, b.min.y() - 1, b.max.x() + 1, b.max.y() + 1, 0), -1, -1});
    s.objects.erase(std::next(it).base());
  }
  AddSmallObjects(rng, c, &s);
  MD_LOG(kDebug,
         "city: " << s.objects.size() << " objects, " << s.empty_lots.size() << " empty lots");
  return s;
}

}  // namespace mapdelta::sim
