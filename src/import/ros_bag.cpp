#include "mm4mm/import/ros_bag.hpp"

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/exception.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <new>

#include "import_text.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/core/trajectory.hpp"
#include "mm4mm/io/input_error.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;

constexpr double kMicroTeslaPerTesla = 1e6;

std::unique_ptr<rosbag::Bag> openBag(const fs::path& file) {
  if (!fs::is_regular_file(file)) throw InputError(file.string(), 0, "file not found");
  auto bag = std::make_unique<rosbag::Bag>();
  bag->open(file.string(), rosbag::bagmode::Read);
  return bag;
}

// rosbag_storage and roscpp's deserialisation throw ros::Exception on a bag they cannot parse
// (a record or a message running past its end, a record of no known kind), and std::bad_alloc
// where a corrupt length asks for more memory than there is: both allocate what a length field
// claims before reading that far (fuzz_rosbag's first minute: a 42 kB bag whose record header
// claimed 2.3 GB). Either is the bag's fault, so it is bad input naming the bag.
template <typename Read>
auto refusingBrokenBags(const fs::path& file, Read&& read) {
  try {
    return read();
  } catch (const ros::Exception& e) {
    throw InputError(file.string(), 0, std::string("not a readable ROS 1 bag: ") + e.what());
  } catch (const std::bad_alloc&) {
    throw InputError(file.string(), 0,
                     "not a readable ROS 1 bag: a length in it asks for more memory than there "
                     "is (corrupt or truncated?)");
  }
}

std::string topicList(const fs::path& file) {
  std::string list;
  for (const auto& [topic, type] : bagTopics(file))
    list += (list.empty() ? "" : ", ") + topic + " (" + type + ")";
  return list.empty() ? "none" : list;
}

// The messages of `topic`, which must be of type `type`.
void requireTopic(const rosbag::Bag& bag, const fs::path& file, const std::string& topic,
                  const std::string& type) {
  rosbag::View view(bag, rosbag::TopicQuery(topic));
  const auto connections = view.getConnections();
  if (connections.empty())
    throw InputError(file.string(), 0,
                     "has no topic '" + topic + "'; its topics: " + topicList(file));
  for (const auto* connection : connections)
    if (connection->datatype != type)
      throw InputError(file.string(), 0,
                       "topic '" + topic + "' is " + connection->datatype + ", not " + type);
}

Eigen::Isometry3d toIsometry(const geometry_msgs::Transform& t) {
  return import_detail::poseFromTq(
      Eigen::Vector3d(t.translation.x, t.translation.y, t.translation.z),
      Eigen::Vector4d(t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w));
}

// /tf_static as a tree: each child frame with its parent and T_parent_child.
struct StaticTree {
  std::map<std::string, std::pair<std::string, Eigen::Isometry3d>> parent_of;

  // T_root_frame and the root's name.
  std::pair<std::string, Eigen::Isometry3d> fromRoot(std::string frame) const {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    for (int depth = 0; depth < 64; ++depth) {
      const auto it = parent_of.find(frame);
      if (it == parent_of.end()) break;
      T = it->second.second * T;
      frame = it->second.first;
    }
    return {frame, T};
  }

  std::optional<Eigen::Isometry3d> lookup(const std::string& target,
                                          const std::string& source) const {
    if (target == source) return Eigen::Isometry3d::Identity();
    const auto [target_root, T_root_target] = fromRoot(target);
    const auto [source_root, T_root_source] = fromRoot(source);
    if (target_root != source_root) return std::nullopt;
    return T_root_target.inverse() * T_root_source;
  }
};

std::string stripSlash(const std::string& frame) {
  return !frame.empty() && frame.front() == '/' ? frame.substr(1) : frame;
}

StaticTree readStaticTree(const rosbag::Bag& bag) {
  StaticTree tree;
  rosbag::View view(bag, rosbag::TopicQuery("/tf_static"));
  for (const rosbag::MessageInstance& message : view) {
    const auto tf = message.instantiate<tf2_msgs::TFMessage>();
    if (!tf) continue;
    for (const geometry_msgs::TransformStamped& t : tf->transforms)
      tree.parent_of[stripSlash(t.child_frame_id)] = {stripSlash(t.header.frame_id),
                                                      toIsometry(t.transform)};
  }
  return tree;
}

PointCloud cloudPoints(const sensor_msgs::PointCloud2& cloud, const fs::path& file,
                       const std::string& topic) {
  for (const char* name : {"x", "y", "z"}) {
    const auto it = std::find_if(cloud.fields.begin(), cloud.fields.end(),
                                 [&](const auto& f) { return f.name == name; });
    if (it == cloud.fields.end() || it->datatype != sensor_msgs::PointField::FLOAT32)
      throw InputError(
          file.string(), 0,
          "topic '" + topic + "': a cloud's field " + name + " is missing or not float32");
  }
  if (cloud.is_bigendian)
    throw InputError(file.string(), 0, "topic '" + topic + "': big-endian clouds are not read");
  PointCloud points;
  points.reserve(static_cast<std::size_t>(cloud.width) * cloud.height);
  sensor_msgs::PointCloud2ConstIterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  for (; x != x.end(); ++x, ++y, ++z) {
    const Eigen::Vector3f p(*x, *y, *z);
    if (p.allFinite() && p.cwiseAbs().maxCoeff() < 1e6f) points.push_back(p);
  }
  return points;
}

// The poses of `topic` in stamp order, one per message that `to_pose` converts (a StampedPose)
// and whose frame `frame_of` names (the last one goes to `frame`). A repeated stamp, the same pose
// published twice, is skipped; a stamp going backwards, a non-finite pose or fewer than two poses
// are refused, naming the topic.
template <typename Message, typename ToPose, typename FrameOf>
std::vector<StampedPose> readPoseTopic(const rosbag::Bag& bag, const fs::path& file,
                                       const std::string& topic, const std::string& what,
                                       ToPose to_pose, FrameOf frame_of, std::string* frame) {
  std::vector<StampedPose> poses;
  rosbag::View view(bag, rosbag::TopicQuery(topic));
  for (const rosbag::MessageInstance& message : view) {
    const auto msg = message.template instantiate<Message>();
    if (!msg) continue;
    const StampedPose pose = to_pose(*msg);
    if (!pose.T_frame_body.matrix().allFinite())
      throw InputError(file.string(), 0, "topic '" + topic + "': a non-finite " + what);
    if (!poses.empty() && pose.time_s <= poses.back().time_s) {
      if (pose.time_s < poses.back().time_s)
        throw InputError(file.string(), 0,
                         "topic '" + topic + "': header stamps go backwards at " +
                             std::to_string(pose.time_s) + " s");
      continue;
    }
    *frame = stripSlash(frame_of(*msg));
    poses.push_back(pose);
  }
  if (poses.size() < 2)
    throw InputError(file.string(), 0, "topic '" + topic + "' holds fewer than two " + what + "s");
  return poses;
}

// Odometry that knows only heading (wheel odometry, a planar SLAM) takes its roll and pitch from
// the IMU's orientation, whose own heading (integrated gyro, or north) is not used: the tilt of
// R_world_imu R_imu_body under the odometry's yaw.
void levelByImu(const rosbag::Bag& bag, const fs::path& file, const std::string& topic,
                const StaticTree& tree, const std::string& body_frame, LidarRecording* recording) {
  requireTopic(bag, file, topic, "sensor_msgs/Imu");
  std::string imu_frame;
  const std::vector<StampedPose> attitude = readPoseTopic<sensor_msgs::Imu>(
      bag, file, topic, "orientation",
      [&](const sensor_msgs::Imu& imu) {
        // REP 145: a covariance of -1 in the first entry means the orientation is not estimated.
        if (imu.orientation_covariance[0] < 0.0)
          throw InputError(file.string(), 0,
                           "topic '" + topic + "' carries no orientation (covariance -1, REP 145)");
        const auto& q = imu.orientation;
        return StampedPose{imu.header.stamp.toSec(),
                           import_detail::poseFromTq(Eigen::Vector3d::Zero(),
                                                     Eigen::Vector4d(q.x, q.y, q.z, q.w))};
      },
      [](const sensor_msgs::Imu& imu) { return imu.header.frame_id; }, &imu_frame);
  const std::optional<Eigen::Isometry3d> T_body_imu = tree.lookup(body_frame, imu_frame);
  if (!T_body_imu)
    throw InputError(file.string(), 0,
                     "/tf_static does not link the odometry's frame '" + body_frame +
                         "' to the IMU's '" + imu_frame + "'");
  std::vector<StampedPose> levelled;
  for (StampedPose pose : recording->odometry) {
    const std::optional<Eigen::Isometry3d> R_world_imu = poseWithin(attitude, pose.time_s);
    if (!R_world_imu) continue;
    const Eigen::Matrix3d R_world_body = R_world_imu->linear() * T_body_imu->linear().transpose();
    pose.T_frame_body.linear() =
        rotationZ(yawOf(pose.T_frame_body.linear())) * tiltOf(R_world_body);
    levelled.push_back(pose);
  }
  if (levelled.size() < 2)
    throw InputError(file.string(), 0,
                     "topic '" + topic + "' does not overlap the odometry's time span");
  const std::size_t dropped = recording->odometry.size() - levelled.size();
  recording->odometry = std::move(levelled);
  recording->notes.push_back(
      "roll and pitch from " + topic + " (heading from the odometry)" +
      (dropped ? "; " + std::to_string(dropped) + " odometry pose(s) outside its span left out"
               : std::string()));
}

std::vector<std::pair<std::string, std::string>> bagTopicsOf(const fs::path& file) {
  const auto bag = openBag(file);
  rosbag::View view(*bag);
  std::map<std::string, std::string> topics;
  for (const auto* connection : view.getConnections())
    topics[connection->topic] = connection->datatype;
  return {topics.begin(), topics.end()};
}

MagnetometerRecording magnetometerOf(const fs::path& file, const std::vector<std::string>& topics,
                                     const std::optional<std::string>& body_frame) {
  const auto bag = openBag(file);
  if (topics.empty()) throw std::invalid_argument("no magnetometer topic given");
  MagnetometerRecording recording;
  recording.source = file.string() + " topic " + topics.front();
  for (std::size_t i = 1; i < topics.size(); ++i) recording.source += ", " + topics[i];
  recording.read_as = FieldUnit::kTesla;
  std::vector<std::string> frames(topics.size());
  for (std::size_t sensor = 0; sensor < topics.size(); ++sensor) {
    const std::string& topic = topics[sensor];
    requireTopic(*bag, file, topic, "sensor_msgs/MagneticField");
    rosbag::View view(*bag, rosbag::TopicQuery(topic));
    double previous = -1e300;
    for (const rosbag::MessageInstance& message : view) {
      const auto field = message.instantiate<sensor_msgs::MagneticField>();
      if (!field) continue;
      MagnetometerSample sample;
      sample.sensor = static_cast<int>(sensor);
      sample.time_s = field->header.stamp.toSec();
      sample.field_body_uT =
          kMicroTeslaPerTesla * Eigen::Vector3d(field->magnetic_field.x, field->magnetic_field.y,
                                                field->magnetic_field.z);
      if (!sample.field_body_uT.allFinite())
        throw InputError(
            file.string(), 0,
            "topic '" + topic + "': a non-finite field at " + std::to_string(sample.time_s) + " s");
      if (sample.time_s < previous)
        throw InputError(file.string(), 0,
                         "topic '" + topic + "': header stamps go backwards at " +
                             std::to_string(sample.time_s) + " s");
      previous = sample.time_s;
      frames[sensor] = stripSlash(field->header.frame_id);
      recording.samples.push_back(sample);
    }
  }
  std::stable_sort(recording.samples.begin(), recording.samples.end(),
                   [](const auto& a, const auto& b) { return a.time_s < b.time_s; });
  recording.frame = frames.front();
  for (std::size_t i = 1; i < frames.size(); ++i) recording.frame += ", " + frames[i];
  if (body_frame) {
    const StaticTree tree = readStaticTree(*bag);
    for (std::size_t sensor = 0; sensor < topics.size(); ++sensor) {
      const std::optional<Eigen::Isometry3d> T =
          tree.lookup(stripSlash(*body_frame), frames[sensor]);
      if (!T)
        throw InputError(file.string(), 0,
                         "/tf_static does not link frame '" + *body_frame + "' to '" +
                             frames[sensor] + "' of topic '" + topics[sensor] +
                             "' (give the extrinsics instead)");
      recording.T_body_magnetometers.push_back(*T);
    }
  }
  return recording;
}

LidarRecording lidarOf(const fs::path& file, const BagLidarOptions& options) {
  const auto bag = openBag(file);
  requireTopic(*bag, file, options.odometry_topic, "nav_msgs/Odometry");
  LidarRecording recording;
  recording.source = file.string() + " topic " + options.odometry_topic;
  std::string body_frame;
  recording.odometry = readPoseTopic<nav_msgs::Odometry>(
      *bag, file, options.odometry_topic, "pose",
      [](const nav_msgs::Odometry& odometry) {
        const auto& p = odometry.pose.pose;
        return StampedPose{
            odometry.header.stamp.toSec(),
            import_detail::poseFromTq(Eigen::Vector3d(p.position.x, p.position.y, p.position.z),
                                      Eigen::Vector4d(p.orientation.x, p.orientation.y,
                                                      p.orientation.z, p.orientation.w))};
      },
      [](const nav_msgs::Odometry& odometry) { return odometry.child_frame_id; }, &body_frame);
  recording.body_frame = "the odometry's child frame '" + body_frame + "'";
  const StaticTree tree = readStaticTree(*bag);
  if (!options.imu_topic.empty())
    levelByImu(*bag, file, options.imu_topic, tree, body_frame, &recording);
  if (options.cloud_topic.empty()) {
    recording.scans_saved = false;
    for (std::size_t i : selectKeyframes(recording.odometry, options.spacing))
      recording.keyframes.push_back({recording.odometry[i], {}});
    recording.notes.push_back("no cloud topic: a magnetic-only session");
    return recording;
  }
  requireTopic(*bag, file, options.cloud_topic, "sensor_msgs/PointCloud2");
  rosbag::View view(*bag, rosbag::TopicQuery(options.cloud_topic));
  std::size_t outside = 0;
  for (const rosbag::MessageInstance& message : view) {
    const auto cloud = message.instantiate<sensor_msgs::PointCloud2>();
    if (!cloud) continue;
    const double t = cloud->header.stamp.toSec();
    const std::optional<Eigen::Isometry3d> pose = poseWithin(recording.odometry, t);
    if (!pose) {
      ++outside;
      continue;
    }
    if (!recording.keyframes.empty()) {
      if (t <= recording.keyframes.back().pose.time_s) continue;
      if (!movedEnough(recording.keyframes.back().pose.T_frame_body, *pose, options.spacing))
        continue;
    }
    std::optional<Eigen::Isometry3d> T_body_lidar = options.T_body_lidar;
    if (!T_body_lidar) T_body_lidar = tree.lookup(body_frame, stripSlash(cloud->header.frame_id));
    if (!T_body_lidar)
      throw InputError(file.string(), 0,
                       "/tf_static does not link the odometry's frame '" + body_frame +
                           "' to the clouds' '" + cloud->header.frame_id +
                           "' (give T_body_lidar in the extrinsics)");
    ImportedKeyframe keyframe;
    keyframe.pose = {t, *pose};
    keyframe.scan_body =
        import_detail::transformed(cloudPoints(*cloud, file, options.cloud_topic), *T_body_lidar);
    if (keyframe.scan_body.empty()) continue;  // a cloud with no return (open space)
    recording.keyframes.push_back(std::move(keyframe));
  }
  if (recording.keyframes.empty())
    throw InputError(
        file.string(), 0,
        "topic '" + options.cloud_topic + "' has no cloud within the odometry's time span");
  if (outside > 0)
    recording.notes.push_back(std::to_string(outside) +
                              " cloud(s) outside the odometry's time span left out");
  return recording;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> bagTopics(const fs::path& file) {
  return refusingBrokenBags(file, [&] { return bagTopicsOf(file); });
}

MagnetometerRecording readBagMagnetometer(const fs::path& file,
                                          const std::vector<std::string>& topics,
                                          const std::optional<std::string>& body_frame) {
  return refusingBrokenBags(file, [&] { return magnetometerOf(file, topics, body_frame); });
}

LidarRecording readBagLidar(const fs::path& file, const BagLidarOptions& options) {
  return refusingBrokenBags(file, [&] { return lidarOf(file, options); });
}

}  // namespace mm4mm
