#include "mm4mm/magnetic/magnetic_matcher.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <tuple>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/magnetic/compass_prior.hpp"

namespace mm4mm {
namespace {

constexpr double kDeg = M_PI / 180.0;

PlanarTransform fromVector(const Eigen::VectorXd& v) { return {v[0], v[1], wrapAngle(v[2])}; }

CorrelationMode modeAt(const MatchScorer& scorer, const PlanarTransform& T) {
  const MatchScore s = scorer.evaluate(T);
  return {T, s.z, s.r, s.overlap_m2};
}

// Refines one coarse mode at the fine resolution; returns the refined mode and its score.
std::pair<CorrelationMode, MatchScore> refineMode(const MatchScorer& full_scorer,
                                                  const CorrelationMode& mode,
                                                  const MagneticMatcherConfig& config,
                                                  std::uint64_t seed, int* evaluations) {
  const PlanarTransform& T = mode.T_a_b;
  // Within the refinement window, b's cells move by at most the window plus the yaw swing at
  // b's far end; cells that cannot reach a's coverage are left out of every evaluation.
  const double reach =
      config.refine_window_m + config.refine_window_deg * kDeg * full_scorer.sampleReach() + 0.5;
  const MatchScorer scorer = full_scorer.focusedOn(T, reach);
  if (config.refinement == RefinementMethod::kNone) {
    ++*evaluations;
    const MatchScore s = scorer.evaluate(T);
    return {{T, s.z, s.r, s.overlap_m2}, s};
  }
  const double w = config.refine_window_m, wy = config.refine_window_deg * kDeg;
  if (config.refinement == RefinementMethod::kPso) {
    Eigen::VectorXd lower(3), upper(3), start(3);
    lower << T.x_m - w, T.y_m - w, T.yaw_rad - wy;
    upper << T.x_m + w, T.y_m + w, T.yaw_rad + wy;
    start << T.x_m, T.y_m, T.yaw_rad;
    PsoConfig pso = config.pso;
    pso.seed = seed;
    const PsoResult result =
        psoMaximize([&](const Eigen::VectorXd& x) { return scorer.evaluate(fromVector(x)).value; },
                    lower, upper, pso, &start);
    *evaluations += result.evaluations;
    const PlanarTransform best = fromVector(result.best);
    const MatchScore s = scorer.evaluate(best);
    return {{best, s.z, s.r, s.overlap_m2}, s};
  }
  // Exhaustive local grid, yaw-major so each yaw's translations run in parallel.
  const int nx = static_cast<int>(std::round(w / config.grid_step_m));
  const int ny = static_cast<int>(std::round(wy / (config.grid_step_deg * kDeg)));
  const int side = 2 * nx + 1;
  std::vector<double> values(static_cast<std::size_t>(side) * side * (2 * ny + 1));
  tbb::parallel_for(0, static_cast<int>(values.size()), [&](int k) {
    const int iyaw = k / (side * side) - ny, rest = k % (side * side);
    const int ix = rest % side - nx, iy = rest / side - nx;
    values[k] = scorer
                    .evaluate({T.x_m + ix * config.grid_step_m, T.y_m + iy * config.grid_step_m,
                               T.yaw_rad + iyaw * config.grid_step_deg * kDeg})
                    .value;
  });
  *evaluations += static_cast<int>(values.size());
  const int k = static_cast<int>(std::max_element(values.begin(), values.end()) - values.begin());
  const int iyaw = k / (side * side) - ny, rest = k % (side * side);
  const PlanarTransform best{T.x_m + (rest % side - nx) * config.grid_step_m,
                             T.y_m + (rest / side - nx) * config.grid_step_m,
                             wrapAngle(T.yaw_rad + iyaw * config.grid_step_deg * kDeg)};
  const MatchScore s = scorer.evaluate(best);
  return {{best, s.z, s.r, s.overlap_m2}, s};
}

// The paper's method: one PSO over the whole box of translations that make the maps touch and
// every yaw, on the configured score (Eq. 4–5 by default for this method).
std::vector<CorrelationMode> paperGlobalPso(const MagneticMap& a, const MagneticMap& b,
                                            const MatchScorer& scorer,
                                            const MagneticMatcherConfig& config, int* evaluations,
                                            MatchScore* best_score) {
  const double reach = 0.5 * std::hypot(b.width, b.height) * b.cell_size_m;
  const Eigen::Vector2d a_lo = a.origin_m,
                        a_hi = a.origin_m + a.cell_size_m * Eigen::Vector2d(a.width, a.height);
  const Eigen::Vector2d b_centre =
      b.origin_m + 0.5 * b.cell_size_m * Eigen::Vector2d(b.width, b.height);
  // t = p_a − R p_b; with p_b near b's centre, any t putting it within reach of a's box.
  Eigen::VectorXd lower(3), upper(3);
  lower << a_lo.x() - reach - b_centre.norm(), a_lo.y() - reach - b_centre.norm(), -M_PI;
  upper << a_hi.x() + reach + b_centre.norm(), a_hi.y() + reach + b_centre.norm(), M_PI;
  const PsoResult result =
      psoMaximize([&](const Eigen::VectorXd& x) { return scorer.evaluate(fromVector(x)).value; },
                  lower, upper, config.paper_pso);
  *evaluations += result.evaluations;
  const PlanarTransform best = fromVector(result.best);
  *best_score = scorer.evaluate(best);
  return {modeAt(scorer, best)};
}

}  // namespace

std::string toString(CompassUse use) {
  switch (use) {
    case CompassUse::kOff:
      return "off";
    case CompassUse::kUntrusted:
      return "untrusted";
    case CompassUse::kWindow:
      return "window";
    case CompassUse::kFellBack:
      return "fell back";
  }
  return "unknown";
}

std::string toString(CoarseToFine use) {
  switch (use) {
    case CoarseToFine::kOff:
      return "off";
    case CoarseToFine::kAccepted:
      return "accepted";
    case CoarseToFine::kFellBack:
      return "fell_back";
    case CoarseToFine::kAlone:
      return "alone";
  }
  return "unknown";
}

std::string toString(MatchVerdict verdict) {
  switch (verdict) {
    case MatchVerdict::kMatch:
      return "match";
    case MatchVerdict::kNoOverlap:
      return "no overlap";
    case MatchVerdict::kAmbiguous:
      return "ambiguous";
    case MatchVerdict::kYawUncertain:
      return "yaw uncertain";
  }
  return "unknown";
}

bool MagneticMatcherConfig::SingleTrack::IsValid(std::string* error) const {
  const auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (const char* problem = sampleCountProblem(min_overlap_m2, area_per_sample_m2))
    return fail(problem);
  if (stride < 1) return fail("stride must be >= 1");
  if (!(mode_separation_m > 0.0)) return fail("mode_separation_m must be > 0");
  if (!(refine_window_m > 0.0) || !(refine_window_deg > 0.0))
    return fail("refine_window_m and refine_window_deg must be > 0");
  if (!(min_r > -1.0 && min_r < 1.0)) return fail("min_r must be in (-1, 1)");
  return true;
}

bool MagneticMatcherConfig::IsValid(std::string* error) const {
  const auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  std::string inner;
  // Each message starts with the key it is about, as the config file names it.
  if (!calibration.IsValid(&inner)) return fail("calibration." + inner);
  if (!map.IsValid(&inner)) return fail("map." + inner);
  if (!search.IsValid(&inner)) return fail("search." + inner);
  if (!score.IsValid(&inner)) return fail("score." + inner);
  if (!pso.IsValid(&inner)) return fail("pso." + inner);
  if (!paper_pso.IsValid(&inner)) return fail("paper_pso." + inner);
  if (!(coarse_cell_size_m >= map.cell_size_m) ||
      !(single_track.coarse_cell_size_m >= map.cell_size_m))
    return fail(
        "coarse_cell_size_m and single_track.coarse_cell_size_m must be >= map.cell_size_m");
  if (!single_track.IsValid(&inner)) return fail("single_track." + inner);
  if (!confidence_model.IsValid(&inner)) return fail("confidence_model." + inner);
  if (refine_modes < 1) return fail("refine_modes must be >= 1");
  if (!(refine_window_m > 0.0) || !(refine_window_deg > 0.0))
    return fail("refine_window_m and refine_window_deg must be > 0");
  if (!(grid_step_m > 0.0) || !(grid_step_deg > 0.0))
    return fail("grid_step_m and grid_step_deg must be > 0");
  if (!(compass_window_deg > 0.0 && compass_window_deg <= 180.0))
    return fail("compass_window_deg must be in (0, 180]");
  if (!(compass_min_resultant >= 0.0 && compass_min_resultant <= 1.0))
    return fail("compass_min_resultant must be in [0, 1]");
  if (!(max_yaw_uncertainty_deg > 0.0)) return fail("max_yaw_uncertainty_deg must be > 0");
  if (!(yaw_uncertainty_step_deg > 0.0) || !(yaw_uncertainty_range_deg >= yaw_uncertainty_step_deg))
    return fail("yaw_uncertainty_step_deg must be > 0 and yaw_uncertainty_range_deg >= it");
  if (!(max_second_ratio > 0.0)) return fail("max_second_ratio must be > 0");
  if (!(min_r > -1.0 && min_r < 1.0)) return fail("min_r must be in (-1, 1)");
  if (!(credible_r_gap >= 0.0)) return fail("credible_r_gap must be >= 0");
  return true;
}

MagneticMatcherConfig MagneticMatcherConfig::appliedTo(const MagneticMap& a,
                                                       const MagneticMap& b) const {
  MagneticMatcherConfig c = *this;
  if (!a.single_track && !b.single_track) return c;
  c.coarse_cell_size_m = single_track.coarse_cell_size_m;
  c.search.min_overlap_m2 = c.score.min_overlap_m2 = single_track.min_overlap_m2;
  c.search.area_per_sample_m2 = c.score.area_per_sample_m2 = single_track.area_per_sample_m2;
  c.score.stride = single_track.stride;
  c.search.mode_separation_m = single_track.mode_separation_m;
  c.refine_window_m = single_track.refine_window_m;
  c.refine_window_deg = single_track.refine_window_deg;
  c.min_z = single_track.min_z;
  c.min_r = single_track.min_r;
  return c;
}

double yawUncertainty(const MatchScorer& scorer, const PlanarTransform& T_a_b, double range_rad,
                      double step_rad) {
  const MatchScore best = scorer.evaluate(T_a_b);
  if (!std::isfinite(best.value) || !(best.r > 0.0)) return range_rad;
  // Profile log-likelihood of a correlation r over n independent samples: -n/2 · log(1 - r²).
  const double samples = best.samples;
  const auto log_likelihood = [samples](double r) {
    return -0.5 * samples * std::log(std::max(1e-12, 1.0 - r * r));
  };
  const double peak = log_likelihood(std::min(best.r, 1.0 - 1e-9));
  const Eigen::Vector2d centre_b = scorer.overlapCentroid(T_a_b);
  const Eigen::Vector2d centre_a = T_a_b.apply(centre_b);
  double widest = 0.0;
  for (const double side : {-1.0, 1.0}) {
    double delta = step_rad;
    for (; delta <= range_rad + 1e-12; delta += step_rad) {
      const double yaw = T_a_b.yaw_rad + side * delta;
      const Eigen::Vector2d t = centre_a - Eigen::Rotation2Dd(yaw) * centre_b;
      const MatchScore s = scorer.evaluate({t.x(), t.y(), yaw});
      if (!std::isfinite(s.value) || !(s.r > 0.0) ||
          log_likelihood(std::min(s.r, 1.0 - 1e-9)) < peak - 0.5)
        break;
    }
    widest = std::max(widest, std::min(delta, range_rad));
  }
  return widest;
}

namespace {

// What one search of a pair leaves for the next search of the same pair with the same config
// (coarse to fine, then the exhaustive sweep where it accepted no place): the coarse maps, each
// yaw's sweep, and each refined mode. Reused, they give the same answer to the bit.
struct SearchMemo {
  std::optional<std::pair<MagneticMap, MagneticMap>> coarse_maps;
  SweepMemo sweeps;
  /// A mode's refinement by its pose's bits and its seed.
  std::map<std::array<std::uint64_t, 4>, std::pair<CorrelationMode, MatchScore>> refined;
};

std::uint64_t bitsOf(double value) {
  std::uint64_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  return bits;
}

// One search over the yaws `search` covers, its modes refined and judged. A search of a compass
// window (`window`) whose coarse modes hold none with r >= credible_r stops there: nothing in it
// is worth refining, and the caller searches the full circle.
// What it can take from an earlier search of the pair, and leaves for a later one, is in `memo`.
MagneticMatchResult matchOnce(const MagneticMap& a, const MagneticMap& b,
                              const MagneticMatcherConfig& config, CorrelationSearchConfig search,
                              bool window, SearchMemo* memo) {
  const auto start = std::chrono::steady_clock::now();
  MagneticMatchResult result;

  MatchScoreConfig fine_score = config.score;
  const MatchScorer scorer(a, b, fine_score);
  // Every mode found, with its fine score once refined (its coarse score until then).
  struct Candidate {
    CorrelationMode mode;
    MatchScore score;
    bool refined = false;
  };
  std::vector<Candidate> candidates;
  const auto since = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  };
  if (config.global == GlobalSearchMethod::kPaperPso) {
    MatchScore best;
    const auto modes = paperGlobalPso(a, b, scorer, config, &result.evaluations, &best);
    candidates.push_back({modes.front(), best, true});
  } else {
    const int factor =
        std::max(1, static_cast<int>(std::round(config.coarse_cell_size_m / a.cell_size_m)));
    if (!memo->coarse_maps) memo->coarse_maps.emplace(downsample(a, factor), downsample(b, factor));
    for (const CorrelationMode& mode : correlationSearch(
             memo->coarse_maps->first, memo->coarse_maps->second, search, &memo->sweeps))
      candidates.push_back({mode, MatchScore{mode.z, mode.z, mode.r, mode.overlap_m2, 0}, false});
  }
  result.stage_seconds.search = since(start);
  const bool any_credible = std::any_of(candidates.begin(), candidates.end(), [&](const auto& c) {
    return c.mode.r >= search.credible_r;
  });
  if (candidates.empty() || (window && !any_credible)) {
    result.seconds = since(start);
    return result;
  }
  const auto refine_start = std::chrono::steady_clock::now();
  const auto refine = [&](std::size_t i) {
    const PlanarTransform& T = candidates[i].mode.T_a_b;
    const std::uint64_t seed = config.pso.seed + i;
    const std::array<std::uint64_t, 4> key{bitsOf(T.x_m), bitsOf(T.y_m), bitsOf(T.yaw_rad), seed};
    const auto known = memo->refined.find(key);
    if (known != memo->refined.end()) {
      std::tie(candidates[i].mode, candidates[i].score) = known->second;
    } else {
      std::tie(candidates[i].mode, candidates[i].score) =
          refineMode(scorer, candidates[i].mode, config, seed, &result.evaluations);
      memo->refined.emplace(key, std::make_pair(candidates[i].mode, candidates[i].score));
    }
    candidates[i].refined = true;
  };
  for (std::size_t i = 0; i < candidates.size() && static_cast<int>(i) < config.refine_modes; ++i)
    refine(i);

  // The best refined mode wins, among those the confidence rule could accept if there are any:
  // a mediocre correlation over a large overlap must not hide an excellent one over a small
  // overlap. The strongest credible mode distinct from it is the second; when that one is still
  // at its coarse score and would make the match ambiguous, it is refined and the choice made
  // again: a coarse z against a fine one is not a fair comparison (refinement lifts a sharp peak
  // more than a broad one).
  const bool correlation_rule = config.global == GlobalSearchMethod::kCorrelation;
  const auto acceptable = [&](const MatchScore& s) {
    return correlation_rule && s.z >= config.min_z && s.r >= config.min_r;
  };
  const auto better = [&](const Candidate& x, const Candidate& y) {
    const bool x_ok = acceptable(x.score), y_ok = acceptable(y.score);
    if (x_ok != y_ok) return x_ok;
    return x.score.value > y.score.value;
  };
  std::size_t best = 0, second = 0;
  double second_z = 0.0;
  for (;;) {
    best = 0;
    for (std::size_t i = 1; i < candidates.size(); ++i)
      if (candidates[i].refined &&
          (!candidates[best].refined || better(candidates[i], candidates[best])))
        best = i;
    const Candidate& top = candidates[best];
    second_z = 0.0;
    second = best;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      const Candidate& c = candidates[i];
      const bool distinct =
          translationDistance(c.mode.T_a_b, top.mode.T_a_b) > config.search.mode_separation_m ||
          yawDistance(c.mode.T_a_b, top.mode.T_a_b) > config.search.mode_separation_deg * kDeg;
      if (i != best && distinct && c.score.r >= top.score.r - config.credible_r_gap &&
          c.score.z > second_z)
        second_z = c.score.z, second = i;
    }
    const bool would_be_ambiguous =
        top.score.z > 0.0 && second_z / top.score.z > config.max_second_ratio;
    if (!correlation_rule || !would_be_ambiguous || candidates[second].refined) break;
    refine(second);
  }
  result.stage_seconds.refine = since(refine_start);
  const Candidate& top = candidates[best];
  result.T_a_b = top.mode.T_a_b;
  result.z = top.score.z;
  result.r = top.score.r;
  result.overlap_m2 = top.score.overlap_m2;
  result.fitness = top.score.value;
  result.second_mode_ratio = result.z > 0.0 ? second_z / result.z : 1.0;
  if (std::isfinite(result.fitness))
    result.overlap_statistics = scorer.overlapStatistics(result.T_a_b);
  // Best first, then the refined modes by value, then the rest in search order.
  std::vector<std::size_t> order(candidates.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    if ((x == best) != (y == best)) return x == best;
    if (candidates[x].refined != candidates[y].refined) return candidates[x].refined;
    return candidates[x].refined && better(candidates[x], candidates[y]);
  });
  for (std::size_t i : order) result.modes.push_back(candidates[i].mode);
  const bool confidence_rule = correlation_rule || config.paper_confidence_rule;
  if (!std::isfinite(result.fitness))
    result.verdict = MatchVerdict::kNoOverlap;
  else if (!confidence_rule)
    result.verdict = MatchVerdict::kMatch;  // the paper's rule
  else if (result.z < config.min_z || result.r < config.min_r)
    result.verdict = MatchVerdict::kNoOverlap;
  else if (result.second_mode_ratio > config.max_second_ratio)
    result.verdict = MatchVerdict::kAmbiguous;
  else
    result.verdict = MatchVerdict::kMatch;
  if (confidence_rule && std::isfinite(result.fitness)) {
    const auto yaw_start = std::chrono::steady_clock::now();
    result.yaw_uncertainty_deg =
        yawUncertainty(scorer, result.T_a_b, config.yaw_uncertainty_range_deg * kDeg,
                       config.yaw_uncertainty_step_deg * kDeg) /
        kDeg;
    if (result.verdict == MatchVerdict::kMatch &&
        result.yaw_uncertainty_deg > config.max_yaw_uncertainty_deg)
      result.verdict = MatchVerdict::kYawUncertain;
    result.stage_seconds.yaw_interval = since(yaw_start);
    MatchFeatures features = matchFeatures(result, a.single_track || b.single_track);
    result.probability = matchProbability(features, config.confidence_model);
    if (correlation_rule && config.confidence_model.decides) {
      // The place judged as if its yaw were known as well as the yaw rule asks: a place the
      // model trusts but whose yaw the field leaves open is yaw uncertain (the geometry may fix
      // the yaw), not absent. And as if it had no rival: a place convincing on its own with a
      // rival close behind is ambiguous (the geometry may choose between them); one that
      // convinces even alone is not offered to the geometry at all.
      features.log_yaw_uncertainty = std::min(
          features.log_yaw_uncertainty, std::log(std::max(config.max_yaw_uncertainty_deg, 0.1)));
      const double place_probability = matchProbability(features, config.confidence_model);
      features.second_mode_ratio = 0.0;
      const double alone_probability = matchProbability(features, config.confidence_model);
      const double min_probability = config.confidence_model.min_probability;
      if (result.probability >= min_probability &&
          result.yaw_uncertainty_deg <= config.max_yaw_uncertainty_deg)
        result.verdict = MatchVerdict::kMatch;
      else if (place_probability >= min_probability)
        result.verdict = MatchVerdict::kYawUncertain;
      else if (alone_probability >= min_probability &&
               result.second_mode_ratio > config.max_second_ratio)
        result.verdict = MatchVerdict::kAmbiguous;
      else
        result.verdict = MatchVerdict::kNoOverlap;
    }
  }
  result.seconds = since(start);
  return result;
}

// `later`, run after `earlier` had been refused, with the time `earlier` took added.
MagneticMatchResult after(MagneticMatchResult later, const MagneticMatchResult& earlier) {
  later.seconds += earlier.seconds;
  later.evaluations += earlier.evaluations;
  later.stage_seconds.search += earlier.stage_seconds.search;
  later.stage_seconds.refine += earlier.stage_seconds.refine;
  later.stage_seconds.yaw_interval += earlier.stage_seconds.yaw_interval;
  return later;
}

// The yaws `search` covers: by coarse to fine where it is on, and where that accepts no place,
// by the exhaustive sweep, which then decides. Coarse to fine can miss a place whose yaw no coarse
// peak ranked among the best (docs/benchmarks.md); it has not been seen to accept where the
// exhaustive sweep does not, or at another pose. So it only hastens a match, and every refusal,
// ambiguity or uncertain yaw is the exhaustive sweep's own.
// Without `fall_back`, coarse to fine's answer stands whatever it is (matchForProposals).
MagneticMatchResult matchSearched(const MagneticMap& a, const MagneticMap& b,
                                  const MagneticMatcherConfig& config,
                                  const CorrelationSearchConfig& search, bool window,
                                  bool fall_back) {
  SearchMemo memo;
  if (search.pyramid_factor <= 1 || config.global != GlobalSearchMethod::kCorrelation)
    return matchOnce(a, b, config, search, window, &memo);
  MagneticMatchResult fast = matchOnce(a, b, config, search, window, &memo);
  fast.coarse_to_fine = CoarseToFine::kAccepted;
  if (fast.overlap()) return fast;
  if (!fall_back) {
    fast.coarse_to_fine = CoarseToFine::kAlone;
    return fast;
  }
  // The exhaustive sweep takes the yaws coarse to fine swept on the fine cells, and the modes it
  // refined, from the memo: the same answer, without doing that work twice.
  CorrelationSearchConfig exhaustive = search;
  exhaustive.pyramid_factor = 1;
  MagneticMatchResult full = after(matchOnce(a, b, config, exhaustive, window, &memo), fast);
  full.coarse_to_fine = CoarseToFine::kFellBack;
  return full;
}

MagneticMatchResult matchMaps(const MagneticMap& a, const MagneticMap& b,
                              const MagneticMatcherConfig& stated, bool fall_back) {
  std::string error;
  if (!stated.IsValid(&error)) throw std::invalid_argument("magnetic matcher: " + error);
  const MagneticMatcherConfig config = stated.appliedTo(a, b);
  if (a.coveredCells() == 0 || b.coveredCells() == 0) return {};
  CorrelationSearchConfig search = config.search;
  search.channels = config.score.channels;
  search.statistic = config.score.statistic;
  if (!config.use_compass_prior || config.global != GlobalSearchMethod::kCorrelation)
    return matchSearched(a, b, config, search, false, fall_back);

  const CompassHeading compass = compassHeading(a, b);
  const auto described = [&](MagneticMatchResult r, CompassUse use) {
    r.compass = use;
    r.compass_yaw_deg = compass.yaw_rad / kDeg;
    r.compass_resultant = compass.resultant;
    return r;
  };
  if (compass.resultant < config.compass_min_resultant)
    return described(matchSearched(a, b, config, search, false, fall_back), CompassUse::kUntrusted);
  CorrelationSearchConfig windowed = search;
  windowed.yaw_centre_deg = compass.yaw_rad / kDeg;
  windowed.yaw_window_deg = config.compass_window_deg;
  const MagneticMatchResult within = matchSearched(a, b, config, windowed, true, fall_back);
  if (within.overlap()) return described(within, CompassUse::kWindow);
  // The window holds no place the confidence rule accepts: the compass may be off (a session
  // over steel, a calibration gone wrong), so the full circle decides, and the time spent on the
  // window is counted.
  return described(after(matchSearched(a, b, config, search, false, fall_back), within),
                   CompassUse::kFellBack);
}

}  // namespace

MagneticMatchResult matchMagneticMaps(const MagneticMap& a, const MagneticMap& b,
                                      const MagneticMatcherConfig& config) {
  return matchMaps(a, b, config, true);
}

MagneticMatchResult matchForProposals(const MagneticMap& a, const MagneticMap& b,
                                      const MagneticMatcherConfig& config) {
  return matchMaps(a, b, config, false);
}

MagneticMap buildSessionMap(const Session& session, const MagneticMatcherConfig& config,
                            SessionCalibration* calibration) {
  const SessionCalibration calibrated = calibrateMagnetometers(session, config.calibration);
  const std::vector<MagnetometerCalibration> used = calibrated.calibrations();
  if (calibration) *calibration = calibrated;
  return buildMagneticMap(placeFingerprints(session, &used), session.rig, config.map);
}

MagneticMatchResult matchSessions(const Session& a, const Session& b,
                                  const MagneticMatcherConfig& config) {
  const auto start = std::chrono::steady_clock::now();
  const MagneticMap map_a = buildSessionMap(a, config);
  const MagneticMap map_b = buildSessionMap(b, config);
  const double maps_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  MagneticMatchResult result = matchMagneticMaps(map_a, map_b, config);
  result.stage_seconds.maps = maps_seconds;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace mm4mm
