#include "mm4mm/import/hdl_graph_slam_dump.hpp"

#include <algorithm>
#include <cmath>

#include "import_text.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/pcd_io.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;
using import_detail::TokenStream;

// KeyFrame::save's lines (keyframe.cpp), read token by token as KeyFrame::load does.
StampedPose readKeyframeData(const fs::path& file) {
  TokenStream in(file);
  StampedPose pose;
  in.expect("stamp");
  const double sec = in.number("stamp sec");
  const double nsec = in.number("stamp nsec");
  pose.time_s = sec + 1e-9 * nsec;
  in.expect("estimate");
  const int line = in.line();
  pose.T_frame_body = import_detail::rigidFromMatrix(in.matrix(4, 4, "estimate"), in.file(), line);
  in.expect("odom");
  in.matrix(4, 4, "odom");
  const std::vector<std::pair<std::string, int>> optional_keys = {
      {"accum_distance", 1}, {"floor_coeffs", 4}, {"utm_coord", 3},
      {"acceleration", 3},   {"orientation", 4},  {"id", 1}};
  while (!in.done()) {
    const int at = in.line();
    const std::string key = in.word("a key");
    const auto it = std::find_if(optional_keys.begin(), optional_keys.end(),
                                 [&](const auto& k) { return k.first == key; });
    if (it == optional_keys.end())
      throw InputError(in.file(), at, "unknown key '" + key + "' in a keyframe's data");
    in.matrix(1, it->second, key);
  }
  return pose;
}

}  // namespace

LidarRecording readHdlGraphSlamDump(const fs::path& dir) {
  if (!fs::exists(dir / "graph.g2o"))
    throw InputError((dir / "graph.g2o").string(), 0,
                     "file not found: not an hdl_graph_slam dump directory");
  const auto keyframe_dirs = import_detail::sixDigitDirectories(dir);
  if (keyframe_dirs.empty())
    throw InputError(dir.string(), 0, "holds no keyframe directory (000000/ ...)");
  LidarRecording recording;
  recording.source = "hdl_graph_slam dump " + dir.string();
  recording.body_frame = "hdl_graph_slam's cloud frame (base_link_frame of the prefilter, if set)";
  for (const auto& [index, path] : keyframe_dirs) {
    ImportedKeyframe keyframe;
    keyframe.pose = readKeyframeData(path / "data");
    keyframe.scan_body = readPcd(path / "cloud.pcd");
    if (keyframe.scan_body.empty())
      throw InputError((path / "cloud.pcd").string(), 0, "holds no point");
    recording.keyframes.push_back(std::move(keyframe));
  }
  std::stable_sort(recording.keyframes.begin(), recording.keyframes.end(),
                   [](const auto& a, const auto& b) { return a.pose.time_s < b.pose.time_s; });
  recording.notes.push_back(
      "hdl_graph_slam saves no pose stream between keyframes: the magnetometer is placed by "
      "interpolating the keyframes; its matrices carry 6 significant digits");
  return recording;
}

}  // namespace mm4mm
