// Embree 3 backend: every box becomes 12 triangles of one static triangle mesh; the ground is a
// second mesh of two triangles. A per-primitive table maps Embree's primID back to the box.
#include <embree3/rtcore.h>

#include <limits>
#include <vector>

#include "mapdelta/common/error.hpp"
#include "mapdelta/sim/raycaster.hpp"

namespace mapdelta::sim {

struct EmbreeCaster::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  unsigned box_geom = RTC_INVALID_GEOMETRY_ID;
  struct Prim {
    int object, box;
    Eigen::Vector3f normal;
  };
  std::vector<Prim> prims;

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

namespace {

// Box corners indexed by bits (x, y, z); faces as two triangles each, counter-clockwise seen
// from outside, with their outward normals.
struct FaceDef {
  int a, b, c, d;
  float nx, ny, nz;
};
constexpr FaceDef kFaces[6] = {{0, 4, 6, 2, -1, 0, 0}, {1, 3, 7, 5, 1, 0, 0},
                               {0, 1, 5, 4, 0, -1, 0}, {2, 6, 7, 3, 0, 1, 0},
                               {0, 2, 3, 1, 0, 0, -1}, {4, 5, 7, 6, 0, 0, 1}};

void Check(RTCDevice device, const char* what) {
  const RTCError e = rtcGetDeviceError(device);
  if (e != RTC_ERROR_NONE) {
    throw Error(ErrorCode::kInternal, std::string("embree: ") + what + " failed (code " +
                                          std::to_string(static_cast<int>(e)) + ")");
  }
}

}  // namespace

EmbreeCaster::EmbreeCaster(const Scene& s) : impl_(std::make_unique<Impl>()) {
  // One build thread: the BVH (and so tie-breaking between equal hits) is then identical on
  // every run, which byte-identical output relies on. Building takes milliseconds anyway.
  impl_->device = rtcNewDevice("threads=1,set_affinity=0");
  if (!impl_->device) throw Error(ErrorCode::kInternal, "embree: rtcNewDevice failed");
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);

  std::vector<float> vertices;
  std::vector<unsigned> indices;
  for (size_t oi = 0; oi < s.objects.size(); ++oi) {
    const auto& boxes = s.objects[oi].boxes;
    for (size_t bi = 0; bi < boxes.size(); ++bi) {
      const unsigned base = static_cast<unsigned>(vertices.size() / 3);
      for (int k = 0; k < 8; ++k) {
        vertices.push_back(static_cast<float>((k & 1) ? boxes[bi].max.x() : boxes[bi].min.x()));
        vertices.push_back(static_cast<float>((k & 2) ? boxes[bi].max.y() : boxes[bi].min.y()));
        vertices.push_back(static_cast<float>((k & 4) ? boxes[bi].max.z() : boxes[bi].min.z()));
      }
      for (const FaceDef& f : kFaces) {
        const unsigned tri[6] = {base + f.a, base + f.b, base + f.c,
                                 base + f.a, base + f.c, base + f.d};
        indices.insert(indices.end(), tri, tri + 6);
        for (int t = 0; t < 2; ++t) {
          impl_->prims.push_back({static_cast<int>(oi), static_cast<int>(bi), {f.nx, f.ny, f.nz}});
        }
      }
    }
  }
  if (!indices.empty()) {
    RTCGeometry g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), vertices.size() / 3));
    auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), indices.size() / 3));
    Check(impl_->device, "allocating box buffers");
    std::copy(vertices.begin(), vertices.end(), vb);
    std::copy(indices.begin(), indices.end(), ib);
    rtcCommitGeometry(g);
    impl_->box_geom = rtcAttachGeometry(impl_->scene, g);
    rtcReleaseGeometry(g);
  }
  {
    const float x0 = static_cast<float>(-0.5 * s.extent_x - kGroundMargin);
    const float x1 = static_cast<float>(0.5 * s.extent_x + kGroundMargin);
    const float y0 = static_cast<float>(-0.5 * s.extent_y - kGroundMargin);
    const float y1 = static_cast<float>(0.5 * s.extent_y + kGroundMargin);
    RTCGeometry g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 4));
    auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), 2));
    Check(impl_->device, "allocating ground buffers");
    const float v[12] = {x0, y0, 0, x1, y0, 0, x1, y1, 0, x0, y1, 0};
    const unsigned i[6] = {0, 1, 2, 0, 2, 3};
    std::copy(v, v + 12, vb);
    std::copy(i, i + 6, ib);
    rtcCommitGeometry(g);
    rtcAttachGeometry(impl_->scene, g);
    rtcReleaseGeometry(g);
  }
  rtcCommitScene(impl_->scene);
  Check(impl_->device, "building the BVH");
}

EmbreeCaster::~EmbreeCaster() = default;

bool EmbreeCaster::Intersect(const Eigen::Vector3f& o, const Eigen::Vector3f& d, float tnear,
                             float tfar, Hit* hit) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh{};
  rh.ray.org_x = o.x();
  rh.ray.org_y = o.y();
  rh.ray.org_z = o.z();
  rh.ray.dir_x = d.x();
  rh.ray.dir_y = d.y();
  rh.ray.dir_z = d.z();
  rh.ray.tnear = tnear;
  rh.ray.tfar = tfar;
  rh.ray.mask = 0xffffffffu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
  hit->t = rh.ray.tfar;
  if (rh.hit.geomID == impl_->box_geom) {
    const Impl::Prim& p = impl_->prims[rh.hit.primID];
    hit->object = p.object;
    hit->box = p.box;
    hit->normal = p.normal;
  } else {
    hit->object = -1;
    hit->box = -1;
    hit->normal = Eigen::Vector3f::UnitZ();
  }
  return true;
}

bool EmbreeCaster::Occluded(const Eigen::Vector3f& o, const Eigen::Vector3f& d, float tnear,
                            float tfar) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay ray{};
  ray.org_x = o.x();
  ray.org_y = o.y();
  ray.org_z = o.z();
  ray.dir_x = d.x();
  ray.dir_y = d.y();
  ray.dir_z = d.z();
  ray.tnear = tnear;
  ray.tfar = tfar;
  ray.mask = 0xffffffffu;
  rtcOccluded1(impl_->scene, &ctx, &ray);
  return ray.tfar < 0.f;  // Embree sets tfar = -inf on a hit
}

}  // namespace mapdelta::sim
