// mapdelta-client disparity / config: one stereo pair with the production settings.
#include <cstdio>
#include <iostream>
#include <string>

#include "commands.hpp"
#include "mapdelta/client/config.hpp"
#include "mapdelta/client/image.hpp"
#include "mapdelta/client/stereo_depth.hpp"
#include "mapdelta/common/cli.hpp"

namespace mapdelta::client::app {

int RunDisparity(int argc, char** argv) {
  std::string left_path, right_path, out_path, config_path;
  int num_disparities = 0;
  cli::Parser cli("mapdelta-client disparity",
                  "One stereo pair's SGBM disparity with the production settings.");
  cli.Positional("LEFT", &left_path, "rectified 8-bit image (colour is converted to grey)")
      .Positional("RIGHT", &right_path, "rectified 8-bit image")
      .Positional("OUT", &out_path,
                  ".pfm (float, NaN = invalid) or .tif/.tiff (float, 0 = invalid), pixels")
      .Option("num-disparities", &num_disparities,
              "search range for THIS image, a positive multiple of 16 (default: the config's value "
              "scaled "
              "from its reference width)")
      .Option("config", &config_path, "client configuration (YAML)", "FILE")
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(argc, argv, std::cout)) return cli::kExitOk;
  if (cli.Given("num-disparities") && (num_disparities < 16 || num_disparities % 16 != 0)) {
    cli::FailUsage(cli.program(), "--num-disparities: expected a positive multiple of 16, got " +
                                      std::to_string(num_disparities));
  }
  ClientConfig config = config_path.empty() ? ClientConfig{} : LoadClientConfig(config_path);
  const GrayImage left = ReadGrayImage(left_path);
  const GrayImage right = ReadGrayImage(right_path);
  if (cli.Given("num-disparities")) {
    config.stereo.num_disparities = num_disparities;
    config.stereo.reference_width = left.width;  // the given range applies to this image as is
  }
  const StereoDepth stereo(config.stereo);
  std::fprintf(stderr, "disparity: %dx%d, %d disparities\n", left.width, left.height,
               stereo.NumDisparitiesFor(left.width));
  const DisparityImage disparity = stereo.ComputeDisparity(left, right);
  WriteDisparity(out_path, disparity);
  size_t valid = 0;
  for (float d : disparity.disparity_px) valid += d > 0.f ? 1 : 0;
  std::fprintf(stderr, "wrote %s (%.1f%% valid)\n", out_path.c_str(),
               100.0 * valid / std::max<size_t>(1, disparity.disparity_px.size()));
  return 0;
}

int RunConfig(int argc, char** argv) {
  std::string config_path;
  cli::Parser cli("mapdelta-client config",
                  "Prints the effective configuration (defaults + FILE) as YAML.");
  cli.Option("config", &config_path, "client configuration (YAML)", "FILE")
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(argc, argv, std::cout)) return cli::kExitOk;
  const ClientConfig config = config_path.empty() ? ClientConfig{} : LoadClientConfig(config_path);
  std::printf("%s", ToYaml(config).c_str());
  return 0;
}

}  // namespace mapdelta::client::app
