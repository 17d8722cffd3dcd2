// Client configuration: defaults from docs/design.md, every problem reported at once, round trip.
#include <gtest/gtest.h>

#include "mapdelta/client/config.hpp"
#include "mapdelta/common/error.hpp"

namespace mapdelta::client {
namespace {

TEST(ClientConfig, DefaultsFollowThePaper) {
  const ClientConfig c;
  EXPECT_EQ(c.stereo.num_disparities, 128);
  EXPECT_EQ(c.stereo.reference_width, 800);
  EXPECT_DOUBLE_EQ(c.temporal_filter.delta_d_m, 0.5);
  EXPECT_EQ(c.temporal_filter.alpha, 3);  // the paper's 4 is a config value (client/README.md)
  EXPECT_EQ(c.local_cloud.keyframes, 5);
  EXPECT_DOUBLE_EQ(c.local_cloud.voxel_m, 0.4);
  EXPECT_DOUBLE_EQ(c.local_cloud.max_depth_m, 50.0);
  EXPECT_DOUBLE_EQ(c.registration.max_fitness_m, 1.0);
  EXPECT_DOUBLE_EQ(c.registration.max_correction_m, 4.0);
}

TEST(ClientConfig, ReportsAllProblemsAtOnce) {
  const std::string text =
      "stereo:\n  block_size: 4\n  colour: red\n"
      "temporal_filter:\n  alpha: many\n  delta_d_m: -1\n"
      "nonsense:\n  a: 1\n";
  try {
    ParseClientConfig(text, "test.yaml");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);  // a config error: exit code 2
    EXPECT_NE(m.find("test.yaml: 5 problem(s)"), std::string::npos) << m;
    EXPECT_NE(m.find("stereo.colour: unknown key"), std::string::npos) << m;
    EXPECT_NE(m.find("temporal_filter.alpha: expected an integer, got 'many'"), std::string::npos)
        << m;
    EXPECT_NE(m.find("temporal_filter.delta_d_m: -1 is outside [1e-06, 1000000]"),
              std::string::npos)
        << m;
    EXPECT_NE(m.find("nonsense: unknown section"), std::string::npos) << m;
    EXPECT_NE(m.find("stereo.block_size: must be odd"), std::string::npos) << m;
  }
  EXPECT_THROW(LoadClientConfig("/nonexistent/client.yaml"), Error);
  EXPECT_THROW(ParseClientConfig("[1, 2]", "list.yaml"), Error);
}

TEST(ClientConfig, GrowingLocalCloudNeedsRoomToGrow) {
  EXPECT_NO_THROW(ParseClientConfig("local_cloud:\n  keyframes: 8\n", "x"));
  try {
    ParseClientConfig("local_cloud:\n  min_points: 500\n  max_keyframes: 3\n", "grow.yaml");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(
        std::string(e.what()).find("local_cloud.max_keyframes: must be >= "
                                   "local_cloud.keyframes when local_cloud.min_points is set"),
        std::string::npos)
        << e.what();
  }
}

TEST(ClientConfig, EffectiveConfigRoundTrips) {
  ClientConfig c =
      ParseClientConfig("fusion:\n  huber_delta: 3.5\nupload:\n  vehicle_id: car-7\n", "x");
  EXPECT_DOUBLE_EQ(c.fusion.huber_delta, 3.5);
  EXPECT_EQ(c.upload.vehicle_id, "car-7");
  const ClientConfig back = ParseClientConfig(ToYaml(c), "echo");
  EXPECT_EQ(ToYaml(back), ToYaml(c));
  EXPECT_NO_THROW(ParseClientConfig("", "empty"));
}

}  // namespace
}  // namespace mapdelta::client
