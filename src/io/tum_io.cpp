#include "mm4mm/io/tum_io.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "mm4mm/io/input_error.hpp"
#include "text_io.hpp"

namespace mm4mm {
namespace {

using io_detail::splitWhitespace;

using io_detail::appendFixed;
using io_detail::forEachLine;
using io_detail::formatNumber;
using io_detail::parseFiniteNumber;
using io_detail::readWholeFile;
using io_detail::writeFileAtomically;

constexpr double kMaxCoordinate_m = 1e6;
// Files written with 6 or 7 digits still pass; a quaternion further off than this is not a
// rounding artefact but a wrong column order or a broken exporter.
constexpr double kQuaternionNormTolerance = 1e-3;
constexpr std::array<const char*, 8> kColumns = {"t", "x", "y", "z", "qx", "qy", "qz", "qw"};

class LineParser {
 public:
  LineParser(const std::filesystem::path& file, int line) : file_(file.string()), line_(line) {}

  double number(std::string_view token, int column) const {
    return parseFiniteNumber(token, kColumns[column], file_, line_);
  }

  StampedPose pose(std::string_view text) const {
    const std::vector<std::string_view> tokens = splitWhitespace(text);
    if (tokens.size() != kColumns.size())
      fail("expected 8 numbers (t x y z qx qy qz qw), got " + std::to_string(tokens.size()));
    std::array<double, 8> v{};
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = number(tokens[i], static_cast<int>(i));
    for (int i = 1; i <= 3; ++i) {
      if (std::abs(v[i]) > kMaxCoordinate_m)
        fail(std::string(kColumns[i]) + " = " + formatNumber(v[i]) +
             " m is beyond 1e6 m, not a plausible coordinate");
    }
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    const double norm = q.norm();
    if (std::abs(norm - 1.0) > kQuaternionNormTolerance)
      fail("quaternion (qx qy qz qw) has norm " + formatNumber(norm) + ", not 1");
    q.coeffs() /= norm;
    StampedPose pose;
    pose.time_s = v[0];
    pose.T_frame_body.linear() = q.toRotationMatrix();
    pose.T_frame_body.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    return pose;
  }

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(file_, line_, problem);
  }

 private:
  std::string file_;
  int line_;
};

void checkPoseForWriting(const StampedPose& pose, std::size_t index) {
  const std::string where = "writeTumPoses: pose " + std::to_string(index) + " ";
  if (!std::isfinite(pose.time_s) || !pose.T_frame_body.matrix().allFinite())
    throw std::invalid_argument(where + "is not finite");
  if (pose.T_frame_body.translation().cwiseAbs().maxCoeff() > kMaxCoordinate_m)
    throw std::invalid_argument(where + "lies beyond 1e6 m");
  const Eigen::Matrix3d R = pose.T_frame_body.linear();
  if (!(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || R.determinant() <= 0.0)
    throw std::invalid_argument(where + "has a rotation part that is not a rotation");
}

}  // namespace

std::vector<StampedPose> readTumPoses(const std::filesystem::path& file,
                                      std::vector<int>* line_numbers) {
  const std::string content = readWholeFile(file);
  std::vector<StampedPose> poses;
  if (line_numbers) line_numbers->clear();
  forEachLine(content, [&](int line, std::string_view text) {
    if (text.empty() || text.front() == '#') return;
    const LineParser parser(file, line);
    StampedPose pose = parser.pose(text);
    if (!poses.empty() && !(pose.time_s > poses.back().time_s))
      parser.fail("time " + formatNumber(pose.time_s) + " is not after the previous line's " +
                  formatNumber(poses.back().time_s));
    poses.push_back(pose);
    if (line_numbers) line_numbers->push_back(line);
  });
  if (poses.empty()) throw InputError(file.string(), 0, "no poses (empty file)");
  return poses;
}

void writeTumPoses(const std::filesystem::path& file, const std::vector<StampedPose>& poses) {
  if (poses.empty()) throw std::invalid_argument("writeTumPoses: no poses");
  std::string content = "# t x y z qx qy qz qw\n";
  content.reserve(poses.size() * 160);
  std::string previous_time;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const StampedPose& pose = poses[i];
    checkPoseForWriting(pose, i);
    // Times are printed to 1 ns; two poses closer than that would read back as equal times.
    std::string time;
    appendFixed(pose.time_s, 9, &time);
    if (i > 0 && !(pose.time_s > poses[i - 1].time_s && time != previous_time))
      throw std::invalid_argument("writeTumPoses: time of pose " + std::to_string(i) +
                                  " is not at least 1 ns after the previous pose's");
    previous_time = time;
    content += time;
    const Eigen::Quaterniond q(pose.T_frame_body.linear());
    const Eigen::Vector3d& t = pose.T_frame_body.translation();
    for (double value : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) {
      content += ' ';
      content += formatNumber(value);
    }
    content += '\n';
  }
  writeFileAtomically(file, content);
}

}  // namespace mm4mm
