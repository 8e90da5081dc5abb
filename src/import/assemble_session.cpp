#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/import/recording.hpp"
#include "mm4mm/io/input_error.hpp"

namespace mm4mm {
namespace {

// The session writer stores magnetometer times to 1 µs; two samples of one sensor closer than
// that would be written as one time twice, which the session reader refuses.
constexpr double kTimeResolution_s = 1e-6;

std::string seconds(double t) {
  char text[64];
  std::snprintf(text, sizeof text, "%.6f", t);
  return text;
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

void checkKeyframes(const LidarRecording& lidar) {
  if (lidar.keyframes.empty()) throw InputError(lidar.source, 0, "holds no keyframe pose");
  for (std::size_t i = 1; i < lidar.keyframes.size(); ++i) {
    if (!(lidar.keyframes[i].pose.time_s > lidar.keyframes[i - 1].pose.time_s))
      throw InputError(lidar.source, 0,
                       "keyframe " + std::to_string(i) + " at " +
                           seconds(lidar.keyframes[i].pose.time_s) +
                           " s is not later than the one before it: times go backwards");
  }
  if (!lidar.scans_saved) return;
  for (std::size_t i = 0; i < lidar.keyframes.size(); ++i) {
    if (lidar.keyframes[i].scan_body.empty())
      throw InputError(lidar.source, 0,
                       "keyframe " + std::to_string(i) + " at " +
                           seconds(lidar.keyframes[i].pose.time_s) + " s has an empty scan");
  }
}

}  // namespace

bool movedEnough(const Eigen::Isometry3d& last, const Eigen::Isometry3d& pose,
                 const KeyframeSpacing& spacing) {
  const Eigen::Isometry3d delta = last.inverse() * pose;
  return delta.translation().norm() >= spacing.distance_m ||
         rotationAngle(delta.linear()) >= spacing.angle_deg * M_PI / 180.0;
}

std::vector<std::size_t> selectKeyframes(const std::vector<StampedPose>& poses,
                                         const KeyframeSpacing& spacing) {
  std::vector<std::size_t> kept;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (kept.empty() ||
        movedEnough(poses[kept.back()].T_frame_body, poses[i].T_frame_body, spacing))
      kept.push_back(i);
  }
  return kept;
}

double microTeslaPer(FieldUnit unit) {
  switch (unit) {
    case FieldUnit::kTesla:
      return 1e6;
    case FieldUnit::kGauss:
      return 100.0;
    case FieldUnit::kMilliGauss:
      return 0.1;
    case FieldUnit::kMicroTesla:
      return 1.0;
    case FieldUnit::kNanoTesla:
      return 1e-3;
  }
  return 1.0;
}

std::string unitName(FieldUnit unit) {
  switch (unit) {
    case FieldUnit::kTesla:
      return "T";
    case FieldUnit::kGauss:
      return "G";
    case FieldUnit::kMilliGauss:
      return "mG";
    case FieldUnit::kMicroTesla:
      return "uT";
    case FieldUnit::kNanoTesla:
      return "nT";
  }
  return "uT";
}

FieldUnit parseFieldUnit(const std::string& text) {
  for (FieldUnit unit : {FieldUnit::kTesla, FieldUnit::kGauss, FieldUnit::kMilliGauss,
                         FieldUnit::kMicroTesla, FieldUnit::kNanoTesla}) {
    if (text == unitName(unit)) return unit;
  }
  if (text == "µT") return FieldUnit::kMicroTesla;
  throw std::invalid_argument("unknown field unit '" + text + "': use T, G, mG, uT or nT");
}

std::string implausibleFieldMessage(double median_uT, FieldUnit assumed) {
  // Earth's field is 25-65 µT; a robot's own magnetism adds tens to a few hundred µT.
  if (median_uT >= 1.0 && median_uT <= 1000.0) return {};
  const double raw = median_uT / microTeslaPer(assumed);
  std::string likely;
  double best = 1e300;
  for (FieldUnit unit : {FieldUnit::kTesla, FieldUnit::kGauss, FieldUnit::kMilliGauss,
                         FieldUnit::kMicroTesla, FieldUnit::kNanoTesla}) {
    const double candidate = raw * microTeslaPer(unit);
    const double distance = std::abs(std::log(candidate / 50.0));
    if (candidate >= 10.0 && candidate <= 300.0 && distance < best) {
      best = distance;
      likely = unitName(unit);
    }
  }
  char text[256];
  std::snprintf(text, sizeof text,
                "median |B| is %.6g in the numbers read as %s, %.6g uT, where Earth's field is "
                "25-65 uT",
                raw, unitName(assumed).c_str(), median_uT);
  std::string message = text;
  if (!likely.empty()) message += ": the numbers fit " + likely + " (give that unit)";
  return message;
}

Session assembleSession(const LidarRecording& lidar, const MagnetometerRecording& magnetometer,
                        const ImportOptions& options, ImportReport* report) {
  checkKeyframes(lidar);
  if (magnetometer.samples.empty())
    throw InputError(magnetometer.source, 0, "holds no magnetometer sample");

  std::vector<StampedPose> keyframe_poses;
  for (const ImportedKeyframe& keyframe : lidar.keyframes) keyframe_poses.push_back(keyframe.pose);
  const std::vector<StampedPose>& stream = lidar.odometry.empty() ? keyframe_poses : lidar.odometry;
  const double first = stream.front().time_s;
  const double last = stream.back().time_s;
  if (!lidar.odometry.empty() && (keyframe_poses.front().time_s < first - kTimeResolution_s ||
                                  keyframe_poses.back().time_s > last + kTimeResolution_s))
    throw InputError(lidar.source, 0,
                     "the odometry stream (" + seconds(first) + " to " + seconds(last) +
                         " s) does not cover the keyframes (" +
                         seconds(keyframe_poses.front().time_s) + " to " +
                         seconds(keyframe_poses.back().time_s) + " s)");

  Session session;
  session.id = options.id;
  int sensors = 0;
  for (const MagnetometerSample& sample : magnetometer.samples)
    sensors = std::max(sensors, sample.sensor + 1);
  if (options.T_body_magnetometer && sensors > 1)
    throw std::invalid_argument("one T_body_magnetometer given for " + std::to_string(sensors) +
                                " magnetometers in " + magnetometer.source);
  if (!magnetometer.T_body_magnetometers.empty() &&
      magnetometer.T_body_magnetometers.size() != static_cast<std::size_t>(sensors))
    throw std::invalid_argument(magnetometer.source + ": " +
                                std::to_string(magnetometer.T_body_magnetometers.size()) +
                                " sensor poses for " + std::to_string(sensors) + " magnetometers");
  std::vector<Eigen::Isometry3d> T_body_mag(static_cast<std::size_t>(sensors),
                                            Eigen::Isometry3d::Identity());
  if (options.T_body_magnetometer)
    T_body_mag[0] = *options.T_body_magnetometer;
  else if (!magnetometer.T_body_magnetometers.empty())
    T_body_mag = magnetometer.T_body_magnetometers;
  for (const Eigen::Isometry3d& T : T_body_mag)
    session.rig.magnetometers_body.push_back(T.translation());
  session.rig.T_body_lidar = options.T_body_lidar;
  session.rig.earth_field_horizontal_uT = options.earth_field_horizontal_uT;
  session.rig.earth_field_vertical_uT = options.earth_field_vertical_uT;
  session.rig.frame_height_above_floor_m = options.frame_height_above_floor_m;

  ImportReport counts;
  std::vector<MagnetometerSample> samples = magnetometer.samples;
  std::stable_sort(samples.begin(), samples.end(), [](const auto& a, const auto& b) {
    return a.time_s < b.time_s || (a.time_s == b.time_s && a.sensor < b.sensor);
  });
  const double mag_first = samples.front().time_s + options.clock_offset_s;
  const double mag_last = samples.back().time_s + options.clock_offset_s;
  if (mag_last < first || mag_first > last)
    throw InputError(magnetometer.source, 0,
                     "no common time with the poses of " + lidar.source + ": magnetometer " +
                         seconds(mag_first) + " to " + seconds(mag_last) + " s (clock offset " +
                         seconds(options.clock_offset_s) + " s applied), poses " + seconds(first) +
                         " to " + seconds(last) +
                         " s; are both on one clock? (--clock-offset shifts the magnetometer)");

  std::vector<double> magnitudes;
  std::vector<double> last_time(static_cast<std::size_t>(sensors), -1e300);
  for (MagnetometerSample sample : samples) {
    sample.time_s += options.clock_offset_s;
    if (sample.time_s < first) {
      ++counts.samples_before_poses;
      continue;
    }
    if (sample.time_s > last) {
      ++counts.samples_after_poses;
      continue;
    }
    double& previous = last_time[static_cast<std::size_t>(sample.sensor)];
    if (sample.time_s - previous < kTimeResolution_s) continue;
    previous = sample.time_s;
    sample.field_body_uT =
        T_body_mag[static_cast<std::size_t>(sample.sensor)].linear() * sample.field_body_uT;
    magnitudes.push_back(sample.field_body_uT.norm());
    session.magnetometer.push_back(sample);
  }
  counts.samples_kept = session.magnetometer.size();
  counts.median_field_uT = median(magnitudes);
  if (session.magnetometer.empty())
    throw InputError(magnetometer.source, 0, "no magnetometer sample within the poses' time span");
  const std::string implausible =
      implausibleFieldMessage(counts.median_field_uT, magnetometer.read_as);
  if (!implausible.empty()) throw InputError(magnetometer.source, 0, implausible);

  session.odometry = lidar.odometry;
  for (const ImportedKeyframe& keyframe : lidar.keyframes) {
    session.keyframes.push_back(keyframe.pose);
    if (lidar.scans_saved) {
      session.scans.push_back(keyframe.scan_body);
      counts.scan_points += keyframe.scan_body.size();
    }
  }
  counts.keyframes = session.keyframes.size();
  if (report) *report = counts;
  return session;
}

}  // namespace mm4mm
