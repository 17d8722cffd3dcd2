#include "mapdelta/sim/preview.hpp"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>

#include "mapdelta/common/error.hpp"

namespace mapdelta::sim {
namespace {

void Write(const std::string& path, const cv::Mat& img) {
  bool ok = false;
  try {
    ok = cv::imwrite(path, img);
  } catch (const cv::Exception&) {
    ok = false;
  }
  if (!ok) throw Error(ErrorCode::kIo, path + ": could not write PNG");
}

}  // namespace

void WriteTopView(const std::string& path, const ChangedScene& cs, const Scene& original,
                  const std::vector<SequencePlan>& plans, double s) {
  const Scene& scene = cs.scene;
  const int w = static_cast<int>(scene.extent_x * s), h = static_cast<int>(scene.extent_y * s);
  auto px = [&](double x, double y) {
    return cv::Point(static_cast<int>((x + 0.5 * scene.extent_x) * s),
                     static_cast<int>((0.5 * scene.extent_y - y) * s));
  };
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(70, 120, 80));  // grass
  const StreetGrid& g = scene.streets;
  const double hw = 0.5 * g.width;
  for (double x : g.xs) {
    cv::rectangle(img, px(x - hw, g.ys.back() + hw), px(x + hw, g.ys.front() - hw),
                  cv::Scalar(150, 150, 150), cv::FILLED);
    cv::rectangle(img, px(x - hw + g.sidewalk, g.ys.back() + hw),
                  px(x + hw - g.sidewalk, g.ys.front() - hw), cv::Scalar(70, 70, 70), cv::FILLED);
  }
  for (double y : g.ys) {
    cv::rectangle(img, px(g.xs.front() - hw, y + hw), px(g.xs.back() + hw, y - hw),
                  cv::Scalar(150, 150, 150), cv::FILLED);
    cv::rectangle(img, px(g.xs.front() - hw, y + hw - g.sidewalk),
                  px(g.xs.back() + hw, y - hw + g.sidewalk), cv::Scalar(70, 70, 70), cv::FILLED);
  }
  // Draw lower boxes first so towers show on top.
  std::vector<std::pair<const Box*, const Object*>> boxes;
  for (const Object& o : scene.objects) {
    for (const Box& b : o.boxes) boxes.push_back({&b, &o});
  }
  std::stable_sort(boxes.begin(), boxes.end(), [](const auto& a, const auto& b) {
    return a.first->max.z() < b.first->max.z();
  });
  for (const auto& [b, o] : boxes) {
    const double shade = std::clamp(120.0 + 3.5 * b->max.z(), 0.0, 255.0);
    cv::Scalar colour(shade, shade, shade);
    if (o->kind == "tree") colour = cv::Scalar(40, 160, 40);
    if (o->kind == "car") colour = cv::Scalar(200, 120, 60);
    cv::rectangle(img, px(b->min.x(), b->max.y()), px(b->max.x(), b->min.y()), colour, cv::FILLED);
    cv::rectangle(img, px(b->min.x(), b->max.y()), px(b->max.x(), b->min.y()),
                  cv::Scalar(40, 40, 40), 1);
  }
  for (const Change& ch : cs.changes) {
    const Box b = ch.object.Bounds();
    const cv::Scalar colour = ch.type == "removed" ? cv::Scalar(0, 0, 255) : cv::Scalar(0, 200, 0);
    cv::rectangle(img, px(b.min.x(), b.max.y()), px(b.max.x(), b.min.y()), colour, 3);
    cv::putText(img, ch.type, px(b.min.x(), b.max.y() + 1.0), cv::FONT_HERSHEY_SIMPLEX, 0.45,
                colour, 1);
  }
  (void)original;
  const cv::Scalar colours[4] = {cv::Scalar(255, 80, 0), cv::Scalar(0, 200, 255),
                                 cv::Scalar(255, 0, 255), cv::Scalar(0, 255, 255)};
  for (size_t i = 0; i < plans.size(); ++i) {
    std::vector<cv::Point> line;
    for (double t = 0; t <= plans[i].duration_s; t += 0.2) {
      const Eigen::Vector3d p = plans[i].trajectory.Evaluate(t).p_map;
      line.push_back(px(p.x(), p.y()));
    }
    cv::polylines(img, line, false, colours[i % 4], 2, cv::LINE_AA);
    cv::circle(img, line.front(), 5, colours[i % 4], cv::FILLED);
    cv::putText(img, plans[i].name, cv::Point(8, 18 + 18 * static_cast<int>(i)),
                cv::FONT_HERSHEY_SIMPLEX, 0.55, colours[i % 4], 2);
  }
  Write(path, img);
}

void WriteDepthColour(const std::string& path, const RenderedView& view, double max_depth) {
  cv::Mat grey(view.height, view.width, CV_8UC1);
  cv::Mat sky(view.height, view.width, CV_8UC1);
  for (int v = 0; v < view.height; ++v) {
    for (int u = 0; u < view.width; ++u) {
      const float d = view.depth[static_cast<size_t>(v) * view.width + u];
      grey.at<uint8_t>(v, u) = static_cast<uint8_t>(255.0 * std::clamp(d / max_depth, 0.0, 1.0));
      sky.at<uint8_t>(v, u) = d <= 0.f ? 255 : 0;
    }
  }
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar(0, 0, 0), sky);
  Write(path, colour);
}

}  // namespace mapdelta::sim
