// Reading g2o text written by g2o_writer.cpp (format: mm4mm/io/g2o_io.hpp).

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "g2o_format.hpp"
#include "mm4mm/io/g2o_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "text_io.hpp"

namespace mm4mm {
namespace {

using namespace io_detail::g2o;
using io_detail::forEachLine;
using io_detail::formatNumber;
using io_detail::parseFiniteNumber;
using io_detail::readWholeFile;
using io_detail::splitWhitespace;
using io_detail::trim;

// Files written with 6 or 7 digits still pass; a quaternion further off than this is not a
// rounding artefact but a wrong column order or a broken exporter.
constexpr double kQuaternionNormTolerance = 1e-3;

// The fields of one line after its tag, with the means to parse them and to fail at that line.
class Fields {
 public:
  Fields(const std::string& file, int line, std::string_view tag,
         std::vector<std::string_view> tokens)
      : file_(file), line_(line), tag_(tag), tokens_(std::move(tokens)) {}

  int line() const { return line_; }

  void expectCount(std::size_t count, const char* layout) const {
    if (tokens_.size() != count)
      fail(std::string(tag_) + " expects " + std::to_string(count) + " fields (" + layout +
           "), got " + std::to_string(tokens_.size()));
  }

  double number(std::size_t index, std::string_view name) const {
    return parseFiniteNumber(tokens_[index], name, file_, line_);
  }

  int integer(std::size_t index, std::string_view name) const {
    const std::string_view token = tokens_[index];
    int value = 0;
    const auto result = std::from_chars(token.data(), token.data() + token.size(), value);
    if (result.ec != std::errc() || result.ptr != token.data() + token.size())
      fail(std::string(name) + " '" + std::string(token) + "' is not an integer");
    return value;
  }

  // x y z qx qy qz qw starting at `first`.
  Eigen::Isometry3d pose(std::size_t first) const {
    static constexpr std::array<const char*, 7> kNames = {"x", "y", "z", "qx", "qy", "qz", "qw"};
    std::array<double, 7> v{};
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = number(first + i, kNames[i]);
    Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    const double norm = q.norm();
    if (std::abs(norm - 1.0) > kQuaternionNormTolerance)
      fail("quaternion (qx qy qz qw) has norm " + formatNumber(norm) + ", not 1");
    q.coeffs() /= norm;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = q.toRotationMatrix();
    T.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
    return T;
  }

  // The 21 upper-triangular entries starting at `first`, row by row.
  Information information(std::size_t first) const {
    Information I;
    std::size_t index = first;
    for (int r = 0; r < 6; ++r) {
      for (int c = r; c < 6; ++c) {
        I(r, c) = I(c, r) = number(index++, "information entry");
      }
    }
    if (I.llt().info() != Eigen::Success) fail("information matrix is not positive definite");
    return I;
  }

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(file_, line_, problem);
  }

 private:
  const std::string& file_;
  int line_;
  std::string_view tag_;
  std::vector<std::string_view> tokens_;
};

template <typename T>
struct AtLine {
  T value;
  int line;
};

struct ParsedEdge {
  OdometryEdge edge;
  int line = 0;
  bool magnetic_tag = false;
};

// Everything the file holds, before references between lines are resolved.
struct ParsedFile {
  std::string session_id;
  SessionGraphConfig noise;
  std::vector<AtLine<ScanNode>> scans;
  std::vector<AtLine<MagneticNode>> magnetic;
  std::vector<AtLine<std::pair<int, double>>> scan_times;  // id, time
  std::vector<AtLine<std::pair<int, Eigen::Vector3d>>> readings;
  std::vector<int> reading_sensors;  // parallel to `readings`
  std::vector<ParsedEdge> edges;
  std::map<int, std::pair<NodeKind, std::size_t>> vertices;  // id -> kind, index
};

void addVertex(const Fields& fields, int id, NodeKind kind, std::size_t index, ParsedFile* file) {
  if (!file->vertices.emplace(id, std::make_pair(kind, index)).second)
    fields.fail("duplicate vertex id " + std::to_string(id));
}

void parseLine(const Fields& fields, std::string_view tag, ParsedFile* parsed) {
  if (tag == kScanVertexTag) {
    fields.expectCount(8, "id x y z qx qy qz qw");
    ScanNode node;
    node.id = fields.integer(0, "id");
    node.T_session_body = fields.pose(1);
    node.keyframe = static_cast<int>(parsed->scans.size());
    addVertex(fields, node.id, NodeKind::kScan, parsed->scans.size(), parsed);
    parsed->scans.push_back({node, fields.line()});
  } else if (tag == kMagVertexTag) {
    fields.expectCount(10, "id t x y z qx qy qz qw n");
    MagneticNode node;
    node.id = fields.integer(0, "id");
    node.time_s = fields.number(1, "t");
    node.T_session_body = fields.pose(2);
    const int sensors = fields.integer(9, "n");
    if (sensors < 1 || sensors > 100000)
      fields.fail("sensor count n = " + std::to_string(sensors) + " is not in [1, 100000]");
    node.readings_body_uT.assign(sensors, Eigen::Vector3d::Zero());
    node.has_reading.assign(sensors, false);
    addVertex(fields, node.id, NodeKind::kMagnetic, parsed->magnetic.size(), parsed);
    parsed->magnetic.push_back({std::move(node), fields.line()});
  } else if (tag == kScanTimeTag) {
    fields.expectCount(2, "id t");
    parsed->scan_times.push_back({{fields.integer(0, "id"), fields.number(1, "t")}, fields.line()});
  } else if (tag == kReadingTag) {
    fields.expectCount(5, "id sensor bx by bz");
    const int id = fields.integer(0, "id");
    parsed->reading_sensors.push_back(fields.integer(1, "sensor"));
    const Eigen::Vector3d b(fields.number(2, "bx"), fields.number(3, "by"), fields.number(4, "bz"));
    parsed->readings.push_back({{id, b}, fields.line()});
  } else if (tag == kEdgeTag || tag == kMagEdgeTag) {
    fields.expectCount(30, "i j x y z qx qy qz qw and 21 information entries");
    ParsedEdge parsed_edge;
    parsed_edge.edge.from = fields.integer(0, "i");
    parsed_edge.edge.to = fields.integer(1, "j");
    parsed_edge.edge.T_from_to = fields.pose(2);
    parsed_edge.edge.information = fields.information(9);
    parsed_edge.line = fields.line();
    parsed_edge.magnetic_tag = tag == kMagEdgeTag;
    parsed->edges.push_back(parsed_edge);
  } else if (tag == kNoiseTag) {
    fields.expectCount(5,
                       "translation per sqrt m, floor; rotation per sqrt m, per sqrt rad, floor");
    SessionGraphConfig& noise = parsed->noise;
    noise.translation_sigma_per_sqrt_m = fields.number(0, "translation_sigma_per_sqrt_m");
    noise.translation_sigma_floor_m = fields.number(1, "translation_sigma_floor_m");
    noise.rotation_sigma_per_sqrt_m_deg = fields.number(2, "rotation_sigma_per_sqrt_m_deg");
    noise.rotation_sigma_per_sqrt_rad_deg = fields.number(3, "rotation_sigma_per_sqrt_rad_deg");
    noise.rotation_sigma_floor_deg = fields.number(4, "rotation_sigma_floor_deg");
    std::string error;
    if (!noise.IsValid(&error)) fields.fail(error);
  }
  // Anything else is a tag this reader does not know: skipped, as g2o does.
}

// The kind of vertex `id`, failing at `line` when there is none.
NodeKind kindOf(const ParsedFile& parsed, int id, const std::string& file, int line,
                std::size_t* index = nullptr) {
  const auto it = parsed.vertices.find(id);
  if (it == parsed.vertices.end())
    throw InputError(file, line, "vertex " + std::to_string(id) + " is not defined");
  if (index) *index = it->second.second;
  return it->second.first;
}

void resolveScanTimes(const std::string& file, ParsedFile* parsed) {
  std::vector<bool> has_time(parsed->scans.size(), false);
  for (const auto& [value, line] : parsed->scan_times) {
    std::size_t index = 0;
    if (kindOf(*parsed, value.first, file, line, &index) != NodeKind::kScan)
      throw InputError(
          file, line,
          "vertex " + std::to_string(value.first) + " is not a scan vertex (VERTEX_SE3:QUAT)");
    if (has_time[index])
      throw InputError(file, line, "second time for vertex " + std::to_string(value.first));
    has_time[index] = true;
    parsed->scans[index].value.time_s = value.second;
  }
  for (std::size_t i = 0; i < has_time.size(); ++i) {
    if (!has_time[i])
      throw InputError(
          file, parsed->scans[i].line,
          "scan vertex " + std::to_string(parsed->scans[i].value.id) + " has no SCAN_TIME line");
  }
}

void resolveReadings(const std::string& file, ParsedFile* parsed) {
  for (std::size_t r = 0; r < parsed->readings.size(); ++r) {
    const auto& [value, line] = parsed->readings[r];
    std::size_t index = 0;
    if (kindOf(*parsed, value.first, file, line, &index) != NodeKind::kMagnetic)
      throw InputError(file, line,
                       "vertex " + std::to_string(value.first) +
                           " is not a magnetic vertex (VERTEX_MAG:SE3:QUAT)");
    MagneticNode& node = parsed->magnetic[index].value;
    const int sensor = parsed->reading_sensors[r];
    const int sensors = static_cast<int>(node.readings_body_uT.size());
    if (sensor < 0 || sensor >= sensors)
      throw InputError(
          file, line,
          "sensor " + std::to_string(sensor) + " is not in [0, " + std::to_string(sensors) + ")");
    if (node.has_reading[sensor])
      throw InputError(file, line,
                       "second reading of sensor " + std::to_string(sensor) + " at vertex " +
                           std::to_string(value.first));
    node.readings_body_uT[sensor] = value.second;
    node.has_reading[sensor] = true;
  }
}

// The odometry chain: every EDGE_MAG edge, and every standard edge from a scan vertex whose
// odometry goes on directly to the next scan vertex (no EDGE_MAG edge leaves it); the other
// standard edges are compositions the writer derived. Sorted into chain order by node times.
std::vector<OdometryEdge> resolveEdges(const std::string& file, const ParsedFile& parsed) {
  std::map<int, double> times;
  for (const auto& scan : parsed.scans) times[scan.value.id] = scan.value.time_s;
  for (const auto& mag : parsed.magnetic) times[mag.value.id] = mag.value.time_s;
  std::set<int> leaves_by_mag_edge;
  for (const ParsedEdge& e : parsed.edges) {
    const NodeKind from = kindOf(parsed, e.edge.from, file, e.line);
    const NodeKind to = kindOf(parsed, e.edge.to, file, e.line);
    const bool scan_to_scan = from == NodeKind::kScan && to == NodeKind::kScan;
    if (!e.magnetic_tag && !scan_to_scan)
      throw InputError(file, e.line, "EDGE_SE3:QUAT must join two scan vertices");
    if (e.magnetic_tag && scan_to_scan)
      throw InputError(file, e.line, "EDGE_MAG:SE3:QUAT must touch a magnetic vertex");
    if (e.magnetic_tag) leaves_by_mag_edge.insert(e.edge.from);
  }
  std::vector<OdometryEdge> odometry;
  for (const ParsedEdge& e : parsed.edges) {
    if (e.magnetic_tag || !leaves_by_mag_edge.count(e.edge.from)) odometry.push_back(e.edge);
  }
  std::stable_sort(odometry.begin(), odometry.end(),
                   [&](const OdometryEdge& a, const OdometryEdge& b) {
                     const double a_from = times.at(a.from), b_from = times.at(b.from);
                     if (a_from != b_from) return a_from < b_from;
                     return times.at(a.to) < times.at(b.to);
                   });
  return odometry;
}

}  // namespace

SessionGraph readSessionGraphG2o(const std::filesystem::path& path) {
  const std::string file = path.string();
  const std::string content = readWholeFile(path);
  ParsedFile parsed;
  bool header_seen = false;
  forEachLine(content, [&](int line, std::string_view text) {
    if (text.empty()) return;
    if (text.front() == '#') {
      if (!header_seen && text.substr(0, kHeader.size()) == kHeader) {
        header_seen = true;
        parsed.session_id = std::string(trim(text.substr(kHeader.size())));
      }
      return;
    }
    std::vector<std::string_view> tokens = splitWhitespace(text);
    const std::string_view tag = tokens.front();
    tokens.erase(tokens.begin());
    parseLine(Fields(file, line, tag, std::move(tokens)), tag, &parsed);
  });
  if (parsed.vertices.empty()) throw InputError(file, 0, "no vertices");
  resolveScanTimes(file, &parsed);
  resolveReadings(file, &parsed);

  SessionGraph graph;
  graph.session_id = parsed.session_id;
  graph.noise = parsed.noise;
  graph.odometry = resolveEdges(file, parsed);
  for (auto& scan : parsed.scans) graph.scans.push_back(scan.value);
  for (auto& mag : parsed.magnetic) graph.magnetic.push_back(std::move(mag.value));
  return graph;
}

StoredInterSessionEdges readInterSessionEdgesG2o(const std::filesystem::path& path) {
  const std::string file = path.string();
  const std::string content = readWholeFile(path);
  StoredInterSessionEdges stored;
  std::map<int, std::pair<int, int>> scan_of;  // vertex id -> (session, keyframe)
  std::vector<int> scans;                      // per session
  bool in_edges = false;
  forEachLine(content, [&](int line, std::string_view text) {
    if (text.empty()) return;
    if (text.front() == '#') {
      if (text.substr(0, kHeader.size()) == kHeader) {
        stored.session_ids.emplace_back(trim(text.substr(kHeader.size())));
        scans.push_back(0);
      } else if (text == kInterSessionHeader) {
        in_edges = true;
      }
      return;
    }
    std::vector<std::string_view> tokens = splitWhitespace(text);
    const std::string_view tag = tokens.front();
    tokens.erase(tokens.begin());
    const Fields fields(file, line, tag, std::move(tokens));
    if (!in_edges && tag == kScanVertexTag) {
      if (stored.session_ids.empty()) fields.fail("a scan vertex before any session graph");
      const int session = static_cast<int>(stored.session_ids.size()) - 1;
      if (!scan_of.emplace(fields.integer(0, "id"), std::pair{session, scans.back()++}).second)
        fields.fail("duplicate vertex id");
    } else if (in_edges && tag == kEdgeTag) {
      fields.expectCount(30, "i j x y z qx qy qz qw and 21 information entries");
      const auto a = scan_of.find(fields.integer(0, "i"));
      const auto b = scan_of.find(fields.integer(1, "j"));
      if (a == scan_of.end() || b == scan_of.end())
        fields.fail("inter-session edge names a vertex that is not a scan vertex");
      if (a->second.first == b->second.first)
        fields.fail("inter-session edge joins a session to itself");
      InterSessionEdge edge;
      edge.session_a = a->second.first;
      edge.keyframe_a = a->second.second;
      edge.session_b = b->second.first;
      edge.keyframe_b = b->second.second;
      edge.T_a_b = fields.pose(2);
      edge.information = fields.information(9);
      stored.edges.push_back(edge);
    }
  });
  if (stored.session_ids.empty()) throw InputError(file, 0, "no session graphs");
  return stored;
}

}  // namespace mm4mm
