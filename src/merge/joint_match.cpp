#include "mm4mm/merge/joint_match.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/magnetic/match_score.hpp"

namespace mm4mm {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The best field score on a small grid around `T` (yaw-major, as the matcher's local grid).
CorrelationMode bestNear(const MatchScorer& scorer, const PlanarTransform& T, int nx, int ny,
                         const JointMatchConfig& config) {
  CorrelationMode best{T, 0.0, 0.0, 0.0};
  double best_value = -std::numeric_limits<double>::infinity();
  for (int iyaw = -ny; iyaw <= ny; ++iyaw)
    for (int iy = -nx; iy <= nx; ++iy)
      for (int ix = -nx; ix <= nx; ++ix) {
        const PlanarTransform candidate{T.x_m + ix * config.step_m, T.y_m + iy * config.step_m,
                                        wrapAngle(T.yaw_rad + iyaw * config.step_deg * kDeg)};
        const MatchScore s = scorer.evaluate(candidate);
        if (s.value > best_value) {
          best_value = s.value;
          best = {candidate, s.z, s.r, s.overlap_m2};
        }
      }
  return best;
}

}  // namespace

bool JointMatchConfig::SingleTrack::IsValid(std::string* error) const {
  const auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (const char* problem = sampleCountProblem(min_overlap_m2, area_per_sample_m2))
    return fail(problem);
  if (!(min_r > -1.0 && min_r < 1.0)) return fail("min_r must be in (-1, 1)");
  return true;
}

bool JointMatchConfig::IsValid(std::string* error) const {
  const auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (max_candidates < 1) return fail("max_candidates must be >= 1");
  if (structure_pyramid_factor < 1 || structure_pyramid_factor > 8)
    return fail("structure_pyramid_factor must be in [1, 8]");
  if (!(window_m >= 0.0) || !(step_m > 0.0)) return fail("window_m must be >= 0 and step_m > 0");
  if (!(window_deg >= 0.0) || !(step_deg > 0.0))
    return fail("window_deg must be >= 0 and step_deg > 0");
  if (!(max_second_ratio > 0.0)) return fail("max_second_ratio must be > 0");
  if (!(min_r > -1.0 && min_r < 1.0)) return fail("min_r must be in (-1, 1)");
  std::string inner;
  if (!single_track.IsValid(&inner)) {
    if (error) *error = "single_track." + inner;
    return false;
  }
  return true;
}

MagneticMatchResult matchStructureForJoint(const MagneticMap& structure_a,
                                           const MagneticMap& structure_b,
                                           const MagneticMatcherConfig& geometry,
                                           const JointMatchConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument(error);
  if (config.structure_pyramid_factor == 1)
    return matchMagneticMaps(structure_a, structure_b, geometry);
  MagneticMatcherConfig proposing = geometry;
  proposing.search.pyramid_factor = config.structure_pyramid_factor;
  return matchForProposals(structure_a, structure_b, proposing);
}

MagneticMatchResult matchJointly(const MagneticMap& field_a, const MagneticMap& field_b,
                                 const MagneticMatchResult& structure,
                                 const MagneticMatcherConfig& geometry,
                                 const MagneticMatcherConfig& stated_field,
                                 const JointMatchConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument(error);
  const auto start = std::chrono::steady_clock::now();
  MagneticMatchResult result;
  if (structure.modes.empty() || field_a.coveredCells() == 0 || field_b.coveredCells() == 0)
    return result;
  const MagneticMatcherConfig field = stated_field.appliedTo(field_a, field_b);

  std::vector<PlanarTransform> proposals;
  const double best_r = structure.modes.front().r;
  for (const CorrelationMode& mode : structure.modes)
    if (static_cast<int>(proposals.size()) < config.max_candidates &&
        mode.r >= best_r - geometry.credible_r_gap)
      proposals.push_back(mode.T_a_b);
  if (proposals.empty()) return result;

  const bool single_track = field_a.single_track || field_b.single_track;
  MatchScoreConfig score = field.score;
  double min_z = config.min_z, min_r = config.min_r;
  if (single_track) {
    score.min_overlap_m2 = config.single_track.min_overlap_m2;
    score.area_per_sample_m2 = config.single_track.area_per_sample_m2;
    min_z = config.single_track.min_z;
    min_r = config.single_track.min_r;
  }
  const MatchScorer scorer(field_a, field_b, score);
  const int nx = static_cast<int>(std::round(config.window_m / config.step_m));
  const int ny = static_cast<int>(std::round(config.window_deg / config.step_deg));
  std::vector<CorrelationMode> candidates(proposals.size());
  tbb::parallel_for(std::size_t{0}, proposals.size(), [&](std::size_t k) {
    candidates[k] = bestNear(scorer, proposals[k], nx, ny, config);
  });
  result.evaluations =
      static_cast<int>(proposals.size()) * (2 * nx + 1) * (2 * nx + 1) * (2 * ny + 1);
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const CorrelationMode& x, const CorrelationMode& y) { return x.z > y.z; });
  const CorrelationMode& top = candidates.front();
  double second_z = 0.0;
  for (std::size_t k = 1; k < candidates.size(); ++k)
    if (candidates[k].r >= top.r - field.credible_r_gap)
      second_z = std::max(second_z, candidates[k].z);
  result.T_a_b = top.T_a_b;
  result.z = top.z;
  result.r = top.r;
  result.overlap_m2 = top.overlap_m2;
  result.fitness = scorer.evaluate(top.T_a_b).value;
  result.second_mode_ratio = top.z > 0.0 ? second_z / top.z : 1.0;
  result.modes = candidates;
  if (!(top.z >= min_z) || !(top.r >= min_r))
    result.verdict = MatchVerdict::kNoOverlap;
  else if (result.second_mode_ratio > config.max_second_ratio)
    result.verdict = MatchVerdict::kAmbiguous;
  else
    result.verdict = MatchVerdict::kMatch;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace mm4mm
