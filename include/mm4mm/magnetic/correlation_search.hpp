#pragma once
// Global stage of magnetic matching: for every yaw step, the masked normalised cross-correlation
// of the levelled components (B_h, B_v) of two coarse maps over every (x, y) shift at once, by
// FFT. Its score z = atanh(r) · sqrt(overlap area in m² − 3) weighs correlation by the evidence
// behind it, so a tiny overlap cannot win by chance.
//
// Coarse to fine (issue 33): with pyramid_factor > 1 the sweep over every yaw and shift runs
// first on maps that many times coarser (a quarter of the cells at 2, so a quarter of each
// transform) with yaw steps that many times coarser. The full sweep of every shift on the maps'
// own cells then runs only at the yaws near those of the coarse sweep's best peaks. At those yaws
// it finds what the exhaustive sweep finds, every local peak and not only the strongest, so the
// second mode that makes a match ambiguous is found as the exhaustive sweep finds it. A first
// version searched only a window of shifts about each coarse peak on the fine cells; it lost
// such second modes and accepted a wrong match the exhaustive sweep had refused
// (docs/benchmarks.md). Cartographer's branch and bound cannot be had here: its score is a sum over
// the scan's points of grid values, which each coarse cell's maximum bounds; a normalised
// cross-correlation has no such bound. So the search can miss where a bound could not:
// docs/benchmarks.md measures how often its answers differ from the exhaustive sweep's.

#include <cstdint>
#include <map>
#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/magnetic/match_channels.hpp"
#include "mm4mm/magnetic/planar_transform.hpp"

namespace mm4mm {

struct CorrelationSearchConfig {
  MatchChannels channels = MatchChannels::kLevelled;
  CorrelationStatistic statistic = CorrelationStatistic::kPearson;
  double yaw_step_deg = 2.0;
  double min_overlap_m2 = 15.0;  ///< shifts with less common coverage are not scored
  /// z counts one independent sample per this area (MatchScoreConfig::area_per_sample_m2).
  double area_per_sample_m2 = 1.0;
  /// Only yaws within `yaw_window_deg` of `yaw_centre_deg` are searched (180: the full circle).
  double yaw_centre_deg = 0.0;
  double yaw_window_deg = 180.0;
  int max_modes = 8;
  /// Candidates whose r reaches this rank before every candidate that does not, best z first
  /// within each group: a large overlap of mediocre correlation scores a high z too, and must not
  /// crowd a small, excellent overlap out of the few modes that get refined.
  double credible_r = 0.8;
  /// ... and whose overlap reaches this (m²; 0: any the search scores).
  double credible_min_overlap_m2 = 0.0;
  /// Two candidates are distinct modes when their translations differ by more than this or ...
  double mode_separation_m = 3.0;
  /// ... their yaws differ by more than this.
  double mode_separation_deg = 8.0;
  /// Coarse to fine: the sweep runs on maps this many times coarser (1: the exhaustive sweep on
  /// the maps' own cells). 2 by default: where it accepts no place the matcher runs the exhaustive
  /// sweep after it, which decides, and with every mode refined it gave the exhaustive sweep's
  /// decision and pose in every pair of the tuning worlds and of held-out seeds 11001-11010
  /// (docs/benchmarks.md, "Coarse to fine"; docs/heldout_set.md for the rule) ...
  int pyramid_factor = 2;
  /// ... keeping this many of its distinct peaks; ...
  int pyramid_candidates = 32;
  /// ... and the yaws of the best-ranked of them, up to this many distinct ones, are swept again
  /// on the maps' own cells (each with the fine yaws within half a coarse step of it).
  int pyramid_yaws = 8;

  bool IsValid(std::string* error) const;
};

/// One peak of the score over (x, y, yaw).
struct CorrelationMode {
  PlanarTransform T_a_b;  ///< maps map b's frame into map a's
  double z = 0.0;
  double r = 0.0;
  double overlap_m2 = 0.0;
};

/// What the sweeps on the maps' own cells found at each yaw they swept (each yaw's distinct
/// modes, keyed by the yaw's bits), so that a later search of the same two maps with the same
/// settings (but for pyramid_factor, pyramid_candidates, pyramid_yaws and the yaw window) takes
/// them instead of sweeping those yaws again: the exhaustive sweep the matcher runs after coarse
/// to fine refused a pair re-swept the up to 24 yaws coarse to fine had just swept. A yaw's modes
/// depend only on the maps, the yaw and those settings, so the answer is the same to the bit.
/// The caller keeps a memo to one pair of maps and one such config.
struct SweepMemo {
  std::map<std::uint64_t, std::vector<CorrelationMode>> per_yaw;
};

/// The best distinct modes, best first. Both maps must have the same cell size. With `memo`, the
/// yaws it holds are not swept again and the yaws swept on the maps' own cells are added to it.
std::vector<CorrelationMode> correlationSearch(const MagneticMap& a, const MagneticMap& b,
                                               const CorrelationSearchConfig& config,
                                               SweepMemo* memo = nullptr);

/// Ranks candidates (credible ones, r >= config.credible_r, before the rest; best z first within
/// each group) and keeps at most config.max_modes, dropping any within the mode separation of a
/// better-ranked one.
std::vector<CorrelationMode> distinctModes(std::vector<CorrelationMode> candidates,
                                           const CorrelationSearchConfig& config);

/// z-score of a correlation r over `samples` independent samples (the search counts one per m² of
/// overlap): atanh(r) · sqrt(samples − 3), Fisher's; 0 at 3 samples or fewer.
double correlationZ(double r, double samples);

/// Why an overlap of at least `min_overlap_m2`, counted at one sample per `area_per_sample_m2`,
/// cannot give z the more than 3 samples it needs; nullptr when it can. Every config that sets
/// both checks them with this.
const char* sampleCountProblem(double min_overlap_m2, double area_per_sample_m2);

}  // namespace mm4mm
