// ROS 1 bags (`mm4mm import --bag`): the input is the bag, read as import reads one: its topics,
// a magnetometer topic with its pose from /tf_static, and the odometry with its clouds and an IMU.
// rosbag_storage (Debian's) parses it; whatever it finds wrong must come out as bad input naming
// the bag, never as a crash or another exception.
#include <optional>
#include <string>

#include "fuzz_input.hpp"
#include "mm4mm/import/ros_bag.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path bag = mm4mm::fuzz::scratchDirectory() / "run.bag";
  mm4mm::fuzz::writeInput(bag, data, size);
  using mm4mm::fuzz::expectReadOrRefusal;
  expectReadOrRefusal([&] { mm4mm::bagTopics(bag); });
  expectReadOrRefusal(
      [&] { mm4mm::readBagMagnetometer(bag, {"/imu/mag"}, std::string("base_link")); });
  mm4mm::BagLidarOptions options;
  options.odometry_topic = "/odom";
  options.cloud_topic = "/points";
  options.imu_topic = "/imu";
  options.spacing = {0.1, 5.0};
  expectReadOrRefusal([&] { mm4mm::readBagLidar(bag, options); });
  return 0;
}
