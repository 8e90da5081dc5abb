#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "mm4mm/io/pcd_io.hpp"
#include "peer_registration.hpp"

// The peers' files: Open3D runs in a child process on clouds written as PCD, and the claim rules
// come from a CSV. No PCL here (peer_registration.cpp holds it).

namespace mm4mm::peers {

namespace fs = std::filesystem;

// Open3D's pipeline in a child process (Debian's python3-open3d), on the clouds written as PCD.
Eigen::Isometry3d registerOpen3d(const PointCloud& target, const PointCloud& source, unsigned seed,
                                 double* child_peak_mb) {
  const fs::path dir = fs::temp_directory_path() / ("mm4mm_peer_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  writePcd(dir / "target.pcd", target, PcdEncoding::kBinary);
  writePcd(dir / "source.pcd", source, PcdEncoding::kBinary);
  const std::string command = "/usr/bin/python3 " MM4MM_SOURCE_DIR "/scripts/open3d_peer.py " +
                              (dir / "target.pcd").string() + " " + (dir / "source.pcd").string() +
                              " " + std::to_string(seed);
  std::string output;
  if (FILE* pipe = ::popen(command.c_str(), "r")) {
    std::array<char, 4096> buffer{};
    while (std::fgets(buffer.data(), buffer.size(), pipe)) output += buffer.data();
    if (::pclose(pipe) != 0) output.clear();
  }
  fs::remove_all(dir);
  if (output.empty()) throw std::runtime_error("open3d peer failed: " + command);
  const nlohmann::json answer = nlohmann::json::parse(output);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 4; ++col)
      T.matrix()(r, col) = answer["T_target_source"][r][col].get<double>();
  T.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
  *child_peak_mb = std::max(*child_peak_mb, answer.value("peak_rss_mb", 0.0));
  return T;
}

namespace {

// A rules CSV as scripts/choose_peer_rules.py writes it: a header, then method and two thresholds
// per line (further columns are the figures the choice was made on).
std::map<std::string, std::pair<double, double>> readRuleRows(const std::string& path,
                                                              const std::string& columns) {
  std::map<std::string, std::pair<double, double>> rows;
  if (path.empty()) return rows;
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read peer rules " + path);
  std::string line;
  std::getline(in, line);
  if (line.rfind(columns, 0) != 0)
    throw std::runtime_error(path + ": expected the header " + columns + ", found: " + line);
  while (std::getline(in, line)) {
    std::stringstream fields(line);
    std::string method, first, second;
    if (!std::getline(fields, method, ',') || !std::getline(fields, first, ',') ||
        !std::getline(fields, second, ','))
      throw std::runtime_error(path + ": expected " + columns + ": " + line);
    rows[method] = {std::stod(first), std::stod(second)};
  }
  return rows;
}

}  // namespace

// A method not listed claims whatever converged.
std::map<std::string, ClaimRule> readClaimRules(const std::string& path) {
  std::map<std::string, ClaimRule> rules;
  for (const auto& [method, thresholds] :
       readRuleRows(path, "method,min_fitness,max_inlier_rmse_m"))
    rules[method] = ClaimRule{thresholds.first, thresholds.second};
  return rules;
}

std::map<std::string, AmbiguityRule> readAmbiguityRules(const std::string& path) {
  std::map<std::string, AmbiguityRule> rules;
  for (const auto& [method, thresholds] : readRuleRows(path, "method,min_fitness,max_second_ratio"))
    rules[method] = AmbiguityRule{thresholds.first, thresholds.second};
  return rules;
}

}  // namespace mm4mm::peers
