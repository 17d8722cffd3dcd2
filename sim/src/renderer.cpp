#include "mapdelta/sim/renderer.hpp"

#include <algorithm>
#include <cmath>

#include "mapdelta/sim/random.hpp"
#include "mapdelta/sim/texture.hpp"

namespace mapdelta::sim {
namespace {

constexpr float kEps = 2e-3f;  // offset of secondary ray origins from the surface (m)

// Display response x^(1/1.8) as a table with linear interpolation (powf per pixel was ~3% of
// the render time); the table error (< 1e-4) is far below one 8-bit step.
class Gamma {
 public:
  Gamma() {
    for (int i = 0; i <= kN; ++i) table_[i] = std::pow(static_cast<float>(i) / kN, 1.f / 1.8f);
  }
  float operator()(float x) const {
    const float f = std::min(1.f, std::max(0.f, x)) * kN;
    const int i = std::min(static_cast<int>(f), kN - 1);
    return table_[i] + (table_[i + 1] - table_[i]) * (f - static_cast<float>(i));
  }

 private:
  static constexpr int kN = 4096;
  float table_[kN + 1];
};

float Sky(const Lighting& l, const Eigen::Vector3f& dir) {
  // Bright near the horizon, darker towards the zenith; scaled with the sky light.
  const float up = std::max(0.f, dir.normalized().z());
  return static_cast<float>(l.ambient / 0.35) * (0.82f - 0.3f * up);
}

// Radiance along a ray (linear); writes the first hit's ray parameter to *t_first.
float Trace(const Scene& s, const RayCaster& caster, const RenderOptions& opt, float fx,
            Eigen::Vector3f o, Eigen::Vector3f d, float* t_first) {
  float weight = 1.f, travelled = 0.f;
  const Lighting& l = s.lighting;
  const Eigen::Vector3f sun = l.sun_dir.cast<float>();
  for (int bounce = 0;; ++bounce) {
    Hit hit;
    if (!caster.Intersect(o, d, 0.f, 1e5f, &hit)) {
      if (bounce == 0) *t_first = 0.f;
      return weight * Sky(l, d);
    }
    if (bounce == 0) *t_first = hit.t;
    const Eigen::Vector3f p = o + hit.t * d;
    const float dist = hit.t * d.norm();
    travelled += dist;
    const Eigen::Vector3f n = hit.normal;
    const bool mirror =
        hit.object >= 0 && s.objects[static_cast<size_t>(hit.object)].material == Material::kMirror;
    if (mirror && bounce < opt.max_bounces) {
      const Eigen::Vector3f dn = d / d.norm();
      weight *= 0.85f;
      d = dn - 2.f * dn.dot(n) * n;
      o = p + kEps * n;
      continue;
    }
    // Pixel footprint on the surface: the cone widens with the distance travelled and
    // stretches at grazing angles (clamped: the stretch is only along one axis).
    const float cosang = std::abs(n.dot(d)) / d.norm();
    const float footprint = travelled / fx / std::max(cosang, 0.2f);
    const float albedo = SurfaceAlbedo(s, hit, p, std::max(footprint, 1e-4f));
    float direct = 0.f;
    const float ndots = n.dot(sun);
    if (ndots > 0.f) {
      direct = ndots;
      if (opt.shadows && caster.Occluded(p + kEps * n, sun, 0.f, 1e4f)) direct = 0.f;
    }
    const float sky = static_cast<float>(l.ambient) * (0.7f + 0.3f * n.z());
    return weight * albedo * (static_cast<float>(l.sun) * direct + sky);
  }
}

}  // namespace

RenderedView RenderView(const Scene& s, const RayCaster& caster, const PinholeCamera& cam,
                        const SE3& T_map_cam, const RenderOptions& opt) {
  RenderedView out;
  RenderViewInto(s, caster, cam, T_map_cam, opt, &out);
  return out;
}

void RenderViewInto(const Scene& s, const RayCaster& caster, const PinholeCamera& cam,
                    const SE3& T_map_cam, const RenderOptions& opt, RenderedView* out_view,
                    const std::vector<Eigen::Vector3f>* rays) {
  RenderedView& out = *out_view;
  out.width = cam.width;
  out.height = cam.height;
  out.intensity.resize(static_cast<size_t>(cam.width) * cam.height);
  out.depth.resize(out.intensity.size());
  const Eigen::Matrix3f R = T_map_cam.linear().cast<float>();
  const Eigen::Vector3f o = T_map_cam.translation().cast<float>();
  const float exposure = static_cast<float>(s.lighting.exposure);
  static const Gamma gamma;
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const size_t i = static_cast<size_t>(v) * cam.width + u;
      // Unnormalized direction with z = 1 in the camera: the hit's ray parameter is its depth.
      const Eigen::Vector3f dc =
          rays ? (*rays)[i]
               : Eigen::Vector3f(static_cast<float>((u - cam.cx) / cam.fx),
                                 static_cast<float>((v - cam.cy) / cam.fy), 1.f);
      if (dc.z() == 0.f) {  // outside the lens model's valid field
        out.intensity[i] = 0.f;
        out.depth[i] = 0.f;
        continue;
      }
      float t = 0.f;
      const float radiance = Trace(s, caster, opt, static_cast<float>(cam.fx), o, R * dc, &t);
      // Display response: a gamma curve, so shadows keep texture.
      out.intensity[i] = gamma(exposure * radiance);
      out.depth[i] = t;
    }
  }
}

std::vector<uint8_t> ToGrey8(const RenderedView& view, double sigma, uint64_t noise_key) {
  std::vector<uint8_t> img;
  ToGrey8Into(view, sigma, noise_key, &img);
  return img;
}

void ToGrey8Into(const RenderedView& view, double sigma, uint64_t noise_key,
                 std::vector<uint8_t>* out) {
  // Quantize first, then add noise to the 8-bit value: the clean image is then a file
  // (a --noise none dataset) from which `mapdelta-sim renoise` makes the same noisy image.
  thread_local std::vector<uint8_t> clean;
  clean.resize(view.intensity.size());
  for (size_t i = 0; i < clean.size(); ++i) {
    clean[i] = static_cast<uint8_t>(
        std::lround(255.0 * std::clamp(static_cast<double>(view.intensity[i]), 0.0, 1.0)));
  }
  AddImageNoise(clean, sigma, noise_key, out);
}

void AddImageNoise(const std::vector<uint8_t>& clean, double sigma, uint64_t noise_key,
                   std::vector<uint8_t>* out) {
  std::vector<uint8_t>& img = *out;
  img.resize(clean.size());
  if (sigma <= 0) {
    std::copy(clean.begin(), clean.end(), img.begin());
    return;
  }
  const double sigma_levels = 255.0 * sigma;
  for (size_t i = 0; i < img.size(); ++i) {
    const double value = clean[i] + sigma_levels * HashGaussian(HashCombine(noise_key, i));
    img[i] = static_cast<uint8_t>(std::lround(std::clamp(value, 0.0, 255.0)));
  }
}

}  // namespace mapdelta::sim
