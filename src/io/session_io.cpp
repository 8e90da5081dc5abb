#include "mm4mm/io/session_io.hpp"

#include <tbb/parallel_for.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/pcd_io.hpp"
#include "mm4mm/io/tum_io.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;

// The Earth's field is about 25–65 µT and steel nearby adds tens of µT; a reading above this is
// a unit mix-up (nT, gauss) or a broken sensor, not a field.
constexpr double kMaxField_uT = 1000.0;
constexpr double kQuaternionNormTolerance = 1e-3;
// Ground truth often comes from another exporter than the odometry; times printed with different
// precision still name the same keyframe.
constexpr double kTimeMatchTolerance_s = 1e-6;
constexpr std::array<const char*, 5> kCsvColumns = {"t", "sensor", "bx", "by", "bz"};

std::string formatNumber(double value) {
  std::array<char, 32> buffer{};
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  return std::string(buffer.data(), result.ptr);
}

void appendFixed(double value, int precision, std::string* out) {
  std::array<char, 64> buffer{};
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value,
                                    std::chars_format::fixed, precision);
  out->append(buffer.data(), result.ptr);
}

std::string_view trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t\r\v\f");
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(" \t\r\v\f");
  return text.substr(first, last - first + 1);
}

std::string readWholeFile(const fs::path& file, const std::string& why_needed) {
  if (!fs::exists(file)) throw InputError(file.string(), 0, "file not found; " + why_needed);
  if (fs::is_directory(file)) throw InputError(file.string(), 0, "is a directory, not a file");
  std::ifstream stream(file, std::ios::binary);
  if (!stream)
    throw InputError(file.string(), 0, std::string("cannot open: ") + std::strerror(errno));
  std::ostringstream content;
  content << stream.rdbuf();
  return content.str();
}

void writeTextFile(const fs::path& file, const std::string& content) {
  std::FILE* stream = std::fopen(file.c_str(), "wb");
  if (!stream)
    throw std::runtime_error("cannot write " + file.string() + ": " + std::strerror(errno));
  const bool written = std::fwrite(content.data(), 1, content.size(), stream) == content.size();
  if (std::fclose(stream) != 0 || !written)
    throw std::runtime_error("cannot write " + file.string() + ": " + std::strerror(errno));
}

// Calls `visit(line_number, trimmed_text)` for every line, numbering from 1.
template <typename Visitor>
void forEachLine(const std::string& content, Visitor&& visit) {
  std::size_t begin = 0;
  for (int line = 1; begin < content.size(); ++line) {
    const std::size_t end = std::min(content.find('\n', begin), content.size());
    visit(line, trim(std::string_view(content).substr(begin, end - begin)));
    begin = end + 1;
  }
}

// The id names files in an atlas (trajectories/<id>.txt).
bool isValidId(const std::string& id) {
  return !id.empty() && id != "." && id != ".." &&
         id.find_first_of(std::string("/\\\n\r\0", 5)) == std::string::npos;
}

bool isRotation(const Eigen::Matrix3d& R) {
  return R.allFinite() && (R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-6) &&
         R.determinant() > 0.0;
}

// ---- session.yaml ---------------------------------------------------------------------------

class YamlReader {
 public:
  explicit YamlReader(const fs::path& file) : file_(file.string()) {}

  YAML::Node load() const {
    const std::string content =
        readWholeFile(file_, "every session needs its id and magnetometer positions there");
    try {
      return YAML::Load(content);
    } catch (const YAML::Exception& e) {
      throw InputError(file_, e.mark.is_null() ? 0 : e.mark.line + 1, e.msg);
    }
  }

  [[noreturn]] void fail(const YAML::Node& at, const std::string& problem) const {
    const YAML::Mark mark = at.Mark();
    throw InputError(file_, mark.is_null() ? 0 : mark.line + 1, problem);
  }

  YAML::Node required(const YAML::Node& root, const char* key) const {
    const YAML::Node node = root[key];
    if (!node) throw InputError(file_, 0, std::string("missing required key '") + key + "'");
    return node;
  }

  template <int N>
  Eigen::Matrix<double, N, 1> vector(const YAML::Node& node, const std::string& key,
                                     const char* shape) const {
    const std::string expected =
        "'" + key + "' must be a list of " + std::to_string(N) + " numbers " + shape;
    if (!node.IsSequence() || node.size() != N) fail(node, expected);
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i) {
      try {
        v[i] = node[i].as<double>();
      } catch (const YAML::Exception&) {
        fail(node[i], expected);
      }
    }
    if (!v.allFinite()) fail(node, "'" + key + "' is not finite");
    return v;
  }

 private:
  std::string file_;
};

Eigen::Isometry3d readLidarPose(const YAML::Node& lidar, const YamlReader& reader) {
  Eigen::Isometry3d T_body_lidar = Eigen::Isometry3d::Identity();
  if (!lidar) return T_body_lidar;
  if (!lidar.IsMap()) reader.fail(lidar, "'lidar' must be a map with translation and quaternion");
  if (const YAML::Node t = lidar["translation"])
    T_body_lidar.translation() = reader.vector<3>(t, "lidar.translation", "[x, y, z]");
  if (const YAML::Node q_node = lidar["quaternion"]) {
    const Eigen::Vector4d xyzw = reader.vector<4>(q_node, "lidar.quaternion", "[x, y, z, w]");
    if (std::abs(xyzw.norm() - 1.0) > kQuaternionNormTolerance)
      reader.fail(q_node, "'lidar.quaternion' has norm " + formatNumber(xyzw.norm()) + ", not 1");
    const Eigen::Quaterniond q(xyzw[3], xyzw[0], xyzw[1], xyzw[2]);
    T_body_lidar.linear() = q.normalized().toRotationMatrix();
  }
  return T_body_lidar;
}

void readSessionYaml(const fs::path& file, Session* session) {
  const YamlReader reader(file);
  const YAML::Node root = reader.load();
  if (!root.IsMap()) {
    throw InputError(file.string(), 0,
                     "must be a YAML map with the keys 'id', 'magnetometers' and 'lidar'");
  }
  const YAML::Node id = reader.required(root, "id");
  if (!id.IsScalar()) reader.fail(id, "'id' must be a string");
  session->id = id.Scalar();
  if (!isValidId(session->id))
    reader.fail(id, "id '" + session->id + "' must be usable as a file name (not empty, no '/')");

  const YAML::Node magnetometers = reader.required(root, "magnetometers");
  if (!magnetometers.IsSequence() || magnetometers.size() == 0)
    reader.fail(magnetometers, "'magnetometers' must be a list of at least one [x, y, z]");
  session->rig.magnetometers_body.clear();
  for (std::size_t i = 0; i < magnetometers.size(); ++i) {
    const std::string key = "magnetometers[" + std::to_string(i) + "]";
    session->rig.magnetometers_body.push_back(reader.vector<3>(magnetometers[i], key, "[x, y, z]"));
  }
  session->rig.T_body_lidar = readLidarPose(root["lidar"], reader);
}

std::string formatSessionYaml(const Session& session) {
  const auto list = [](YAML::Emitter& out, std::initializer_list<double> values) {
    // Shortest round-trip text; yaml-cpp would print 0.3 as 0.29999999999999999.
    out << YAML::Flow << YAML::BeginSeq;
    for (double value : values) out << formatNumber(value);
    out << YAML::EndSeq;
  };
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "id" << YAML::Value << session.id;
  out << YAML::Key << "magnetometers" << YAML::Value << YAML::BeginSeq;
  for (const Eigen::Vector3d& p : session.rig.magnetometers_body) list(out, {p.x(), p.y(), p.z()});
  out << YAML::EndSeq;
  const Eigen::Vector3d t = session.rig.T_body_lidar.translation();
  const Eigen::Quaterniond q(session.rig.T_body_lidar.linear());
  out << YAML::Key << "lidar" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "translation" << YAML::Value;
  list(out, {t.x(), t.y(), t.z()});
  out << YAML::Key << "quaternion" << YAML::Value;
  list(out, {q.x(), q.y(), q.z(), q.w()});
  out << YAML::EndMap << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

// ---- magnetometer.csv -----------------------------------------------------------------------

// Splits at commas into `fields` (at most 5 kept); returns the number of fields on the line.
std::size_t splitCsv(std::string_view row, std::array<std::string_view, 5>* fields) {
  std::size_t count = 0;
  std::size_t begin = 0;
  while (true) {
    const std::size_t comma = row.find(',', begin);
    const std::size_t end = comma == std::string_view::npos ? row.size() : comma;
    if (count < fields->size()) (*fields)[count] = trim(row.substr(begin, end - begin));
    ++count;
    if (comma == std::string_view::npos) return count;
    begin = comma + 1;
  }
}

class CsvRowParser {
 public:
  CsvRowParser(const fs::path& file, int sensors) : file_(file.string()), sensors_(sensors) {}

  MagnetometerSample parse(std::string_view row, int line) {
    line_ = line;
    std::array<std::string_view, 5> fields;
    const std::size_t count = splitCsv(row, &fields);
    if (count != fields.size())
      fail("expected 5 values (t,sensor,bx,by,bz), got " + std::to_string(count));
    MagnetometerSample sample;
    sample.time_s = number(fields[0], kCsvColumns[0]);
    sample.sensor = sensor(fields[1]);
    for (int k = 0; k < 3; ++k) sample.field_body_uT[k] = number(fields[2 + k], kCsvColumns[2 + k]);
    const double magnitude = sample.field_body_uT.norm();
    if (magnitude > kMaxField_uT)
      fail("field magnitude " + formatNumber(magnitude) +
           " µT is absurd (over 1000 µT; the Earth's field is about 50 µT)");
    return sample;
  }

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(file_, line_, problem);
  }

 private:
  double number(std::string_view token, const char* name) const {
    if (token.size() > 1 && token.front() == '+') token.remove_prefix(1);
    double value = 0.0;
    const auto result = std::from_chars(token.data(), token.data() + token.size(), value);
    if (result.ec != std::errc() || result.ptr != token.data() + token.size())
      fail(std::string(name) + " '" + std::string(token) + "' is not a number");
    if (!std::isfinite(value))
      fail(std::string(name) + " is not finite (" + std::string(token) + ")");
    return value;
  }

  int sensor(std::string_view token) const {
    int value = 0;
    const auto result = std::from_chars(token.data(), token.data() + token.size(), value);
    if (result.ec != std::errc() || result.ptr != token.data() + token.size())
      fail("sensor index '" + std::string(token) + "' is not an integer");
    if (value < 0 || value >= sensors_)
      fail("sensor index " + std::to_string(value) + " is not in session.yaml's " +
           std::to_string(sensors_) + " magnetometers");
    return value;
  }

  std::string file_;
  int sensors_;
  int line_ = 0;
};

void checkCsvHeader(std::string_view text, int line, const fs::path& file) {
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);  // UTF-8 byte order mark
  std::array<std::string_view, 5> fields;
  bool matches = splitCsv(text, &fields) == fields.size();
  for (std::size_t i = 0; matches && i < fields.size(); ++i) matches = fields[i] == kCsvColumns[i];
  if (!matches)
    throw InputError(file.string(), line,
                     "header is '" + std::string(text) + "', expected 't,sensor,bx,by,bz'");
}

std::vector<MagnetometerSample> readMagnetometerCsv(const fs::path& file, int sensors) {
  const std::string content = readWholeFile(
      file, "every session needs one (a header alone for a session without magnetometer data)");
  std::vector<MagnetometerSample> samples;
  samples.reserve(std::count(content.begin(), content.end(), '\n'));
  CsvRowParser parser(file, sensors);
  bool has_header = false;
  double previous_time = -std::numeric_limits<double>::infinity();
  std::vector<double> last_time(sensors, -std::numeric_limits<double>::infinity());
  std::vector<int> last_line(sensors, 0);
  forEachLine(content, [&](int line, std::string_view text) {
    if (text.empty()) return;
    if (!has_header) {
      checkCsvHeader(text, line, file);
      has_header = true;
      return;
    }
    const MagnetometerSample sample = parser.parse(text, line);
    if (sample.time_s < previous_time)
      parser.fail("time " + formatNumber(sample.time_s) + " is before the previous row's " +
                  formatNumber(previous_time));
    if (sample.time_s == last_time[sample.sensor])
      parser.fail("duplicate sample: sensor " + std::to_string(sample.sensor) +
                  " already has one at time " + formatNumber(sample.time_s) + " (line " +
                  std::to_string(last_line[sample.sensor]) + ")");
    previous_time = last_time[sample.sensor] = sample.time_s;
    last_line[sample.sensor] = line;
    samples.push_back(sample);
  });
  if (!has_header)
    throw InputError(file.string(), 0, "is empty; expected the header 't,sensor,bx,by,bz'");
  // Rows at one time may list the sensors in any order; Session promises ties by sensor index.
  const auto by_time_then_sensor = [](const MagnetometerSample& a, const MagnetometerSample& b) {
    return a.time_s < b.time_s || (a.time_s == b.time_s && a.sensor < b.sensor);
  };
  if (!std::is_sorted(samples.begin(), samples.end(), by_time_then_sensor))
    std::stable_sort(samples.begin(), samples.end(), by_time_then_sensor);
  return samples;
}

std::string formatMagnetometerCsv(const std::vector<MagnetometerSample>& samples, int sensors) {
  const auto fail = [](std::size_t i, const std::string& problem) {
    throw std::invalid_argument("writeSession: magnetometer sample " + std::to_string(i) + " " +
                                problem);
  };
  std::string out = "t,sensor,bx,by,bz\n";
  out.reserve(out.size() + samples.size() * 48);
  // Compare times as they will read back (1 µs), so that the file passes readSession's checks.
  double previous_time = -std::numeric_limits<double>::infinity();
  std::vector<double> last_time(sensors, -std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const MagnetometerSample& s = samples[i];
    if (s.sensor < 0 || s.sensor >= sensors) fail(i, "has a sensor index outside the rig");
    if (!std::isfinite(s.time_s) || !s.field_body_uT.allFinite()) fail(i, "is not finite");
    if (s.field_body_uT.norm() > kMaxField_uT) fail(i, "has a field above 1000 µT");
    const std::size_t row_begin = out.size();
    appendFixed(s.time_s, 6, &out);
    double time = 0.0;
    std::from_chars(out.data() + row_begin, out.data() + out.size(), time);
    if (time < previous_time) fail(i, "is earlier than the one before (samples must be sorted)");
    if (time == last_time[s.sensor]) fail(i, "repeats its sensor's time (to 1 µs)");
    previous_time = last_time[s.sensor] = time;
    out += ',';
    out += std::to_string(s.sensor);
    for (int k = 0; k < 3; ++k) {
      out += ',';
      appendFixed(s.field_body_uT[k], 4, &out);
    }
    out += '\n';
  }
  return out;
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

fs::path siblingPath(const fs::path& target, const std::string& suffix) {
  fs::path sibling = target;
  sibling += suffix + std::to_string(::getpid());
  return sibling;
}

// Swaps `staged` in for `target` with renames, so `target` is at every moment either the old
// session or the complete new one (never a mix), and the old one is removed only at the end.
void moveIntoPlace(const fs::path& staged, const fs::path& target) {
  if (!fs::exists(fs::symlink_status(target))) {
    fs::rename(staged, target);
    return;
  }
  const fs::path old = siblingPath(target, ".old-");
  fs::remove_all(old);
  fs::rename(target, old);
  try {
    fs::rename(staged, target);
  } catch (...) {
    std::error_code ignored;
    fs::rename(old, target, ignored);
    throw;
  }
  fs::remove_all(old);
}

}  // namespace

Session readSession(const fs::path& dir) {
  if (!fs::exists(dir)) throw InputError(dir.string(), 0, "session directory not found");
  if (!fs::is_directory(dir))
    throw InputError(dir.string(), 0,
                     "not a directory (a session is a directory with session.yaml, poses.txt "
                     "and magnetometer.csv)");
  Session session;
  readSessionYaml(dir / "session.yaml", &session);
  session.keyframes = readTumPoses(dir / "poses.txt");
  session.ground_truth = readGroundTruth(dir / "ground_truth.txt", session.keyframes);
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
  const fs::path staged = siblingPath(target, ".tmp-");
  fs::create_directories(target.parent_path());
  fs::remove_all(staged);
  fs::create_directory(staged);
  try {
    writeTextFile(staged / "session.yaml", yaml);
    writeTumPoses(staged / "poses.txt", session.keyframes);
    if (session.ground_truth) writeTumPoses(staged / "ground_truth.txt", *session.ground_truth);
    writeTextFile(staged / "magnetometer.csv", csv);
    if (session.hasScans()) writeScans(staged / "scans", session.scans);
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(staged, ignored);
    throw;
  }
  moveIntoPlace(staged, target);
}

}  // namespace mm4mm
