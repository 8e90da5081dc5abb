#pragma once
// Scores of a candidate planar transform between two magnetic maps, evaluated directly (bilinear
// look-ups in map a of map b's cells) at the maps' own resolution: what the fine stage and the
// paper's global PSO optimise.

#include <memory>
#include <string>
#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/magnetic/match_channels.hpp"
#include "mm4mm/magnetic/planar_transform.hpp"

namespace mm4mm {

enum class MatchScoreKind {
  /// z-scored masked normalised cross-correlation: atanh(r) · sqrt(overlap m² − 3).
  kCorrelation,
  /// The paper's Eq. 4–5: −Var(‖B_a − B_b‖) / sqrt(P), P the share of pairs whose |B| agree
  /// within `association_tolerance_uT` over the fingerprints of both maps (negated: higher is
  /// better).
  kPaperFitness,
  /// The paper's Eq. 6: Gaussian log-likelihood of the fingerprint differences (σ_B), averaged
  /// over the overlapping pairs so that overlaps of different size compare.
  kPaperLikelihood,
};

struct MatchScoreConfig {
  MatchScoreKind kind = MatchScoreKind::kCorrelation;
  MatchChannels channels = MatchChannels::kLevelled;
  CorrelationStatistic statistic = CorrelationStatistic::kPearson;
  double min_overlap_m2 = 15.0;  ///< below it a transform scores −infinity
  /// The overlap z counts one independent sample per this area (m²): z = atanh(r) ·
  /// sqrt(overlap / area_per_sample_m2 − 3). One m² is the search's and the rules' count; a
  /// Gaussian-process map of length scale ℓ decorrelates over about πℓ² (∫ρ² dA of its
  /// squared-exponential kernel), which counts a narrow strip of two tracks more fairly.
  double area_per_sample_m2 = 1.0;
  int stride = 3;                         ///< evaluate every stride-th cell of map b along x and y
  double association_tolerance_uT = 1.0;  ///< Eq. 5's As(·): |B| within this
  double sigma_B_uT = 1.0;                ///< Eq. 6

  bool IsValid(std::string* error) const;
};

struct MatchScore {
  double value = 0.0;  ///< the chosen kind's score; higher is better
  double z = 0.0;      ///< correlation z-score, whatever the kind
  double r = 0.0;
  double overlap_m2 = 0.0;
  double samples = 0.0;  ///< independent samples z counts: overlap_m2 / area_per_sample_m2
  int pairs = 0;
};

/// What two maps share under a transform: the scored cells of b that land on map a. The features
/// a match's confidence is judged by besides its score: a strip (one pass along a corridor) is
/// long and narrow, and an overlap of flat field holds little to match.
struct OverlapStatistics {
  int cells = 0;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();  ///< in b's frame (b's origin when empty)
  double length_m = 0.0;      ///< 4 σ of the cells along the overlap's principal axis
  double width_m = 0.0;       ///< 4 σ across it
  double field_std_uT = 0.0;  ///< spread of b's channel values there, pooled over channels
};

class MatchScorer {
 public:
  /// Keeps references to both maps, which must outlive the scorer.
  MatchScorer(const MagneticMap& a, const MagneticMap& b, const MatchScoreConfig& config);
  MatchScore evaluate(const PlanarTransform& T_a_b) const;

  /// A scorer over only those cells of b that land within `margin_m` of map a's coverage under
  /// `T_a_b`: the same scores for transforms within the margin of it, at a fraction of the cost.
  MatchScorer focusedOn(const PlanarTransform& T_a_b, double margin_m) const;
  /// Largest distance of a scored cell of b from b's origin (m): how far a yaw change moves it.
  double sampleReach() const;
  /// Centroid, in b's frame, of the scored cells of b that land on map a under `T_a_b` (b's
  /// origin when none does).
  Eigen::Vector2d overlapCentroid(const PlanarTransform& T_a_b) const;
  OverlapStatistics overlapStatistics(const PlanarTransform& T_a_b) const;

 private:
  static constexpr int kMaxValues = 3;
  /// A cell's channel values and total field, side by side: the look-ups of one evaluation touch
  /// four neighbouring cells per sample, and one array keeps them in one or two cache lines.
  struct Cell {
    float values[kMaxValues];
    float total;  ///< NaN where the cell is not covered
  };
  struct Sample {
    Eigen::Vector2d position;
    std::size_t index;
    float values[kMaxValues];  ///< b's channel values at yaw 0 (session-frame where they turn)
    float total;
  };
  bool lookUp(const Eigen::Vector2d& p, double* values, double* total) const;

  const MagneticMap& a_;
  const MagneticMap& b_;
  MatchScoreConfig config_;
  int channels_ = 0;
  /// Map a's cells; shared by the focused copies of this scorer.
  std::shared_ptr<const std::vector<Cell>> a_cells_;
  std::vector<Sample> samples_;
  double area_per_sample_m2_;
  std::size_t fingerprints_a_, fingerprints_b_;
};

}  // namespace mm4mm
