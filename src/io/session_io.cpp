#include "mm4mm/io/session_io.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <exception>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "directory_swap.hpp"
#include "magnetometer_csv.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/pcd_io.hpp"
#include "mm4mm/io/tum_io.hpp"
#include "session_yaml.hpp"
#include "text_io.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;

using io_detail::formatMagnetometerCsv;
using io_detail::formatNumber;
using io_detail::formatSessionYaml;
using io_detail::isValidId;
using io_detail::readMagnetometerCsv;
using io_detail::readSessionYaml;
using io_detail::siblingPath;
using io_detail::writeTextFile;

// Ground truth often comes from another exporter than the odometry; times printed with different
// precision still name the same keyframe.
constexpr double kTimeMatchTolerance_s = 1e-6;

bool isRotation(const Eigen::Matrix3d& R) {
  return R.allFinite() && (R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-6) &&
         R.determinant() > 0.0;
}

// ---- scans/ and ground_truth.txt ----------------------------------------------------------

std::string scanName(std::size_t index) {
  std::array<char, 32> buffer{};
  std::snprintf(buffer.data(), buffer.size(), "%06zu.pcd", index);
  return buffer.data();
}

std::optional<std::size_t> scanIndex(const std::string& name) {
  if (name.size() != 10 || name.compare(6, 4, ".pcd") != 0) return std::nullopt;
  std::size_t index = 0;
  const auto result = std::from_chars(name.data(), name.data() + 6, index);
  if (result.ec != std::errc() || result.ptr != name.data() + 6) return std::nullopt;
  return index;
}

void checkScanFiles(const fs::path& scans_dir, std::size_t keyframes) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(scans_dir))
    names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());  // report the same file whatever the directory order
  const std::string count = "poses.txt has " + std::to_string(keyframes) + " keyframes";
  std::vector<bool> present(keyframes, false);
  for (const std::string& name : names) {
    if (name.front() == '.') continue;  // hidden files that file managers and editors leave
    const std::optional<std::size_t> index = scanIndex(name);
    if (!index || *index >= keyframes)
      throw InputError((scans_dir / name).string(), 0,
                       "unexpected file: " + count + ", so scans/ holds 000000.pcd to " +
                           scanName(keyframes - 1) + " only");
    present[*index] = true;
  }
  for (std::size_t i = 0; i < keyframes; ++i) {
    if (!present[i])
      throw InputError((scans_dir / scanName(i)).string(), 0,
                       "missing: " + count + ", one scan each");
  }
}

// Runs `task(i)` for i in [0, n) in parallel and rethrows the failure of the lowest index, so the
// reported error does not depend on thread scheduling.
template <typename Task>
void parallelForFirstError(std::size_t n, Task&& task) {
  std::vector<std::exception_ptr> errors(n);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
    try {
      task(i);
    } catch (...) {
      errors[i] = std::current_exception();
    }
  });
  for (const std::exception_ptr& error : errors) {
    if (error) std::rethrow_exception(error);
  }
}

std::vector<PointCloud> readScans(const fs::path& scans_dir, std::size_t keyframes) {
  if (!fs::exists(scans_dir)) return {};  // magnetic-only session
  if (!fs::is_directory(scans_dir))
    throw InputError(scans_dir.string(), 0, "is not a directory of NNNNNN.pcd scans");
  checkScanFiles(scans_dir, keyframes);
  std::vector<PointCloud> scans(keyframes);
  parallelForFirstError(keyframes,
                        [&](std::size_t i) { scans[i] = readPcd(scans_dir / scanName(i)); });
  return scans;
}

std::optional<std::vector<StampedPose>> readGroundTruth(const fs::path& file,
                                                        const std::vector<StampedPose>& keyframes) {
  if (!fs::exists(file)) return std::nullopt;
  std::vector<int> lines;
  std::vector<StampedPose> truth = readTumPoses(file, &lines);
  if (truth.size() != keyframes.size())
    throw InputError(file.string(), 0,
                     "has " + std::to_string(truth.size()) + " poses but poses.txt has " +
                         std::to_string(keyframes.size()) +
                         "; ground truth needs one per keyframe");
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (std::abs(truth[i].time_s - keyframes[i].time_s) > kTimeMatchTolerance_s)
      throw InputError(file.string(), lines[i],
                       "time " + formatNumber(truth[i].time_s) + " differs from keyframe " +
                           std::to_string(i) + "'s time " + formatNumber(keyframes[i].time_s) +
                           " in poses.txt");
  }
  return truth;
}

// odometry.txt: the odometry's full pose stream. It places the magnetometer samples, so it must
// cover the keyframes' time span.
std::vector<StampedPose> readOdometryStream(const fs::path& file,
                                            const std::vector<StampedPose>& keyframes) {
  if (!fs::exists(file)) return {};
  std::vector<StampedPose> stream = readTumPoses(file);
  if (stream.size() < 2) throw InputError(file.string(), 0, "needs at least two poses");
  if (!keyframes.empty() &&
      (stream.front().time_s > keyframes.front().time_s + kTimeMatchTolerance_s ||
       stream.back().time_s < keyframes.back().time_s - kTimeMatchTolerance_s))
    throw InputError(file.string(), 0,
                     "covers " + formatNumber(stream.front().time_s) + " to " +
                         formatNumber(stream.back().time_s) +
                         " s, but the keyframes of poses.txt span " +
                         formatNumber(keyframes.front().time_s) + " to " +
                         formatNumber(keyframes.back().time_s) + " s");
  return stream;
}

std::optional<std::vector<MagnetometerCalibration>> readTrueCalibrationIfAny(
    const fs::path& file, std::size_t magnetometers) {
  if (!fs::exists(file)) return std::nullopt;
  return io_detail::readTrueCalibration(file, magnetometers);
}

// ---- writing ------------------------------------------------------------------------------

void checkSessionForWriting(const Session& session) {
  const auto fail = [](const std::string& problem) {
    throw std::invalid_argument("writeSession: " + problem);
  };
  if (!isValidId(session.id)) fail("id '" + session.id + "' is not usable as a file name");
  if (session.rig.magnetometers_body.empty()) fail("the rig has no magnetometers");
  for (const Eigen::Vector3d& p : session.rig.magnetometers_body)
    if (!p.allFinite()) fail("a magnetometer position is not finite");
  if (!session.rig.T_body_lidar.translation().allFinite() ||
      !isRotation(session.rig.T_body_lidar.linear()))
    fail("T_body_lidar is not a rigid transform");
  if (session.keyframes.empty()) fail("no keyframes");
  const std::size_t sensors = session.rig.magnetometers_body.size();
  if (!session.rig.calibrations.empty() && session.rig.calibrations.size() != sensors)
    fail("the rig states calibrations for " + std::to_string(session.rig.calibrations.size()) +
         " of its " + std::to_string(sensors) + " magnetometers; need one entry per sensor");
  if (session.true_calibration && session.true_calibration->size() != sensors)
    fail("true calibrations for " + std::to_string(session.true_calibration->size()) + " of " +
         std::to_string(sensors) + " magnetometers");
  if (!session.odometry.empty() &&
      (session.odometry.front().time_s > session.keyframes.front().time_s ||
       session.odometry.back().time_s < session.keyframes.back().time_s))
    fail("the odometry stream does not cover the keyframes' time span");
  if (session.hasScans() && session.scans.size() != session.keyframes.size())
    fail(std::to_string(session.scans.size()) + " scans for " +
         std::to_string(session.keyframes.size()) + " keyframes; need one per keyframe or none");
  if (!session.ground_truth) return;
  const std::vector<StampedPose>& truth = *session.ground_truth;
  if (truth.size() != session.keyframes.size())
    fail(std::to_string(truth.size()) + " ground-truth poses for " +
         std::to_string(session.keyframes.size()) + " keyframes");
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (!(std::abs(truth[i].time_s - session.keyframes[i].time_s) <= kTimeMatchTolerance_s))
      fail("ground-truth pose " + std::to_string(i) + " has another time than its keyframe");
  }
}

void writeScans(const fs::path& scans_dir, const std::vector<PointCloud>& scans) {
  fs::create_directory(scans_dir);
  parallelForFirstError(scans.size(),
                        [&](std::size_t i) { writePcd(scans_dir / scanName(i), scans[i]); });
}

}  // namespace

Session readSession(const fs::path& dir, SessionParts parts) {
  if (!fs::exists(dir)) throw InputError(dir.string(), 0, "session directory not found");
  if (!fs::is_directory(dir))
    throw InputError(dir.string(), 0,
                     "not a directory (a session is a directory with session.yaml, poses.txt "
                     "and magnetometer.csv)");
  Session session;
  readSessionYaml(dir / "session.yaml", &session);
  session.keyframes = readTumPoses(dir / "poses.txt");
  session.odometry = readOdometryStream(dir / "odometry.txt", session.keyframes);
  session.ground_truth = readGroundTruth(dir / "ground_truth.txt", session.keyframes);
  session.true_calibration = readTrueCalibrationIfAny(dir / "ground_truth_magnetometers.yaml",
                                                      session.rig.magnetometers_body.size());
  if (parts == SessionParts::kPoses) return session;
  session.magnetometer = readMagnetometerCsv(
      dir / "magnetometer.csv", static_cast<int>(session.rig.magnetometers_body.size()));
  session.scans = readScans(dir / "scans", session.keyframes.size());
  return session;
}

void writeSession(const Session& session, const fs::path& dir) {
  if (dir.empty()) throw std::invalid_argument("writeSession: empty directory name");
  checkSessionForWriting(session);
  const std::string yaml = formatSessionYaml(session);
  const std::string csv = formatMagnetometerCsv(
      session.magnetometer, static_cast<int>(session.rig.magnetometers_body.size()));

  // Absolute and without a trailing '/', so that the siblings land next to the session.
  fs::path target = fs::absolute(dir).lexically_normal();
  if (!target.has_filename()) target = target.parent_path();
  const fs::path staged = siblingPath(target, ".partial");
  fs::create_directories(target.parent_path());
  io_detail::removeStaleStaging(target, ".partial");
  fs::remove_all(staged);
  fs::create_directory(staged);
  try {
    writeTextFile(staged / "session.yaml", yaml);
    writeTumPoses(staged / "poses.txt", session.keyframes);
    if (!session.odometry.empty()) writeTumPoses(staged / "odometry.txt", session.odometry);
    if (session.ground_truth) writeTumPoses(staged / "ground_truth.txt", *session.ground_truth);
    if (session.true_calibration)
      writeTextFile(staged / "ground_truth_magnetometers.yaml",
                    io_detail::formatTrueCalibration(*session.true_calibration));
    writeTextFile(staged / "magnetometer.csv", csv);
    if (session.hasScans()) writeScans(staged / "scans", session.scans);
    // Flushed before the swap, and swapped in one rename: killed or cut off at any moment,
    // `target` holds the old session or the whole new one.
    io_detail::syncTree(staged);
    fs::path previous = target;
    previous += ".previous";
    io_detail::swapIntoPlace(staged, target, previous);
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(staged, ignored);
    throw;
  }
}

}  // namespace mm4mm
