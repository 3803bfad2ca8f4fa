// Every functionality descriptor issue 11's components ship is valid.
#include <catch2/catch.hpp>

#include "peis/descriptor.h"

TEST_CASE("the descriptors of navigation, executor and the devices load", "[unit]") {
  const std::string root = PEIS_SOURCE_DIR "/components/";
  for (const char* file : {"navigation/navigation.yaml", "executor/executor.yaml",
                           "devices/talk/talk.yaml", "devices/photo/photo_camera.yaml",
                           "devices/vacuum/vacuum.yaml", "devices/sensors/sensors.yaml"}) {
    INFO(file);
    const auto descriptor = peis::Descriptor::fromFile(root + file);
    CHECK_FALSE(descriptor.functionalities.empty());
  }
}
