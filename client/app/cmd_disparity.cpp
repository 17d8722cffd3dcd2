// mapdelta-client disparity / config: one stereo pair with the production settings.
#include <cstdio>
#include <string>

#include "args.hpp"
#include "commands.hpp"
#include "mapdelta/client/config.hpp"
#include "mapdelta/client/image.hpp"
#include "mapdelta/client/stereo_depth.hpp"

namespace mapdelta::client::app {

int RunDisparity(int argc, char** argv) {
  const char* usage =
      "usage: mapdelta-client disparity LEFT RIGHT OUT [--num-disparities N] [--config FILE]\n"
      "  LEFT/RIGHT: rectified 8-bit images (colour is converted to grey)\n"
      "  OUT: .pfm (float, NaN = invalid) or .tif/.tiff (float, 0 = invalid), pixels\n"
      "  --num-disparities N: search range for THIS image (default: the config's value\n"
      "                       scaled from its reference width, multiple of 16)\n";
  Args args;
  try {
    args = ParseArgs(argc, argv, {"num-disparities", "config"});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n%s", e.what(), usage);
    return 2;
  }
  if (args.help) {
    std::fprintf(stderr, "%s", usage);
    return 0;
  }
  if (args.positional.size() != 3) {
    std::fprintf(stderr, "expected LEFT RIGHT OUT\n%s", usage);
    return 2;
  }
  ClientConfig config = args.Has("config") ? LoadClientConfig(args.Get("config")) : ClientConfig{};
  const GrayImage left = ReadGrayImage(args.positional[0]);
  const GrayImage right = ReadGrayImage(args.positional[1]);
  if (args.Has("num-disparities")) {
    int n = 0;
    try {
      n = std::stoi(args.Get("num-disparities"));
    } catch (const std::exception&) {
      n = 0;
    }
    if (n < 16 || n % 16 != 0) {
      std::fprintf(stderr, "--num-disparities must be a positive multiple of 16\n");
      return 2;
    }
    config.stereo.num_disparities = n;
    config.stereo.reference_width = left.width;  // the given range applies to this image as is
  }
  const StereoDepth stereo(config.stereo);
  std::fprintf(stderr, "disparity: %dx%d, %d disparities\n", left.width, left.height,
               stereo.NumDisparitiesFor(left.width));
  const DisparityImage disparity = stereo.ComputeDisparity(left, right);
  WriteDisparity(args.positional[2], disparity);
  size_t valid = 0;
  for (float d : disparity.disparity_px) valid += d > 0.f ? 1 : 0;
  std::fprintf(stderr, "wrote %s (%.1f%% valid)\n", args.positional[2].c_str(),
               100.0 * valid / std::max<size_t>(1, disparity.disparity_px.size()));
  return 0;
}

int RunConfig(int argc, char** argv) {
  Args args;
  try {
    args = ParseArgs(argc, argv, {"config"});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\nusage: mapdelta-client config [--config FILE]\n", e.what());
    return 2;
  }
  if (args.help) {
    std::fprintf(stderr, "usage: mapdelta-client config [--config FILE]\n"
                         "  prints the effective configuration (defaults + FILE) as YAML\n");
    return 0;
  }
  const ClientConfig config =
      args.Has("config") ? LoadClientConfig(args.Get("config")) : ClientConfig{};
  std::printf("%s", ToYaml(config).c_str());
  return 0;
}

}  // namespace mapdelta::client::app
