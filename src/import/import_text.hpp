#pragma once
// Internal to src/import: what the importers share. Token streams over another tool's text files
// (with line numbers for the error), matrices printed by Eigen's operator<<, numbered files in a
// directory, and clouds moved between frames. Not installed.

#include <Eigen/Geometry>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm::import_detail {

/// The whitespace-separated tokens of a text file, each with its 1-based line: the other tools
/// write matrices as Eigen's operator<< does (rows on lines, padded columns), which their own
/// loaders read token by token, and so does this.
class TokenStream {
 public:
  /// Reads `file` whole; InputError (file, 0, ...) when it is missing or a directory.
  explicit TokenStream(const std::filesystem::path& file);

  bool done() const { return next_ >= tokens_.size(); }
  /// The line of the next token (of the last one at the end).
  int line() const;
  const std::string& file() const { return file_; }
  /// The next token; InputError "ends early, where <what> was expected" at the end.
  const std::string& word(const std::string& what);
  /// The next token, which must be `expected`.
  void expect(const std::string& expected);
  double number(const std::string& what);
  /// `rows` x `cols` numbers, row after row.
  Eigen::MatrixXd matrix(int rows, int cols, const std::string& what);
  /// The next token without consuming it (empty at the end).
  std::string peek() const;

 private:
  struct Token {
    std::string text;
    int line;
  };
  std::string file_;
  std::vector<Token> tokens_;
  std::size_t next_ = 0;
};

/// The rigid motion of a homogeneous 4x4 (or the top 3x4) matrix. The rotation is
/// re-orthonormalised (the tools print 6 significant digits); InputError at `file`:`line` when it
/// is not within 1e-3 of a rotation or the last row is not 0 0 0 1.
Eigen::Isometry3d rigidFromMatrix(const Eigen::MatrixXd& M, const std::string& file, int line);

/// The files (or directories) of `dir` whose names `index_of` maps to a number, sorted by that
/// number; InputError when `dir` is missing, or two names give one number.
std::vector<std::pair<long, std::filesystem::path>> numberedEntries(
    const std::filesystem::path& dir,
    const std::function<std::optional<long>(const std::string&)>& index_of);

/// The subdirectories of `dir` named by six digits (000000/, 000001/, ...: GLIM's submaps and
/// hdl_graph_slam's keyframes, both "%06d"), sorted by number.
std::vector<std::pair<long, std::filesystem::path>> sixDigitDirectories(
    const std::filesystem::path& dir);

/// The number of a name made of `prefix`, decimal digits and `suffix` ("000012.pcd",
/// "scans_3.pcd"), none otherwise.
std::optional<long> numberBetween(const std::string& name, const std::string& prefix,
                                  const std::string& suffix);

/// `cloud` with every point mapped by `T`.
PointCloud transformed(const PointCloud& cloud, const Eigen::Isometry3d& T);

/// TUM lines `t x y z qx qy qz qw` (blank lines and '#' comments skipped), where a line repeating
/// the previous time is dropped and counted in `repeated` (tools that write one pose per frame
/// may write a frame shared by two segments twice). InputError with file and line on a line
/// without 8 numbers, times going backwards, or fewer than two poses.
std::vector<StampedPose> readTumLenient(const std::filesystem::path& file, std::size_t* repeated);

/// A rigid transform from translation and quaternion (x y z w), normalised.
Eigen::Isometry3d poseFromTq(const Eigen::Vector3d& t, const Eigen::Vector4d& q_xyzw);

}  // namespace mm4mm::import_detail
