// Exit status of a stage (serviceMain): an entity DDS Security refuses is a
// configuration error (status 2, not restarted by the launcher), any other
// DDS failure an internal one (status 1).
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "config/errors.hpp"
#include "dds/dds.hpp"
#include "dds/service.hpp"

namespace sg::dds {
namespace {

int runStage(const std::function<void(const ServiceOptions&)>& body) {
  std::string name = "stereoguard-test";
  std::vector<char*> argv{name.data()};
  ServiceOptions options;
  return serviceMain(static_cast<int>(argv.size()), argv.data(), "test", nullptr, body, options);
}

TEST(DdsError, EntityRefusedByDdsSecurityNamesTheTopicAndTheMissingGrant) {
  try {
    checkEntity(DDS_RETCODE_NOT_ALLOWED_BY_SECURITY, "dds_create_writer", kStageMetricsTopic, "publishing");
    FAIL() << "no DdsError";
  } catch (const DdsError& e) {
    EXPECT_TRUE(e.notAllowedBySecurity());
    EXPECT_EQ(e.retcode(), DDS_RETCODE_NOT_ALLOWED_BY_SECURITY);
    EXPECT_EQ(std::string(e.what()),
              "dds_create_writer for topic 'stereoguard/stage_metrics' failed: Not Allowed By Security (the "
              "permissions of this DDS Security identity do not grant publishing it)");
  }
  try {
    checkEntity(DDS_RETCODE_BAD_PARAMETER, "dds_create_reader", kStageMetricsTopic, "subscribing to");
    FAIL() << "no DdsError";
  } catch (const DdsError& e) {
    EXPECT_FALSE(e.notAllowedBySecurity());
    EXPECT_EQ(e.retcode(), DDS_RETCODE_BAD_PARAMETER);
    EXPECT_EQ(std::string(e.what()), "dds_create_reader for topic 'stereoguard/stage_metrics' failed: Bad Parameter");
  }
  EXPECT_EQ(checkEntity(5, "dds_create_reader", kStageMetricsTopic, "subscribing to"), 5);
}

TEST(ServiceStatus, RefusedByDdsSecurityIsAConfigurationErrorOtherDdsFailuresAreInternal) {
  EXPECT_EQ(runStage([](const ServiceOptions&) {}), 0);
  EXPECT_EQ(runStage([](const ServiceOptions&) {
              checkEntity(DDS_RETCODE_NOT_ALLOWED_BY_SECURITY, "dds_create_writer", kStageMetricsTopic,
                          "publishing");
            }),
            2);
  EXPECT_EQ(runStage([](const ServiceOptions&) { check(DDS_RETCODE_OUT_OF_RESOURCES, "dds_write"); }), 1);
  EXPECT_EQ(runStage([](const ServiceOptions&) { throw InputError("bad.yaml: unknown key 'x'"); }), 2);
}

}  // namespace
}  // namespace sg::dds
