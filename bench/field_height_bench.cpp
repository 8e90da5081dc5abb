// How well the field at one height predicts it at another (issue 32: a handheld session, its
// magnetometer at 1.1 m, matched none of the robots, theirs at 0.3 m, in 6 of 10 held-out worlds).
// The matching scores two sessions' maps by Pearson's r over their overlap, so two heights can
// match only where the field's pattern at one is the pattern at the other. Per world: the
// preset's sessions simulated on the imu robot; the 0.5 m cells (the correlation search's coarse
// cells) whose centres lie within 0.75 m of their true trajectories (a map's swath); at each cell's
// centre the simulator's true field at the robot's magnetometer height and at each of --heights.
// For every crossed cell with at least 20 crossed cells within --radius-m (2.5 m: about the 15-20
// m² of a small overlap), Pearson's r of B_v and of B_h between the robot's height and the other
// over those cells; the median and the 10th percentile of r over the centres. No sensor noise,
// calibration or interpolation: the best any map could do.
//
// Usage: field_height_bench [--seeds N] [--first-seed S] [--presets a,b,...]
//                           [--heights 0.3,0.5,...] [--radius-m R] [--csv FILE]
// CSV (appended, header when new): preset, seed, base and other height (m), centres, median and
// 10th percentile of r for B_v and for B_h.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "bench_util.hpp"
#include "mm4mm/sim/magnetic_field.hpp"
#include "mm4mm/sim/simulator.hpp"
#include "sim_presets.hpp"

using namespace mm4mm;
using namespace mm4mm::bench;
namespace fs = std::filesystem;

namespace {

constexpr double kCell = 0.5;
constexpr std::size_t kMinCells = 20;
// A map covers a swath about its track: the Gaussian process reaches a few length scales out.
constexpr double kSwath = 0.75;

double pearson(const std::vector<double>& a, const std::vector<double>& b) {
  const double n = static_cast<double>(a.size());
  double ma = 0, mb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) ma += a[i] / n, mb += b[i] / n;
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : 0.0;
}

// The q-quantile (lower) of `values`.
double quantile(std::vector<double> values, double q) {
  if (values.empty()) return std::nan("");
  std::sort(values.begin(), values.end());
  return values[static_cast<std::size_t>(q * (values.size() - 1))];
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 5, first_seed = 1;
  std::vector<std::string> presets{"procedural"}, height_list{"0.3", "0.5", "0.7", "0.9", "1.1"};
  double radius = 2.5;
  std::string csv_path = "field_height.csv";
  for (const auto& [flag, value] : parseFlags(
           argc, argv, {"--seeds", "--first-seed", "--presets", "--heights", "--radius-m", "--csv"},
           "field_height_bench [--seeds N] [--first-seed S] [--presets a,b,...] "
           "[--heights 0.3,0.5,...] [--radius-m R] [--csv FILE]")) {
    if (flag == "--seeds") seeds = std::stoi(value);
    if (flag == "--first-seed") first_seed = std::stoi(value);
    if (flag == "--presets") presets = splitList(value);
    if (flag == "--heights") height_list = splitList(value);
    if (flag == "--radius-m") radius = std::stod(value);
    if (flag == "--csv") csv_path = value;
  }
  const bool fresh = !fs::exists(csv_path);
  std::FILE* csv = std::fopen(csv_path.c_str(), "a");
  if (!csv) {
    std::fprintf(stderr, "field_height_bench: cannot open %s\n", csv_path.c_str());
    return 1;
  }
  if (fresh)
    std::fprintf(csv,
                 "preset,seed,base_height_m,height_m,centres,median_r_vertical,p10_r_vertical,"
                 "median_r_horizontal,p10_r_horizontal\n");
  for (const std::string& preset_name : presets)
    for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
      Preset preset = presetFor(preset_name);
      sim::applyRigPreset("imu", &preset.config);
      const double base = preset.config.rig.magnetometer_height_m;
      const std::vector<Session> sessions =
          sim::simulateSessions(preset.config, preset.sessions, seed);
      const sim::SimulatedWorld world(preset.config, seed);
      std::map<std::pair<long, long>, Eigen::Vector2d> crossed;
      for (const Session& s : sessions)
        for (const StampedPose& pose : *s.ground_truth) {
          const Eigen::Vector2d p = pose.T_frame_body.translation().head<2>();
          const long cx = std::lround(std::floor(p.x() / kCell));
          const long cy = std::lround(std::floor(p.y() / kCell));
          for (long ix = cx - 2; ix <= cx + 2; ++ix)
            for (long iy = cy - 2; iy <= cy + 2; ++iy) {
              const Eigen::Vector2d centre((ix + 0.5) * kCell, (iy + 0.5) * kCell);
              if ((centre - p).norm() <= kSwath) crossed.emplace(std::make_pair(ix, iy), centre);
            }
        }
      std::vector<Eigen::Vector2d> centres;
      for (const auto& entry : crossed) centres.push_back(entry.second);
      const auto channels = [&](double height, std::vector<double>* v, std::vector<double>* h) {
        for (const Eigen::Vector2d& c : centres) {
          const Eigen::Vector3d b = world.field.fieldAt(Eigen::Vector3d(c.x(), c.y(), height));
          v->push_back(b.z());
          h->push_back(b.head<2>().norm());
        }
      };
      std::vector<double> base_v, base_h;
      channels(base, &base_v, &base_h);
      std::fprintf(stderr, "%s seed %d: %zu cells crossed\n", preset_name.c_str(), seed,
                   centres.size());
      for (const std::string& text : height_list) {
        const double height = std::stod(text);
        std::vector<double> other_v, other_h;
        channels(height, &other_v, &other_h);
        std::vector<double> r_v, r_h;
        for (std::size_t i = 0; i < centres.size(); ++i) {
          std::vector<double> av, bv, ah, bh;
          for (std::size_t j = 0; j < centres.size(); ++j)
            if ((centres[j] - centres[i]).norm() <= radius) {
              av.push_back(base_v[j]), bv.push_back(other_v[j]);
              ah.push_back(base_h[j]), bh.push_back(other_h[j]);
            }
          if (av.size() < kMinCells) continue;
          r_v.push_back(pearson(av, bv));
          r_h.push_back(pearson(ah, bh));
        }
        std::fprintf(csv, "%s,%d,%.2f,%.2f,%zu,%.3f,%.3f,%.3f,%.3f\n", preset_name.c_str(), seed,
                     base, height, r_v.size(), quantile(r_v, 0.5), quantile(r_v, 0.1),
                     quantile(r_h, 0.5), quantile(r_h, 0.1));
        std::fflush(csv);
        std::fprintf(stderr, "%s seed %d: %.2f m against %.2f m, median r %.3f (B_v) %.3f (B_h)\n",
                     preset_name.c_str(), seed, height, base, quantile(r_v, 0.5),
                     quantile(r_h, 0.5));
      }
    }
  std::fclose(csv);
  return 0;
}
