// mm4mm import: a simulated session written in each tool's own format (as that tool's writer
// writes it: the same print formats, PCL point types and ROS messages) and read back, compared
// with the session it came from; and the errors a user meets on bad input.

#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <rosbag/bag.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_msgs/TFMessage.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>

#include "calibrated_sessions.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/import/extrinsics.hpp"
#include "mm4mm/import/fast_lio.hpp"
#include "mm4mm/import/glim_dump.hpp"
#include "mm4mm/import/hdl_graph_slam_dump.hpp"
#include "mm4mm/import/kitti_odometry.hpp"
#include "mm4mm/import/lio_sam_map.hpp"
#include "mm4mm/import/magnetometer_table.hpp"
#include "mm4mm/import/recording.hpp"
#include "mm4mm/import/ros_bag.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/io/tum_io.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/sim/simulator.hpp"
#include "test_support.hpp"

// LIO-SAM's key-pose type, with the fields and types its utility.h declares (PCL's own point
// types' layout: the macros' anonymous unions are a compiler extension pedantic mode warns of).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpedantic"
struct EIGEN_ALIGN16 PointXYZIRPYT {
  PCL_ADD_POINT4D;
  PCL_ADD_INTENSITY;
  float roll;
  float pitch;
  float yaw;
  double time;
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};
#pragma GCC diagnostic pop
POINT_CLOUD_REGISTER_POINT_STRUCT(
    PointXYZIRPYT, (float, x, x)(float, y, y)(float, z, z)(float, intensity, intensity)(
                       float, roll, roll)(float, pitch, pitch)(float, yaw, yaw)(double, time, time))

namespace mm4mm {
namespace {

namespace fs = std::filesystem;
using test::readBytes;
using test::TempDir;

// 24 keyframes of a simulated corridor session (sensor 0 of its rig): enough motion to test,
// quick to write.
const Session& sourceSession() {
  static const Session session = [] {
    sim::SimulationConfig config =
        loadSimulationConfig(fs::path(MM4MM_SOURCE_DIR) / "configs" / "corridor_small.yaml");
    Session s = sim::simulateSessions(config, 1, 11).front();
    const std::size_t keep = std::min<std::size_t>(24, s.keyframes.size());
    s.keyframes.resize(keep);
    s.scans.resize(keep);
    std::vector<MagnetometerSample> samples;
    for (const MagnetometerSample& m : s.magnetometer)
      if (m.sensor == 0 && m.time_s <= s.keyframes.back().time_s) samples.push_back(m);
    s.magnetometer = samples;
    // Recorded times are epoch seconds (and ROS refuses a stamp of 0).
    constexpr double kEpoch_s = 1.7e9;
    for (StampedPose& pose : s.keyframes) pose.time_s += kEpoch_s;
    for (MagnetometerSample& m : s.magnetometer) m.time_s += kEpoch_s;
    s.odometry.clear();
    return s;
  }();
  return session;
}

MagnetometerRecording sourceMagnetometer() {
  MagnetometerRecording recording;
  recording.source = "test magnetometer";
  recording.samples = sourceSession().magnetometer;
  return recording;
}

void writeText(const fs::path& file, const std::string& text) {
  fs::create_directories(file.parent_path());
  std::ofstream(file) << text;
}

template <typename Point>
void savePcl(const fs::path& file, const pcl::PointCloud<Point>& cloud) {
  fs::create_directories(file.parent_path());
  ASSERT_EQ(pcl::io::savePCDFileBinary(file.string(), cloud), 0);
}

pcl::PointCloud<pcl::PointXYZI> xyzi(const PointCloud& points, const Eigen::Isometry3d& T) {
  pcl::PointCloud<pcl::PointXYZI> cloud;
  for (const Eigen::Vector3f& p : points) {
    const Eigen::Vector3f q = T.cast<float>() * p;
    pcl::PointXYZI point;
    point.x = q.x();
    point.y = q.y();
    point.z = q.z();
    point.intensity = 7.0f;
    cloud.push_back(point);
  }
  return cloud;
}

void expectSamePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double tolerance_m) {
  EXPECT_LT((a.translation() - b.translation()).norm(), tolerance_m);
  EXPECT_LT(rotationAngle(a.linear().transpose() * b.linear()), 1e-4);
}

void expectSameCloud(const PointCloud& a, const PointCloud& b, float tolerance_m) {
  ASSERT_EQ(a.size(), b.size());
  float worst = 0.0f;
  for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, (a[i] - b[i]).norm());
  EXPECT_LT(worst, tolerance_m);
}

// ---- assembleSession ----------------------------------------------------------------------

LidarRecording keyframesOnly() {
  LidarRecording lidar;
  lidar.source = "test poses";
  for (std::size_t i = 0; i < sourceSession().keyframes.size(); ++i)
    lidar.keyframes.push_back({sourceSession().keyframes[i], sourceSession().scans[i]});
  return lidar;
}

TEST(AssembleSession, ShiftsRotatesAndDropsSamplesOutsideThePoses) {
  const LidarRecording lidar = keyframesOnly();
  MagnetometerRecording magnetometer = sourceMagnetometer();
  // The logger's clock runs 100 s behind; its axes are the body's turned 90 degrees about z.
  const Eigen::Isometry3d T_body_mag = planarPose(0.1, 0.0, M_PI / 2, 0.3);
  for (MagnetometerSample& m : magnetometer.samples) {
    m.time_s -= 100.0;
    m.field_body_uT = T_body_mag.linear().transpose() * m.field_body_uT;
  }
  MagnetometerSample early = magnetometer.samples.front();
  early.time_s -= 5.0;
  magnetometer.samples.insert(magnetometer.samples.begin(), early);
  ImportOptions options;
  options.id = "imported";
  options.clock_offset_s = 100.0;
  options.T_body_magnetometer = T_body_mag;
  ImportReport report;
  const Session session = assembleSession(lidar, magnetometer, options, &report);
  EXPECT_EQ(report.samples_before_poses, 1u);
  ASSERT_EQ(session.rig.magnetometers_body.size(), 1u);
  EXPECT_TRUE(session.rig.magnetometers_body[0].isApprox(T_body_mag.translation()));
  const double first = sourceSession().keyframes.front().time_s;
  std::size_t expected = 0;
  for (const MagnetometerSample& m : sourceSession().magnetometer) expected += m.time_s >= first;
  ASSERT_EQ(session.magnetometer.size(), expected);
  const MagnetometerSample& original =
      sourceSession().magnetometer[sourceSession().magnetometer.size() - expected];
  EXPECT_NEAR(session.magnetometer.front().time_s, original.time_s, 1e-9);
  EXPECT_LT((session.magnetometer.front().field_body_uT - original.field_body_uT).norm(), 1e-9);
  EXPECT_EQ(session.scans.size(), session.keyframes.size());
}

TEST(AssembleSession, RefusesDisjointClocksAndNamesTheLikelyUnit) {
  const LidarRecording lidar = keyframesOnly();
  MagnetometerRecording late = sourceMagnetometer();
  for (MagnetometerSample& m : late.samples) m.time_s += 1e5;
  ImportOptions options;
  options.id = "x";
  try {
    assembleSession(lidar, late, options);
    FAIL() << "disjoint clocks accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no common time"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--clock-offset"), std::string::npos) << e.what();
  }
  MagnetometerRecording nanotesla = sourceMagnetometer();  // nT numbers read as µT
  for (MagnetometerSample& m : nanotesla.samples) m.field_body_uT *= 1000.0;
  try {
    assembleSession(lidar, nanotesla, options);
    FAIL() << "a field of ~45000 uT accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("fit nT"), std::string::npos) << e.what();
  }
}

// ---- GLIM ---------------------------------------------------------------------------------
// Written as GlobalMapping::save writes a dump (koide3/glim src/glim/mapping/global_mapping.cpp;
// SubMap::save in src/glim/mapping/sub_map.cpp, gtsam_points' PointCloud::save_compact).

// SubMap::save's text, Eigen's operator<< at the stream's default precision as GLIM prints it.
std::string glimData(int id, const std::vector<StampedPose>& frames, std::size_t origin) {
  std::ostringstream o;
  const Eigen::Isometry3d T_world_origin = frames[origin].T_frame_body;
  o << "id: " << id << std::endl;
  o << "T_world_origin: " << std::endl << T_world_origin.matrix() << std::endl;
  o << "T_origin_endpoint_L: " << std::endl
    << (T_world_origin.inverse() * frames.front().T_frame_body).matrix() << std::endl;
  o << "T_origin_endpoint_R: " << std::endl
    << (T_world_origin.inverse() * frames.back().T_frame_body).matrix() << std::endl;
  o << "T_lidar_imu: " << std::endl << Eigen::Matrix4d::Identity() << std::endl;
  o << "imu_bias: " << Eigen::Matrix<double, 6, 1>::Zero().transpose() << std::endl;
  o << "frame_id: " << 2 << std::endl;
  o << "num_frames: " << frames.size() << std::endl;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    char stamp[64];
    std::snprintf(stamp, sizeof stamp, "%.9f", frames[i].time_s);
    o << "frame_" << i << std::endl << "id: " << i << std::endl << "stamp: " << stamp << std::endl;
    o << "T_odom_lidar: " << std::endl << frames[i].T_frame_body.matrix() << std::endl;
    o << "T_world_lidar: " << std::endl << frames[i].T_frame_body.matrix() << std::endl;
    o << "v_world_imu: " << Eigen::Vector3d::Zero().transpose() << std::endl;
  }
  return o.str();
}

std::string tumLine(const StampedPose& pose) {
  const Eigen::Quaterniond q(pose.T_frame_body.linear());
  const Eigen::Vector3d t = pose.T_frame_body.translation();
  char line[256];
  std::snprintf(line, sizeof line, "%.9f %.6f %.6f %.6f %.6f %.6f %.6f %.6f\n", pose.time_s, t.x(),
                t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
  return line;
}

TEST(GlimDump, SubmapOriginsAndTheirCloudsComeBack) {
  const Session& s = sourceSession();
  TempDir dir("mm4mm_glim");
  std::string trajectory;
  for (const StampedPose& pose : s.keyframes) trajectory += tumLine(pose);
  writeText(dir.path() / "traj_imu.txt", trajectory);
  writeText(dir.path() / "traj_lidar.txt", trajectory);
  const std::size_t per_submap = 6;
  std::vector<PointCloud> expected_clouds;
  for (std::size_t first = 0; first < s.keyframes.size(); first += per_submap) {
    const std::vector<StampedPose> frames(s.keyframes.begin() + first,
                                          s.keyframes.begin() + first + per_submap);
    const std::size_t origin = frames.size() / 2;
    char name[32];
    std::snprintf(name, sizeof name, "%06zu", first / per_submap);
    writeText(dir.path() / name / "data.txt", glimData(static_cast<int>(first), frames, origin));
    // The merged cloud in the origin frame, float32 x y z packed (PointCloud::save_compact).
    PointCloud merged;
    const Eigen::Isometry3d T_origin_world = frames[origin].T_frame_body.inverse();
    for (std::size_t k = 0; k < frames.size(); ++k)
      for (const Eigen::Vector3f& p : s.scans[first + k])
        merged.push_back((T_origin_world * frames[k].T_frame_body).cast<float>() * p);
    std::ofstream(dir.path() / name / "points_compact.bin", std::ios::binary)
        .write(reinterpret_cast<const char*>(merged.data()),
               static_cast<std::streamsize>(merged.size() * sizeof(Eigen::Vector3f)));
    expected_clouds.push_back(merged);
  }
  const LidarRecording glim = readGlimDump(dir.path());
  ASSERT_EQ(glim.keyframes.size(), s.keyframes.size() / per_submap);
  EXPECT_EQ(glim.odometry.size(), s.keyframes.size());
  EXPECT_EQ(glim.body_frame, "GLIM's imu frame");
  for (std::size_t i = 0; i < glim.keyframes.size(); ++i) {
    const StampedPose& origin = s.keyframes[i * per_submap + per_submap / 2];
    EXPECT_NEAR(glim.keyframes[i].pose.time_s, origin.time_s, 1e-6);
    expectSamePose(glim.keyframes[i].pose.T_frame_body, origin.T_frame_body, 1e-3);
    expectSameCloud(glim.keyframes[i].scan_body, expected_clouds[i], 1e-6f);
  }
  // A session that readSession takes as it is.
  ImportOptions options;
  options.id = "glim";
  TempDir out("mm4mm_glim_session");
  writeSession(assembleSession(glim, sourceMagnetometer(), options), out.path() / "s");
  EXPECT_EQ(readSession(out.path() / "s").keyframes.size(), glim.keyframes.size());
}

TEST(GlimDump, ATruncatedSubmapNamesItsFileAndLine) {
  TempDir dir("mm4mm_glim_bad");
  writeText(dir.path() / "traj_imu.txt", "");
  writeText(dir.path() / "000000" / "data.txt", "id: 0\nT_world_origin: \n1 0 0 0\n0 1 0\n");
  try {
    readGlimDump(dir.path());
    FAIL() << "a truncated data.txt accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), (dir.path() / "000000" / "data.txt").string());
    EXPECT_EQ(e.line(), 4);
  }
}

// ---- hdl_graph_slam -----------------------------------------------------------------------
// Written as the dump service writes it (koide3/hdl_graph_slam apps/hdl_graph_slam_nodelet.cpp
// dump_service, src/hdl_graph_slam/keyframe.cpp KeyFrame::save).

TEST(HdlGraphSlamDump, KeyframeEstimatesAndCloudsComeBack) {
  const Session& s = sourceSession();
  TempDir dir("mm4mm_hdl");
  writeText(dir.path() / "graph.g2o", "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n");
  for (std::size_t i = 0; i < s.keyframes.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%06zu", i);
    const double t = s.keyframes[i].time_s;
    std::ostringstream data;  // KeyFrame::save
    data << "stamp " << static_cast<long>(std::floor(t)) << " "
         << static_cast<long>(std::llround((t - std::floor(t)) * 1e9)) << "\n";
    data << "estimate\n" << s.keyframes[i].T_frame_body.matrix() << "\n";
    data << "odom\n" << s.keyframes[i].T_frame_body.matrix() << "\n";
    data << "accum_distance " << 1.5 * i << "\n";
    data << "orientation " << 1 << " " << 0 << " " << 0 << " " << 0 << "\n";
    data << "id " << i + 1 << "\n";
    writeText(dir.path() / name / "data", data.str());
    savePcl(dir.path() / name / "cloud.pcd", xyzi(s.scans[i], Eigen::Isometry3d::Identity()));
  }
  const LidarRecording hdl = readHdlGraphSlamDump(dir.path());
  ASSERT_EQ(hdl.keyframes.size(), s.keyframes.size());
  for (std::size_t i = 0; i < s.keyframes.size(); ++i) {
    EXPECT_NEAR(hdl.keyframes[i].pose.time_s, s.keyframes[i].time_s, 1e-6);
    expectSamePose(hdl.keyframes[i].pose.T_frame_body, s.keyframes[i].T_frame_body, 1e-3);
  }
  expectSameCloud(hdl.keyframes[3].scan_body, s.scans[3], 1e-6f);
  writeText(dir.path() / "000002" / "data",
            "stamp 1 2\nestimate\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n"
            "odom\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\nspeed 3\n");
  try {
    readHdlGraphSlamDump(dir.path());
    FAIL() << "an unknown key accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 12);
    EXPECT_NE(e.problem().find("unknown key 'speed'"), std::string::npos) << e.what();
  }
}

// ---- LIO-SAM ------------------------------------------------------------------------------
// Written as saveMapService writes it (TixiaoShan/LIO-SAM src/mapOptmization.cpp), through
// PCL's own PCD writer.

TEST(LioSamMap, KeyPosesComeBackAndTheSessionIsMagneticOnlyWithoutScans) {
  const Session& s = sourceSession();
  TempDir dir("mm4mm_liosam");
  pcl::PointCloud<PointXYZIRPYT> poses;
  pcl::PointCloud<pcl::PointXYZI> map;
  for (std::size_t i = 0; i < s.keyframes.size(); ++i) {
    const Eigen::Isometry3d& T = s.keyframes[i].T_frame_body;
    // gtsam's Rot3::roll/pitch/yaw: R = Rz(yaw) Ry(pitch) Rx(roll).
    const Eigen::Vector3d ypr = T.linear().eulerAngles(2, 1, 0);
    PointXYZIRPYT p;
    p.x = static_cast<float>(T.translation().x());
    p.y = static_cast<float>(T.translation().y());
    p.z = static_cast<float>(T.translation().z());
    p.intensity = static_cast<float>(i);
    p.roll = static_cast<float>(ypr[2]);
    p.pitch = static_cast<float>(ypr[1]);
    p.yaw = static_cast<float>(ypr[0]);
    p.time = s.keyframes[i].time_s;
    poses.push_back(p);
    map += xyzi(s.scans[i], T);
  }
  savePcl(dir.path() / "transformations.pcd", poses);
  savePcl(dir.path() / "GlobalMap.pcd", map);
  const LidarRecording lio = readLioSamMap(dir.path());
  EXPECT_FALSE(lio.scans_saved);
  ASSERT_EQ(lio.keyframes.size(), s.keyframes.size());
  for (std::size_t i = 0; i < s.keyframes.size(); ++i) {
    EXPECT_NEAR(lio.keyframes[i].pose.time_s, s.keyframes[i].time_s, 1e-9);
    expectSamePose(lio.keyframes[i].pose.T_frame_body, s.keyframes[i].T_frame_body, 1e-3);
  }
  ImportOptions options;
  options.id = "liosam";
  EXPECT_TRUE(assembleSession(lio, sourceMagnetometer(), options).scans.empty());
  const LidarRecording cropped = readLioSamMap(dir.path(), 5.0);
  ASSERT_TRUE(cropped.scans_saved);
  for (const Eigen::Vector3f& p : cropped.keyframes[5].scan_body) EXPECT_LE(p.norm(), 5.0f + 1e-3f);
  std::size_t within = 0;  // every map point within the radius, counted by brute force
  const Eigen::Vector3f centre = s.keyframes[5].T_frame_body.translation().cast<float>();
  for (const auto& p : map) within += (p.getVector3fMap() - centre).norm() <= 5.0f;
  EXPECT_NEAR(static_cast<double>(cropped.keyframes[5].scan_body.size()),
              static_cast<double>(within), 2.0);  // points on the sphere may round either way

  // Saved as older LIO-SAM saves it (savePCDFileASCII: 8 significant digits) with Unix times, the
  // key poses share times: refused, saying why and what to save instead.
  for (auto& p : poses) p.time += 1.7e9;
  ASSERT_EQ(pcl::io::savePCDFileASCII((dir.path() / "transformations.pcd").string(), poses), 0);
  try {
    readLioSamMap(dir.path());
    FAIL() << "rounded key pose times accepted";
  } catch (const InputError& e) {
    EXPECT_NE(e.problem().find("8 significant digits"), std::string::npos) << e.what();
    EXPECT_NE(e.problem().find("savePCDFileBinary"), std::string::npos) << e.what();
  }
}

// ---- FAST-LIO2 ----------------------------------------------------------------------------
// Written as laserMapping.cpp writes pcd_save's scans_N.pcd and runtime_pos_log's pos_log.txt
// (hku-mars/FAST_LIO src/laserMapping.cpp).

TEST(FastLio, PcdSaveScansComeBackInTheBodyFrameOfALevelledWorld) {
  const Session& s = sourceSession();
  TempDir dir("mm4mm_fastlio");
  // FAST-LIO's world is the IMU frame at start, here tilted 4 degrees from level.
  const Eigen::Isometry3d T_fast_world(Eigen::AngleAxisd(0.07, Eigen::Vector3d::UnitX()));
  const Eigen::Vector3d gravity = T_fast_world.linear() * Eigen::Vector3d(0, 0, -9.81);
  const double t0 = s.keyframes.front().time_s;
  const int interval = 3;
  // FAST-LIO logs each scan's start time beside the state at its end: here each keyframe's state,
  // logged one median keyframe gap before it.
  std::vector<double> gaps;
  for (std::size_t i = 1; i < s.keyframes.size(); ++i)
    gaps.push_back(s.keyframes[i].time_s - s.keyframes[i - 1].time_s);
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  const double sweep = gaps[gaps.size() / 2];
  FILE* log = std::fopen((dir.path() / "pos_log.txt").c_str(), "w");
  pcl::PointCloud<pcl::PointXYZINormal> waiting;
  int file_index = 0;
  for (std::size_t i = 0; i < s.keyframes.size(); ++i) {
    const Eigen::Isometry3d T = T_fast_world * s.keyframes[i].T_frame_body;
    const Eigen::AngleAxisd r(T.linear());
    const Eigen::Vector3d rv = r.angle() * r.axis();
    const Eigen::Vector3d p = T.translation();
    std::fprintf(log, "%lf ", s.keyframes[i].time_s - sweep - t0);  // dump_lio_state_to_log
    std::fprintf(log, "%lf %lf %lf ", rv(0), rv(1), rv(2));
    std::fprintf(log, "%lf %lf %lf ", p(0), p(1), p(2));
    std::fprintf(log, "%lf %lf %lf ", 0.0, 0.0, 0.0);
    std::fprintf(log, "%lf %lf %lf ", 0.5, 0.0, 0.0);
    std::fprintf(log, "%lf %lf %lf ", 0.0, 0.0, 0.0);
    std::fprintf(log, "%lf %lf %lf ", 0.0, 0.0, 0.0);
    std::fprintf(log, "%lf %lf %lf ", 0.0, 0.0, 0.0);
    std::fprintf(log, "%lf %lf %lf ", gravity(0), gravity(1), gravity(2));
    std::fprintf(log, "\r\n");
    for (const Eigen::Vector3f& q : s.scans[i]) {
      const Eigen::Vector3f w = T.cast<float>() * q;
      pcl::PointXYZINormal point;
      point.x = w.x();
      point.y = w.y();
      point.z = w.z();
      waiting.push_back(point);
    }
    if ((i + 1) % interval == 0) {
      savePcl(dir.path() / "PCD" / ("scans_" + std::to_string(++file_index) + ".pcd"), waiting);
      waiting.clear();
    }
  }
  std::fclose(log);
  const LidarRecording fast =
      readFastLioPcdSave(dir.path() / "PCD", dir.path() / "pos_log.txt", interval, t0);
  ASSERT_EQ(fast.keyframes.size(), s.keyframes.size() / interval);
  EXPECT_EQ(fast.odometry.size(), s.keyframes.size());
  for (std::size_t k = 0; k < fast.keyframes.size(); ++k) {
    const std::size_t middle = k * interval + interval / 2;
    // %lf keeps 1 µs; the levelled world is the session's own frame.
    EXPECT_NEAR(fast.keyframes[k].pose.time_s, s.keyframes[middle].time_s, 2e-6);
    expectSamePose(fast.keyframes[k].pose.T_frame_body, s.keyframes[middle].T_frame_body, 1e-4);
  }
  // The middle scan's own points come back in its body frame.
  const PointCloud& body = fast.keyframes[1].scan_body;
  const std::size_t before = s.scans[3].size();
  ASSERT_GE(body.size(), before + s.scans[4].size());
  float worst = 0.0f;
  for (std::size_t i = 0; i < s.scans[4].size(); ++i)
    worst = std::max(worst, (body[before + i] - s.scans[4][i]).norm());
  EXPECT_LT(worst, 1e-3f);
  EXPECT_THROW(readFastLioPcdSave(dir.path() / "PCD", dir.path() / "pos_log.txt", 5, t0),
               InputError);  // the wrong interval asks for more log lines than there are
  // FAST-LIO's defaults: one scans.pcd (pcd_save/interval -1) and an empty pos_log
  // (runtime_pos_log_enable 0) are refused naming the setting to change.
  const auto refusedNaming = [&](const fs::path& pcd, const fs::path& pos,
                                 const std::string& words) {
    try {
      readFastLioPcdSave(pcd, pos, interval, t0);
      ADD_FAILURE() << "accepted; expected a message naming " << words;
    } catch (const InputError& e) {
      EXPECT_NE(e.problem().find(words), std::string::npos) << e.what();
    }
  };
  fs::create_directories(dir.path() / "one");
  fs::copy_file(dir.path() / "PCD" / "scans_1.pcd", dir.path() / "one" / "scans.pcd");
  refusedNaming(dir.path() / "one", dir.path() / "pos_log.txt", "pcd_save/interval: -1");
  std::ofstream(dir.path() / "empty_pos_log.txt").flush();
  refusedNaming(dir.path() / "PCD", dir.path() / "empty_pos_log.txt", "runtime_pos_log_enable");
  // Too small an interval leaves whole intervals of log lines over: refused, the saved one named.
  try {
    readFastLioPcdSave(dir.path() / "PCD", dir.path() / "pos_log.txt", interval - 1, t0);
    FAIL() << "an interval of " << interval - 1 << " accepted for files of " << interval;
  } catch (const InputError& e) {
    EXPECT_NE(e.problem().find("is pcd_save/interval about " + std::to_string(interval) + "?"),
              std::string::npos)
        << e.what();
  }
}

// SC-PGO (FAST_LIO_SLAM SC-PGO/src/laserPosegraphOptimization.cpp) writes optimized_poses.txt in
// camera_init, the IMU frame at start, which is tilted by the body's attitude then (5.7 deg here),
// the keyframe scans in the body frame and times.txt. The import levels the frame by the floor the
// scans see: every pose comes back relative to the first as it was, with its own up to 0.05 deg.
// The poses written are the simulator's true ones, with which the scans agree (the odometry's
// drift would tilt the floor they place by a few tenths of a degree).
void writeFork(const fs::path& dir, const Eigen::Isometry3d& T_frame_init,
               const std::vector<PointCloud>& scans) {
  const Session& s = sourceSession();
  const std::vector<StampedPose>& truth = *s.ground_truth;
  std::ofstream poses(dir / "optimized_poses.txt");
  std::ofstream times(dir / "times.txt");
  times.precision(std::numeric_limits<double>::max_digits10);
  for (std::size_t i = 0; i < s.keyframes.size(); ++i) {
    const Eigen::Matrix4d M = (T_frame_init.inverse() * truth[i].T_frame_body).matrix();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) poses << M(r, c) << (r == 2 && c == 3 ? "\n" : " ");
    times << s.keyframes[i].time_s << std::endl;
    char name[32];
    std::snprintf(name, sizeof name, "%06zu.pcd", i);
    savePcl(dir / "Scans" / name, xyzi(scans[i], Eigen::Isometry3d::Identity()));
  }
}

TEST(FastLio, ForkKeyframesComeBackLevelledByTheFloor) {
  const Session& s = sourceSession();
  ASSERT_TRUE(s.ground_truth.has_value());
  const std::vector<StampedPose>& truth = *s.ground_truth;
  TempDir dir("mm4mm_fastlio_sc");
  Eigen::Isometry3d T_frame_init = truth.front().T_frame_body;
  T_frame_init.linear() =
      T_frame_init.linear() *
      Eigen::AngleAxisd(5.7 * M_PI / 180.0, Eigen::Vector3d(1, 0.5, 0).normalized()).matrix();
  writeFork(dir.path(), T_frame_init, s.scans);
  fs::remove(dir.path() / "Scans" / "000023.pcd");  // the writer had not saved the last scan yet
  const LidarRecording fork = readFastLioKeyframes(dir.path());
  ASSERT_EQ(fork.keyframes.size(), 23u);
  ASSERT_EQ(fork.notes.size(), 2u);
  EXPECT_NE(fork.notes[0].find("levelled by the floor"), std::string::npos) << fork.notes[0];
  const Eigen::Isometry3d first = fork.keyframes[0].pose.T_frame_body;
  for (std::size_t i : {std::size_t{0}, std::size_t{7}, std::size_t{22}}) {
    const Eigen::Isometry3d& got = fork.keyframes[i].pose.T_frame_body;
    const Eigen::Isometry3d& want = truth[i].T_frame_body;
    expectSamePose(first.inverse() * got, truth[0].T_frame_body.inverse() * want, 1e-3);
    const Eigen::Vector3d up_got = got.linear().transpose() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d up_true = want.linear().transpose() * Eigen::Vector3d::UnitZ();
    EXPECT_LT(std::acos(std::min(1.0, up_got.dot(up_true))) * 180.0 / M_PI, 0.05) << i;
    EXPECT_DOUBLE_EQ(fork.keyframes[i].pose.time_s, s.keyframes[i].time_s);
  }

  // Scans that show no floor or ceiling (a cloud of scattered points) leave nothing to level by:
  // refused, naming the import that carries FAST-LIO's gravity.
  TempDir bare("mm4mm_fastlio_sc_bare");
  std::vector<PointCloud> scattered(s.scans.size());
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-10.0f, 10.0f);
  for (PointCloud& scan : scattered)
    for (int k = 0; k < 2000; ++k) scan.push_back({u(rng), u(rng), u(rng)});
  writeFork(bare.path(), T_frame_init, scattered);
  try {
    readFastLioKeyframes(bare.path());
    FAIL() << "a fork with nothing to level by accepted";
  } catch (const InputError& e) {
    EXPECT_NE(e.problem().find("--from fast_lio"), std::string::npos) << e.what();
  }
}

// ---- KITTI and TUM + PCDs -----------------------------------------------------------------

TEST(KittiOdometry, CameraPosesBecomeVelodynePoses) {
  const Session& s = sourceSession();
  TempDir dir("mm4mm_kitti");
  // A KITTI-like Tr (velodyne to camera 0): x_cam = -y_velo, y_cam = -z_velo, z_cam = x_velo.
  Eigen::Isometry3d Tr = Eigen::Isometry3d::Identity();
  Tr.linear() << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  Tr.translation() = Eigen::Vector3d(-0.004, -0.076, -0.272);
  auto row12 = [](const Eigen::Isometry3d& T) {
    std::ostringstream o;
    o << std::scientific;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) o << T.matrix()(r, c) << (r == 2 && c == 3 ? "" : " ");
    return o.str();
  };
  writeText(dir.path() / "calib.txt",
            "P0: 7.1e+02 0 6.0e+02 0 0 7.1e+02 1.8e+02 0 0 0 1 0\nTr: " + row12(Tr) + "\n");
  std::string times, poses;
  const Eigen::Isometry3d T_velo0_world = s.keyframes.front().T_frame_body.inverse();
  for (std::size_t i = 0; i < s.keyframes.size(); ++i) {
    char line[64];
    std::snprintf(line, sizeof line, "%e\n", s.keyframes[i].time_s - s.keyframes[0].time_s);
    times += line;
    poses += row12(Tr * T_velo0_world * s.keyframes[i].T_frame_body * Tr.inverse()) + "\n";
    std::vector<float> bin;
    for (const Eigen::Vector3f& p : s.scans[i]) bin.insert(bin.end(), {p.x(), p.y(), p.z(), 0.5f});
    char name[32];
    std::snprintf(name, sizeof name, "%06zu.bin", i);
    fs::create_directories(dir.path() / "velodyne");
    std::ofstream(dir.path() / "velodyne" / name, std::ios::binary)
        .write(reinterpret_cast<const char*>(bin.data()),
               static_cast<std::streamsize>(bin.size() * sizeof(float)));
  }
  writeText(dir.path() / "times.txt", times);
  writeText(dir.path() / "poses.txt", poses);
  const LidarRecording kitti = readKittiOdometry(dir.path(), dir.path() / "poses.txt",
                                                 s.keyframes[0].time_s, KeyframeSpacing{2.0, 30.0});
  ASSERT_EQ(kitti.odometry.size(), s.keyframes.size());
  ASSERT_GT(kitti.keyframes.size(), 2u);
  ASSERT_LT(kitti.keyframes.size(), s.keyframes.size());
  for (std::size_t i = 0; i < s.keyframes.size(); ++i)
    expectSamePose(kitti.odometry[i].T_frame_body, T_velo0_world * s.keyframes[i].T_frame_body,
                   1e-4);
  expectSameCloud(kitti.keyframes[0].scan_body, s.scans[0], 1e-6f);
}

TEST(TumWithPcds, WorldFrameScansComeBackInTheBodyFrame) {
  const Session& s = sourceSession();
  TempDir dir("mm4mm_tum");
  writeTumPoses(dir.path() / "poses.txt", s.keyframes);
  for (std::size_t i = 0; i < s.keyframes.size(); ++i)
    savePcl(dir.path() / "pcd" / (std::to_string(i) + ".pcd"),  // 0.pcd ... 23.pcd: by number
            xyzi(s.scans[i], s.keyframes[i].T_frame_body));
  const LidarRecording tum = readTumWithPcds(dir.path() / "poses.txt", dir.path() / "pcd", true);
  ASSERT_EQ(tum.keyframes.size(), s.keyframes.size());
  expectSameCloud(tum.keyframes[12].scan_body, s.scans[12], 1e-3f);
  fs::remove(dir.path() / "pcd" / "5.pcd");
  try {
    readTumWithPcds(dir.path() / "poses.txt", dir.path() / "pcd", true);
    FAIL() << "a missing scan accepted";
  } catch (const InputError& e) {
    EXPECT_NE(e.problem().find("holds 23 PCD files"), std::string::npos) << e.what();
  }
}

// Exporters name scans scan_0 ... scan_23: by text, scan_10 would come before scan_2 and every
// scan from the third on would be paired with another pose. The numbers order them; names that
// give no one order are refused, each naming the file.
TEST(TumWithPcds, ScansPairWithPosesByTheNumberInTheirNames) {
  const Session& s = sourceSession();
  TempDir dir("mm4mm_tum_names");
  writeTumPoses(dir.path() / "poses.txt", s.keyframes);
  const fs::path pcd = dir.path() / "pcd";
  for (std::size_t i = 0; i < s.keyframes.size(); ++i)
    savePcl(pcd / ("scan_" + std::to_string(i) + ".pcd"),
            xyzi(s.scans[i], s.keyframes[i].T_frame_body));
  const LidarRecording tum = readTumWithPcds(dir.path() / "poses.txt", pcd, true);
  ASSERT_EQ(tum.keyframes.size(), s.keyframes.size());
  for (const std::size_t i : {2u, 10u, 12u, 23u})
    expectSameCloud(tum.keyframes[i].scan_body, s.scans[i], 1e-3f);

  const auto refused = [&](const std::string& words, const std::string& file) {
    try {
      readTumWithPcds(dir.path() / "poses.txt", pcd, true);
      ADD_FAILURE() << "accepted: " << words;
    } catch (const InputError& e) {
      EXPECT_NE(e.problem().find(words), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
    }
  };
  fs::rename(pcd / "scan_5.pcd", pcd / "scan_05_copy.pcd");
  refused("more than one pattern", "scan_05_copy.pcd");
  fs::rename(pcd / "scan_05_copy.pcd", pcd / "scan_05.pcd");  // the same number as scan_5 was
  fs::copy_file(pcd / "scan_05.pcd", pcd / "scan_5.pcd");
  refused("the same number", "scan_5");
  fs::remove(pcd / "scan_05.pcd");
  fs::copy_file(pcd / "scan_5.pcd", pcd / "latest.pcd");
  refused("holds no number", "latest.pcd");
}

// ---- ROS 1 bag ----------------------------------------------------------------------------

geometry_msgs::TransformStamped staticTransform(const std::string& parent, const std::string& child,
                                                const Eigen::Isometry3d& T) {
  geometry_msgs::TransformStamped t;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  const Eigen::Quaterniond q(T.linear());
  t.transform.translation.x = T.translation().x();
  t.transform.translation.y = T.translation().y();
  t.transform.translation.z = T.translation().z();
  t.transform.rotation.x = q.x();
  t.transform.rotation.y = q.y();
  t.transform.rotation.z = q.z();
  t.transform.rotation.w = q.w();
  return t;
}

// Writes `s` as a robot would record it: nav_msgs/Odometry at four times the keyframe rate (or
// the session's own odometry stream), a sensor_msgs/PointCloud2 in the LiDAR's frame at each
// keyframe but the last, sensor_msgs/MagneticField in tesla along each magnetometer's own axes on
// `mag_topics[i]`, and /tf_static with the LiDAR's and the magnetometers' poses in base_link.
void writeSessionBag(const Session& s, const fs::path& file, const Eigen::Isometry3d& T_base_velo,
                     const std::vector<Eigen::Isometry3d>& T_base_mag,
                     const std::vector<std::string>& mag_topics) {
  rosbag::Bag bag;
  bag.open(file.string(), rosbag::bagmode::Write);
  tf2_msgs::TFMessage tf;
  tf.transforms.push_back(staticTransform("base_link", "velodyne", T_base_velo));
  for (std::size_t i = 0; i < T_base_mag.size(); ++i)
    tf.transforms.push_back(
        staticTransform("base_link", "mag_" + std::to_string(i), T_base_mag[i]));
  bag.write("/tf_static", ros::Time(s.keyframes.front().time_s), tf);
  std::vector<StampedPose> stream = s.odometry;
  if (stream.empty()) {
    for (std::size_t i = 0; i + 1 < s.keyframes.size(); ++i)
      for (int k = 0; k < 4; ++k) {
        const double t =
            s.keyframes[i].time_s + 0.25 * k * (s.keyframes[i + 1].time_s - s.keyframes[i].time_s);
        stream.push_back({t, poseAt(s.keyframes, t)});
      }
  }
  for (const StampedPose& pose : stream) {
    nav_msgs::Odometry odometry;
    odometry.header.stamp = ros::Time(pose.time_s);
    odometry.header.frame_id = "odom";
    odometry.child_frame_id = "base_link";
    const Eigen::Quaterniond q(pose.T_frame_body.linear());
    odometry.pose.pose.position.x = pose.T_frame_body.translation().x();
    odometry.pose.pose.position.y = pose.T_frame_body.translation().y();
    odometry.pose.pose.position.z = pose.T_frame_body.translation().z();
    odometry.pose.pose.orientation.x = q.x();
    odometry.pose.pose.orientation.y = q.y();
    odometry.pose.pose.orientation.z = q.z();
    odometry.pose.pose.orientation.w = q.w();
    bag.write("/odom", odometry.header.stamp, odometry);
  }
  for (std::size_t i = 0; i + 1 < s.keyframes.size(); ++i) {
    sensor_msgs::PointCloud2 cloud;
    cloud.header.stamp = ros::Time(s.keyframes[i].time_s);
    cloud.header.frame_id = "velodyne";
    sensor_msgs::PointCloud2Modifier modifier(cloud);
    modifier.setPointCloud2FieldsByString(1, "xyz");
    modifier.resize(s.scans[i].size());
    sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
    for (const Eigen::Vector3f& p : s.scans[i]) {
      const Eigen::Vector3f q = T_base_velo.inverse().cast<float>() * p;
      *x = q.x();
      *y = q.y();
      *z = q.z();
      ++x, ++y, ++z;
    }
    bag.write("/points", cloud.header.stamp, cloud);
  }
  for (const MagnetometerSample& m : s.magnetometer) {
    sensor_msgs::MagneticField field;
    field.header.stamp = ros::Time(m.time_s);
    field.header.frame_id = "mag_" + std::to_string(m.sensor);
    const Eigen::Vector3d tesla =
        1e-6 *
        (T_base_mag[static_cast<std::size_t>(m.sensor)].linear().transpose() * m.field_body_uT);
    field.magnetic_field.x = tesla.x();
    field.magnetic_field.y = tesla.y();
    field.magnetic_field.z = tesla.z();
    bag.write(mag_topics[static_cast<std::size_t>(m.sensor)], field.header.stamp, field);
  }
}

class RosBag : public ::testing::Test {
 protected:
  const Eigen::Isometry3d T_base_mag = planarPose(0.2, -0.1, M_PI, 0.4);
  const Eigen::Isometry3d T_base_velo = planarPose(0.0, 0.0, 0.1, 0.8);
  TempDir dir{"mm4mm_bag"};
  fs::path bag_file = dir.path() / "run.bag";

  void SetUp() override {
    writeSessionBag(sourceSession(), bag_file, T_base_velo, {T_base_mag}, {"/imu/mag"});
  }
};

TEST_F(RosBag, OdometryCloudsAndFieldComeBackInTheBodyFrame) {
  const Session& s = sourceSession();
  BagLidarOptions options;
  options.odometry_topic = "/odom";
  options.cloud_topic = "/points";
  options.spacing = {1e-3, 1e-3};  // every cloud a keyframe
  const LidarRecording lidar = readBagLidar(bag_file, options);
  ASSERT_EQ(lidar.keyframes.size(), s.keyframes.size() - 1);
  for (std::size_t i = 0; i < lidar.keyframes.size(); ++i)
    expectSamePose(lidar.keyframes[i].pose.T_frame_body, s.keyframes[i].T_frame_body, 1e-6);
  expectSameCloud(lidar.keyframes[6].scan_body, s.scans[6], 1e-4f);

  const MagnetometerRecording magnetometer =
      readBagMagnetometer(bag_file, {"/imu/mag"}, std::string("base_link"));
  ASSERT_EQ(magnetometer.T_body_magnetometers.size(), 1u);
  expectSamePose(magnetometer.T_body_magnetometers[0], T_base_mag, 1e-9);
  ImportOptions import;
  import.id = "bag";
  ImportReport report;
  const Session session = assembleSession(lidar, magnetometer, import, &report);
  EXPECT_GT(report.samples_after_poses, 0u);  // the clouds stop a keyframe before the field
  ASSERT_GT(session.magnetometer.size(), 100u);
  const MagnetometerSample& imported = session.magnetometer[50];
  const auto original =
      std::find_if(s.magnetometer.begin(), s.magnetometer.end(),
                   [&](const auto& m) { return std::abs(m.time_s - imported.time_s) < 1e-6; });
  ASSERT_NE(original, s.magnetometer.end());
  EXPECT_LT((imported.field_body_uT - original->field_body_uT).norm(), 1e-6);
  EXPECT_TRUE(session.rig.magnetometers_body[0].isApprox(T_base_mag.translation()));
}

TEST_F(RosBag, AnUnknownTopicListsTheBagsTopics) {
  try {
    readBagMagnetometer(bag_file, {"/mag"}, std::nullopt);
    FAIL() << "an unknown topic accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), bag_file.string());
    EXPECT_NE(e.problem().find("/imu/mag (sensor_msgs/MagneticField)"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(readBagMagnetometer(bag_file, {"/odom"}, std::nullopt), InputError);  // wrong type
}

// Wheel odometry knows heading only; the IMU's orientation (here with its own heading 0.7 rad off
// and mounted turned about z) gives roll and pitch.
TEST(RosBagImu, HeadingOnlyOdometryTakesRollAndPitchFromTheImu) {
  const Session& s = sourceSession();
  TempDir dir("mm4mm_bag_imu");
  const fs::path file = dir.path() / "wheels.bag";
  const Eigen::Matrix3d R_body_imu = rotationZ(M_PI / 2);
  std::vector<Eigen::Isometry3d> truth;
  {
    rosbag::Bag bag;
    bag.open(file.string(), rosbag::bagmode::Write);
    tf2_msgs::TFMessage tf;
    tf.transforms = {staticTransform("base_link", "imu_link", Eigen::Isometry3d(R_body_imu))};
    bag.write("/tf_static", ros::Time(s.keyframes.front().time_s), tf);
    for (std::size_t i = 0; i < s.keyframes.size(); ++i) {
      Eigen::Isometry3d T = s.keyframes[i].T_frame_body;
      T.linear() = T.linear() * (Eigen::AngleAxisd(0.06 * std::sin(i), Eigen::Vector3d::UnitX()) *
                                 Eigen::AngleAxisd(0.04 * std::cos(i), Eigen::Vector3d::UnitY()))
                                    .toRotationMatrix();
      truth.push_back(T);
      nav_msgs::Odometry odometry;
      odometry.header.stamp = ros::Time(s.keyframes[i].time_s);
      odometry.child_frame_id = "base_link";
      const Eigen::Quaterniond flat(rotationZ(yawOf(T.linear())));
      odometry.pose.pose.position.x = T.translation().x();
      odometry.pose.pose.position.y = T.translation().y();
      odometry.pose.pose.position.z = T.translation().z();
      odometry.pose.pose.orientation.x = flat.x();
      odometry.pose.pose.orientation.y = flat.y();
      odometry.pose.pose.orientation.z = flat.z();
      odometry.pose.pose.orientation.w = flat.w();
      bag.write("/wheel_odom", odometry.header.stamp, odometry);
      sensor_msgs::Imu imu;
      imu.header.stamp = odometry.header.stamp;
      imu.header.frame_id = "imu_link";
      const Eigen::Quaterniond q(rotationZ(0.7) * T.linear() * R_body_imu);
      imu.orientation.x = q.x();
      imu.orientation.y = q.y();
      imu.orientation.z = q.z();
      imu.orientation.w = q.w();
      bag.write("/imu/data", imu.header.stamp, imu);
    }
  }
  BagLidarOptions options;
  options.odometry_topic = "/wheel_odom";
  options.imu_topic = "/imu/data";
  options.spacing = {1e-6, 1e-6};
  const LidarRecording lidar = readBagLidar(file, options);
  EXPECT_FALSE(lidar.scans_saved);
  ASSERT_EQ(lidar.keyframes.size(), truth.size());
  for (std::size_t i = 0; i < truth.size(); ++i)
    expectSamePose(lidar.keyframes[i].pose.T_frame_body, truth[i], 1e-6);
  options.imu_topic = "/wheel_odom";
  EXPECT_THROW(readBagLidar(file, options), InputError);  // not a sensor_msgs/Imu topic
}

TEST(RosBagErrors, StampsThatGoBackwardsAreNamedWithTheirTopic) {
  TempDir dir("mm4mm_bag_backwards");
  const fs::path file = dir.path() / "backwards.bag";
  {
    rosbag::Bag bag;
    bag.open(file.string(), rosbag::bagmode::Write);
    for (double t : {100.0, 100.02, 99.5}) {  // a logger whose clock was stepped back
      sensor_msgs::MagneticField field;
      field.header.stamp = ros::Time(t);
      field.magnetic_field.x = 2e-5;
      bag.write("/imu/mag", ros::Time(100.0), field);
    }
  }
  try {
    readBagMagnetometer(file, {"/imu/mag"}, std::nullopt);
    FAIL() << "stamps going backwards accepted";
  } catch (const InputError& e) {
    EXPECT_NE(e.problem().find("topic '/imu/mag': header stamps go backwards at 99.5"),
              std::string::npos)
        << e.what();
  }
}

// The seed of fuzz/fuzz_rosbag (fuzz/corpus/fuzz_rosbag/run.bag): a few messages of every topic
// that target reads, so that mutations start inside a bag the readers take whole.
void writeFuzzSeedBag(const fs::path& file) {
  rosbag::Bag bag;
  bag.open(file.string(), rosbag::bagmode::Write);
  tf2_msgs::TFMessage tf;
  tf.transforms.push_back(staticTransform("base_link", "velodyne", planarPose(0, 0, 0.1, 0.8)));
  tf.transforms.push_back(staticTransform("base_link", "mag_0", planarPose(0.2, 0, M_PI, 0.4)));
  tf.transforms.push_back(staticTransform("base_link", "imu_link", planarPose(0, 0, 0, 0.2)));
  bag.write("/tf_static", ros::Time(100.0), tf);
  for (int i = 0; i < 8; ++i) {
    const ros::Time stamp(100.0 + 0.5 * i);
    nav_msgs::Odometry odometry;
    odometry.header.stamp = stamp;
    odometry.header.frame_id = "odom";
    odometry.child_frame_id = "base_link";
    odometry.pose.pose.position.x = 0.3 * i;
    odometry.pose.pose.orientation.w = 1.0;
    bag.write("/odom", stamp, odometry);
    sensor_msgs::Imu imu;
    imu.header.stamp = stamp;
    imu.header.frame_id = "imu_link";
    imu.orientation.w = 1.0;
    bag.write("/imu", stamp, imu);
    sensor_msgs::MagneticField field;
    field.header.stamp = stamp;
    field.header.frame_id = "mag_0";
    field.magnetic_field.x = 2e-5;
    field.magnetic_field.z = -4e-5;
    bag.write("/imu/mag", stamp, field);
    if (i % 2 == 1) continue;
    sensor_msgs::PointCloud2 cloud;
    cloud.header.stamp = stamp;
    cloud.header.frame_id = "velodyne";
    sensor_msgs::PointCloud2Modifier modifier(cloud);
    modifier.setPointCloud2FieldsByString(1, "xyz");
    modifier.resize(3);
    sensor_msgs::PointCloud2Iterator<float> x(cloud, "x");
    for (int k = 0; k < 3; ++k, ++x) {
      x[0] = 2.0f + k;
      x[1] = 1.0f;
      x[2] = 0.5f * k;
    }
    bag.write("/points", stamp, cloud);
  }
}

// Not a test: writes the fuzz seed above.
//   MM4MM_FUZZ_SEED=fuzz/corpus/fuzz_rosbag/run.bag import_test --gtest_also_run_disabled_tests
//   --gtest_filter='*DISABLED_WriteFuzzSeed*'
TEST(RosBagFuzzSeed, DISABLED_WriteFuzzSeed) {
  const char* file = std::getenv("MM4MM_FUZZ_SEED");
  ASSERT_NE(file, nullptr) << "set MM4MM_FUZZ_SEED to the bag to write";
  writeFuzzSeedBag(file);
}

// The committed seed is the one writeFuzzSeedBag writes, and every reader the fuzz target runs
// takes it whole: mutations of it reach the messages, not only the bag's header.
TEST(RosBagFuzzSeed, TheCommittedSeedIsABagEveryReaderTakes) {
  const fs::path seed = fs::path(MM4MM_SOURCE_DIR) / "fuzz" / "corpus" / "fuzz_rosbag" / "run.bag";
  TempDir dir("mm4mm_bag_seed");
  writeFuzzSeedBag(dir.path() / "run.bag");
  EXPECT_EQ(readBytes(seed), readBytes(dir.path() / "run.bag"));
  EXPECT_EQ(bagTopics(seed).size(), 5u);
  const MagnetometerRecording magnetometer =
      readBagMagnetometer(seed, {"/imu/mag"}, std::string("base_link"));
  EXPECT_EQ(magnetometer.samples.size(), 8u);
  BagLidarOptions options;
  options.odometry_topic = "/odom";
  options.cloud_topic = "/points";
  options.imu_topic = "/imu";
  options.spacing = {0.1, 5.0};
  const LidarRecording lidar = readBagLidar(seed, options);
  EXPECT_EQ(lidar.keyframes.size(), 4u);
  for (const ImportedKeyframe& keyframe : lidar.keyframes) EXPECT_EQ(keyframe.scan_body.size(), 3u);
}

// Broken bags are bad input naming the bag, whatever rosbag_storage or roscpp's deserialisation
// throw on them: the fuzz seed cut short and with its messages' bytes overwritten, and the input
// fuzz_rosbag found in its first minute, whose record header claims 2.3 GB (rosbag allocates it
// before reading; it fails on a machine with less memory, and fails to read where it succeeds).
TEST(RosBagFuzzSeed, BrokenBagsAreRefusedNamingTheBag) {
  const fs::path corpus = fs::path(MM4MM_SOURCE_DIR) / "fuzz" / "corpus" / "fuzz_rosbag";
  TempDir dir("mm4mm_bag_broken");
  const std::string seed = readBytes(corpus / "run.bag");
  ASSERT_GT(seed.size(), 10000u);
  const fs::path cut = dir.path() / "cut.bag", overwritten = dir.path() / "overwritten.bag";
  std::ofstream(cut, std::ios::binary) << seed.substr(0, seed.size() / 2);
  // The bag opens, but the messages that name the frames "mag_0" and "velodyne" (the field, the
  // clouds, /tf_static) say those names run for 2 GB: roscpp's deserialisation overruns them.
  std::string garbled = seed;
  for (const std::string name : {"mag_0", "velodyne"}) {
    const std::string length(1, static_cast<char>(name.size()));
    const std::string serialised = length + std::string(3, '\0') + name;
    for (std::size_t at = garbled.find(serialised); at != std::string::npos;
         at = garbled.find(serialised, at + 1))
      garbled.replace(at, 4, "\xf0\xff\xff\x7f");
  }
  ASSERT_NE(garbled, seed);
  std::ofstream(overwritten, std::ios::binary) << garbled;
  BagLidarOptions options;
  options.odometry_topic = "/odom";
  options.cloud_topic = "/points";
  for (const fs::path& bag : {cut, overwritten, corpus / "oom-record-header-claims-2.3-GB.bag"}) {
    const auto refused = [&](auto&& read, const char* what) {
      try {
        read();
        ADD_FAILURE() << what << " accepted " << bag;
      } catch (const InputError& e) {
        EXPECT_EQ(e.file(), bag.string()) << e.what();
      } catch (const std::exception& e) {
        ADD_FAILURE() << what << " of " << bag << " threw other than InputError: " << e.what();
      }
    };
    refused([&] { readBagMagnetometer(bag, {"/imu/mag"}, std::string("base_link")); },
            "the magnetometer reader");
    refused([&] { readBagLidar(bag, options); }, "the odometry and cloud reader");
  }
}

TEST(GlimDumpErrors, AnEmptySubmapCloudNamesItsFile) {
  const Session& s = sourceSession();
  TempDir dir("mm4mm_glim_empty");
  std::string trajectory;
  for (const StampedPose& pose : s.keyframes) trajectory += tumLine(pose);
  writeText(dir.path() / "traj_imu.txt", trajectory);
  const std::vector<StampedPose> frames(s.keyframes.begin(), s.keyframes.begin() + 4);
  writeText(dir.path() / "000000" / "data.txt", glimData(0, frames, 2));
  writeText(dir.path() / "000000" / "points_compact.bin", "");
  try {
    readGlimDump(dir.path());
    FAIL() << "an empty submap cloud accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), (dir.path() / "000000" / "points_compact.bin").string());
    EXPECT_EQ(e.problem(), "holds no point");
  }
}

// ---- magnetometer tables and extrinsics ---------------------------------------------------

TEST(MagnetometerTable, ColumnsByNameWithUnitsAreConverted) {
  TempDir dir("mm4mm_table");
  writeText(dir.path() / "mag.csv",
            "stamp_ms;mx;my;mz;temp\n1000;0.2;-0.1;0.4;21\n1010;0.21;-0.1;0.41;21\n");
  MagnetometerTableOptions options;
  parseColumnMap("t=stamp_ms,x=mx,y=my,z=mz", &options);
  options.unit = parseFieldUnit("G");
  options.seconds_per_time_unit = 1e-3;
  const MagnetometerRecording table = readMagnetometerTable(dir.path() / "mag.csv", options);
  ASSERT_EQ(table.samples.size(), 2u);
  EXPECT_DOUBLE_EQ(table.samples[1].time_s, 1.01);
  EXPECT_NEAR(table.samples[0].field_body_uT.x(), 20.0, 1e-12);
  EXPECT_NEAR(table.samples[1].field_body_uT.z(), 41.0, 1e-12);
  options.x_column = "bx";
  try {
    readMagnetometerTable(dir.path() / "mag.csv", options);
    FAIL() << "a missing column accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 1);
    EXPECT_NE(e.problem().find("stamp_ms, mx, my, mz, temp"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parseColumnMap("t=0,w=1", &options), std::invalid_argument);
}

TEST(Extrinsics, ReadsTransformsAndRefusesUnknownKeys) {
  TempDir dir("mm4mm_extrinsics");
  writeText(dir.path() / "rig.yaml",
            "T_body_magnetometer: {translation: [0.1, 0, 0.3], quaternion: [0, 0, 1, 0]}\n");
  const Extrinsics extrinsics = readExtrinsicsYaml(dir.path() / "rig.yaml");
  ASSERT_TRUE(extrinsics.T_body_magnetometer.has_value());
  EXPECT_FALSE(extrinsics.T_body_lidar.has_value());
  EXPECT_TRUE(extrinsics.T_body_magnetometer->linear().isApprox(rotationZ(M_PI)));
  writeText(dir.path() / "bad.yaml", "T_body_lidar: {translation: [0, 0, 1]}\nT_body_imu: {}\n");
  try {
    readExtrinsicsYaml(dir.path() / "bad.yaml");
    FAIL() << "an unknown key accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 2);
  }
}

// A list or map as a key is valid YAML; it must come back as the file's error, not yaml-cpp's
// (the input fuzz_import found, reduced).
TEST(Extrinsics, RefusesKeysThatAreNotNamesWithTheLine) {
  TempDir dir("mm4mm_extrinsics");
  writeText(dir.path() / "inner.yaml",
            "T_body_magnetometer: {translation: [0.1, 0, 0.3], quaternion: 0,[ 0, 0, 1]}\n");
  writeText(dir.path() / "top.yaml", "T_body_lidar: {}\n? [1, 2]\n: {}\n");
  for (const char* name : {"inner.yaml", "top.yaml"}) {
    try {
      readExtrinsicsYaml(dir.path() / name);
      FAIL() << name << ": a list as a key accepted";
    } catch (const InputError& e) {
      EXPECT_NE(e.problem().find("key that is not a name"), std::string::npos) << e.what();
      EXPECT_GE(e.line(), 1) << e.what();
    }
  }
}

// ---- the command line ---------------------------------------------------------------------

TEST_F(RosBag, TheCommandLineWritesASessionOrNothing) {
  const fs::path out = dir.path() / "session";
  const test::CliRun ok =
      test::runCli("import --from bag --input " + bag_file.string() +
                   " --odom-topic /odom --cloud-topic " + "/points --mag " + bag_file.string() +
                   " --mag-topic /imu/mag --body-frame base_link " + "--out " + out.string());
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("samples kept"), std::string::npos) << ok.output;
  // The simulated body's origin is on the floor: the scans say so, for merge to use.
  EXPECT_NE(ok.output.find("the scans show the floor 0.00 m below the frame's origin; merge takes "
                           "that height"),
            std::string::npos)
      << ok.output;
  const Session session = readSession(out);
  EXPECT_EQ(session.id, "session");
  EXPECT_EQ(session.scans.size(), session.keyframes.size());

  // The magnetometer's pose as a flag gives the session /tf_static gave.
  const fs::path flagged = dir.path() / "flagged";
  const test::CliRun by_flag = test::runCli(
      "import --from bag --input " + bag_file.string() + " --odom-topic /odom --cloud-topic " +
      "/points --mag " + bag_file.string() + " --mag-topic /imu/mag --mag-extrinsic 0.2 -0.1 0.4 " +
      "0 0 1 0 --earth-field-horizontal 19.5 --earth-field-vertical -45.3 "
      "--frame-height-above-floor 0.45 --out " +
      flagged.string());
  ASSERT_EQ(by_flag.exit_code, 0) << by_flag.output;
  EXPECT_NE(by_flag.output.find("--frame-height-above-floor says 0.45 m, but the scans show the "
                                "floor 0.00 m below the frame's origin"),
            std::string::npos)
      << by_flag.output;
  const Session same = readSession(flagged);
  // The site's Earth field as stated, written to session.yaml for the merge to anchor on.
  ASSERT_TRUE(same.rig.earth_field_vertical_uT.has_value());
  EXPECT_DOUBLE_EQ(*same.rig.earth_field_vertical_uT, -45.3);
  EXPECT_DOUBLE_EQ(same.rig.earth_field_horizontal_uT.value_or(0.0), 19.5);
  EXPECT_FALSE(session.rig.earth_field_vertical_uT.has_value());
  EXPECT_DOUBLE_EQ(same.rig.frame_height_above_floor_m.value_or(0.0), 0.45);
  EXPECT_FALSE(session.rig.frame_height_above_floor_m.has_value());
  ASSERT_EQ(same.magnetometer.size(), session.magnetometer.size());
  EXPECT_LT((same.magnetometer[100].field_body_uT - session.magnetometer[100].field_body_uT).norm(),
            1e-3);
  EXPECT_TRUE(same.rig.magnetometers_body[0].isApprox(session.rig.magnetometers_body[0]));
  const test::CliRun bad_quaternion = test::runCli(
      "import --from bag --input " + bag_file.string() + " --odom-topic /odom --mag " +
      bag_file.string() + " --mag-topic /imu/mag --mag-extrinsic 0 0 0 0 0 2 0 --out " +
      (dir.path() / "q").string());
  EXPECT_EQ(bad_quaternion.exit_code, 2);
  EXPECT_NE(bad_quaternion.output.find("--mag-extrinsic: the quaternion"), std::string::npos)
      << bad_quaternion.output;

  const fs::path failed = dir.path() / "failed";
  const test::CliRun bad = test::runCli("import --from bag --input " + bag_file.string() +
                                        " --odom-topic /odometry --mag " + bag_file.string() +
                                        " --mag-topic /imu/mag --out " + failed.string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("has no topic '/odometry'; its topics: /imu/mag"), std::string::npos)
      << bad.output;
  EXPECT_FALSE(fs::exists(failed));
  const test::CliRun exists =
      test::runCli("import --from bag --input " + bag_file.string() + " --odom-topic /odom --mag " +
                   bag_file.string() + " --mag-topic /imu/mag --out " + out.string());
  EXPECT_EQ(exists.exit_code, 2);
  EXPECT_NE(exists.output.find("--overwrite"), std::string::npos) << exists.output;
  const fs::path precious = dir.path() / "precious";
  writeText(precious / "notes.txt", "not a session");
  const test::CliRun other = test::runCli(
      "import --from bag --input " + bag_file.string() + " --odom-topic /odom --mag " +
      bag_file.string() + " --mag-topic /imu/mag --overwrite --out " + precious.string());
  EXPECT_EQ(other.exit_code, 2);
  EXPECT_TRUE(fs::exists(precious / "notes.txt"));
}

// ---- end to end ---------------------------------------------------------------------------

// Two overlapping corridor sessions of the paper's seven-magnetometer rig, recorded as ROS bags
// (each magnetometer on its own topic, mounted turned about z) and imported, merge as the
// sessions they came from do.
TEST(ImportEndToEnd, BagsOfASimulatedRigMergeAsTheOriginalSessionsDo) {
  sim::SimulationConfig config =
      loadSimulationConfig(fs::path(MM4MM_SOURCE_DIR) / "configs" / "corridor_small.yaml");
  std::vector<Session> originals = sim::simulateSessions(config, 2, 3);
  TempDir dir("mm4mm_import_e2e");
  std::vector<Session> imported;
  for (Session& s : originals) {
    for (StampedPose& pose : s.keyframes) pose.time_s += 1.7e9;
    for (StampedPose& pose : s.odometry) pose.time_s += 1.7e9;
    for (MagnetometerSample& m : s.magnetometer) m.time_s += 1.7e9;
    // The bag's clouds stop a keyframe early; so does the session compared with.
    s.keyframes.pop_back();
    s.scans.pop_back();
    if (s.ground_truth) s.ground_truth->pop_back();
    std::vector<Eigen::Isometry3d> T_base_mag;
    std::vector<std::string> topics;
    for (std::size_t i = 0; i < s.rig.magnetometers_body.size(); ++i) {
      Eigen::Isometry3d T = Eigen::Isometry3d(rotationZ(0.5 * static_cast<double>(i)));
      T.translation() = s.rig.magnetometers_body[i];
      T_base_mag.push_back(T);
      topics.push_back("/mag_" + std::to_string(i));
    }
    const fs::path bag = dir.path() / (s.id + ".bag");
    Session recorded = s;
    recorded.keyframes.push_back(recorded.keyframes.back());  // the last keyframe, unsent
    recorded.keyframes.back().time_s += 1e-3;
    recorded.scans.push_back({});
    writeSessionBag(recorded, bag, s.rig.T_body_lidar, T_base_mag, topics);
    BagLidarOptions lidar_options;
    lidar_options.odometry_topic = "/odom";
    lidar_options.cloud_topic = "/points";
    lidar_options.spacing = {1e-3, 1e-3};
    ImportOptions options;
    options.id = s.id;
    options.T_body_lidar = s.rig.T_body_lidar;
    options.earth_field_horizontal_uT = s.rig.earth_field_horizontal_uT;
    Session session =
        assembleSession(readBagLidar(bag, lidar_options),
                        readBagMagnetometer(bag, topics, std::string("base_link")), options);
    writeSession(session, dir.path() / s.id);
    imported.push_back(readSession(dir.path() / s.id));
    ASSERT_EQ(imported.back().keyframes.size(), s.keyframes.size());
    s.rig.calibrations.clear();
  }
  calibrate(&originals);
  calibrate(&imported);
  const MergeResult expected = mergeSessions(originals, MergeConfig{});
  const MergeResult got = mergeSessions(imported, MergeConfig{});
  ASSERT_TRUE(expected.solution.connected[1]);
  ASSERT_TRUE(got.solution.connected[1]);
  const Eigen::Isometry3d difference =
      expected.solution.T_atlas_session[1].inverse() * got.solution.T_atlas_session[1];
  EXPECT_LT(difference.translation().norm(), 0.02);
  EXPECT_LT(rotationAngle(difference.linear()) * 180.0 / M_PI, 0.1);
}

}  // namespace
}  // namespace mm4mm
