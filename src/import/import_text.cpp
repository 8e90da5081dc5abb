#include "import_text.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <map>

#include "../io/text_io.hpp"
#include "mm4mm/io/input_error.hpp"

namespace mm4mm::import_detail {

namespace fs = std::filesystem;

TokenStream::TokenStream(const fs::path& file) : file_(file.string()) {
  const std::string content = io_detail::readWholeFile(file);
  io_detail::forEachLine(content, [this](int line, std::string_view text) {
    for (std::string_view token : io_detail::splitWhitespace(text))
      tokens_.push_back({std::string(token), line});
  });
}

int TokenStream::line() const {
  if (tokens_.empty()) return 0;
  return tokens_[std::min(next_, tokens_.size() - 1)].line;
}

const std::string& TokenStream::word(const std::string& what) {
  if (done()) throw InputError(file_, line(), "ends early, where " + what + " was expected");
  return tokens_[next_++].text;
}

void TokenStream::expect(const std::string& expected) {
  const int at = line();
  const std::string& got = word("'" + expected + "'");
  if (got != expected)
    throw InputError(file_, at, "expected '" + expected + "', found '" + got + "'");
}

double TokenStream::number(const std::string& what) {
  const int at = line();
  return io_detail::parseFiniteNumber(word(what), what, file_, at);
}

Eigen::MatrixXd TokenStream::matrix(int rows, int cols, const std::string& what) {
  Eigen::MatrixXd M(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) M(r, c) = number(what);
  return M;
}

std::string TokenStream::peek() const { return done() ? std::string() : tokens_[next_].text; }

Eigen::Isometry3d rigidFromMatrix(const Eigen::MatrixXd& M, const std::string& file, int line) {
  const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
  if (M.rows() == 4 && !M.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1), 1e-6))
    throw InputError(file, line, "a pose matrix's last row is not 0 0 0 1");
  // Printed with 6 significant digits, a rotation is off by up to ~1e-6 per entry; project it
  // back onto the rotations (the nearest one, by SVD) rather than carry a slightly skewed frame.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d nearest = svd.matrixU() * svd.matrixV().transpose();
  if (nearest.determinant() < 0.0 || !((R - nearest).cwiseAbs().maxCoeff() < 1e-3))
    throw InputError(file, line, "a pose matrix's rotation part is not a rotation");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = nearest;
  T.translation() = M.block<3, 1>(0, 3);
  if (T.translation().cwiseAbs().maxCoeff() > 1e6)
    throw InputError(file, line, "a pose lies beyond 1e6 m; not a position in metres");
  return T;
}

std::optional<long> numberBetween(const std::string& name, const std::string& prefix,
                                  const std::string& suffix) {
  if (name.size() <= prefix.size() + suffix.size()) return std::nullopt;
  if (name.compare(0, prefix.size(), prefix) != 0) return std::nullopt;
  if (name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0) return std::nullopt;
  const char* begin = name.data() + prefix.size();
  const char* end = name.data() + name.size() - suffix.size();
  if (!std::all_of(begin, end, [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
    return std::nullopt;
  long value = 0;
  const auto result = std::from_chars(begin, end, value);
  if (result.ec != std::errc() || result.ptr != end) return std::nullopt;
  return value;
}

std::vector<std::pair<long, fs::path>> numberedEntries(
    const fs::path& dir, const std::function<std::optional<long>(const std::string&)>& index_of) {
  if (!fs::is_directory(dir)) throw InputError(dir.string(), 0, "directory not found");
  std::map<long, fs::path> entries;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    const std::optional<long> index = index_of(name);
    if (!index) continue;
    const auto [it, inserted] = entries.emplace(*index, entry.path());
    if (!inserted)
      throw InputError(dir.string(), 0,
                       "holds two entries numbered " + std::to_string(*index) + ": " +
                           it->second.filename().string() + " and " + name);
  }
  return {entries.begin(), entries.end()};
}

std::vector<std::pair<long, fs::path>> sixDigitDirectories(const fs::path& dir) {
  return numberedEntries(dir, [&](const std::string& name) {
    const std::optional<long> n = numberBetween(name, "", "");
    return name.size() == 6 && n && fs::is_directory(dir / name) ? n : std::nullopt;
  });
}

PointCloud transformed(const PointCloud& cloud, const Eigen::Isometry3d& T) {
  const Eigen::Isometry3f Tf = T.cast<float>();
  PointCloud out;
  out.reserve(cloud.size());
  for (const Eigen::Vector3f& p : cloud) out.push_back(Tf * p);
  return out;
}

std::vector<StampedPose> readTumLenient(const fs::path& file, std::size_t* repeated) {
  const std::string content = io_detail::readWholeFile(file);
  std::vector<StampedPose> poses;
  const std::string name = file.string();
  io_detail::forEachLine(content, [&](int line, std::string_view text) {
    if (text.empty() || text.front() == '#') return;
    const std::vector<std::string_view> tokens = io_detail::splitWhitespace(text);
    if (tokens.size() != 8)
      throw InputError(name, line,
                       "a TUM line needs 8 numbers (t x y z qx qy qz qw), found " +
                           std::to_string(tokens.size()));
    double v[8];
    for (int k = 0; k < 8; ++k) v[k] = io_detail::parseFiniteNumber(tokens[k], "value", name, line);
    StampedPose pose;
    pose.time_s = v[0];
    const Eigen::Vector4d q(v[4], v[5], v[6], v[7]);
    if (std::abs(q.norm() - 1.0) > 1e-3)
      throw InputError(name, line, "the quaternion's norm is not 1");
    pose.T_frame_body = poseFromTq(Eigen::Vector3d(v[1], v[2], v[3]), q);
    if (!poses.empty() && pose.time_s <= poses.back().time_s) {
      if (pose.time_s < poses.back().time_s) throw InputError(name, line, "times go backwards");
      ++*repeated;
      return;
    }
    poses.push_back(pose);
  });
  if (poses.size() < 2) throw InputError(name, 0, "holds fewer than two poses");
  return poses;
}

Eigen::Isometry3d poseFromTq(const Eigen::Vector3d& t, const Eigen::Vector4d& q_xyzw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(q_xyzw[3], q_xyzw[0], q_xyzw[1], q_xyzw[2])
                   .normalized()
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

}  // namespace mm4mm::import_detail
