#pragma once
// Magnetic map matching (paper Section III-B.1, with the search that works on real buildings):
// an exhaustive FFT correlation over (x, y, yaw) at coarse resolution finds the distinct modes,
// Particle Swarm Optimization refines each at the fine resolution, and a confidence rule answers
// "no overlap" or "ambiguous" instead of a transform when the evidence is not there.
// The paper's Eq. 2 (MAP estimate of T_B) reduces with a flat prior to Eq. 3, the maximum
// likelihood of the maps' overlap. The default score (match_score.hpp) is a z-scored correlation;
// the paper's Eq. 4-5 fitness and Eq. 6 likelihood are kept as options and as baselines.

#include <string>
#include <vector>

#include "mm4mm/magnetic/correlation_search.hpp"
#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/magnetic/match_confidence.hpp"
#include "mm4mm/magnetic/match_score.hpp"
#include "mm4mm/magnetic/planar_transform.hpp"
#include "mm4mm/magnetic/pso.hpp"
#include "mm4mm/magnetic/self_calibration.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

enum class RefinementMethod {
  kPso,        ///< PSO inside each mode's neighbourhood (the paper's optimiser)
  kLocalGrid,  ///< exhaustive grid inside each mode's neighbourhood
  kNone,       ///< keep the coarse modes
};

enum class GlobalSearchMethod {
  kCorrelation,  ///< exhaustive FFT correlation over (x, y, yaw), then refinement
  kPaperPso,     ///< the paper's method: one PSO over the whole (x, y, yaw) box
};

struct MagneticMatcherConfig {
  /// Each session's magnetometers calibrated before its map is built (self_calibration.hpp).
  CalibrationConfig calibration;
  MagneticMapConfig map;            ///< fine maps (5 cm cells by default)
  double coarse_cell_size_m = 0.5;  ///< global search resolution
  GlobalSearchMethod global = GlobalSearchMethod::kCorrelation;
  CorrelationSearchConfig search;
  /// Search the yaws within ± compass_window_deg of the relative heading of the two sessions'
  /// mean horizontal fields first (compass_prior.hpp), where that heading is trusted (both maps'
  /// mean resultant length >= compass_min_resultant); the full circle where it is not, or where
  /// the window holds no place the confidence rule accepts. The correlation search only.
  bool use_compass_prior = false;
  double compass_window_deg = 15.0;
  double compass_min_resultant = 0.0;

  RefinementMethod refinement = RefinementMethod::kPso;
  /// How many coarse modes get refined up front; a further mode is refined when, still coarse,
  /// it would make the best one ambiguous. Every mode the sweep keeps (search.max_modes): with
  /// the best three, a strong right place ranked lower by its coarse score was never refined
  /// (docs/benchmarks.md, "Every mode refined"; docs/heldout_set.md for the rule that chose it).
  int refine_modes = 8;
  double refine_window_m = 0.75;   ///< ± around a mode's translation
  double refine_window_deg = 3.0;  ///< ± around a mode's yaw
  /// Each mode's refinement searches a small window: a smaller swarm that stops sooner than
  /// PsoConfig's defaults.
  PsoConfig pso = [] {
    PsoConfig c;
    c.particles = 24;
    c.iterations = 40;
    c.tolerance = 1e-4;
    c.stall_iterations = 10;
    return c;
  }();
  double grid_step_m = 0.05;   ///< kLocalGrid
  double grid_step_deg = 0.5;  ///< kLocalGrid
  MatchScoreConfig score;      ///< fine-stage score (and the paper PSO's)
  /// The paper's one PSO over the whole (x, y, yaw) box needs a large swarm and patience.
  PsoConfig paper_pso = [] {
    PsoConfig c;
    c.particles = 200;
    c.iterations = 150;
    c.stall_iterations = 30;
    return c;
  }();
  /// kPaperPso only: judge the PSO's answer by the confidence rule below (min_z, min_r,
  /// max_yaw_uncertainty_deg; its one answer has no second mode to be ambiguous with), as the
  /// correlation search's is. False is the paper's rule: any finite fitness is a match.
  bool paper_confidence_rule = false;

  /// Accept the best mode when z >= min_z, r >= min_r, and no credible distinct mode comes
  /// close: a distinct mode is credible when its r is within `credible_r_gap` of the best's, and
  /// close when its z is more than `max_second_ratio` of the best's. A large overlap of a
  /// mediocre correlation can reach the z of a small, excellent one; it is not the same place.
  /// Chosen on tuning seeds 1-6 with the 7-sensor array's realistic sensors, calibrated
  /// (scripts/choose_thresholds.py on docs/bench/match_tuning_array.csv).
  double min_z = 8.0;
  double min_r = 0.825;
  double max_second_ratio = 0.75;
  double credible_r_gap = 0.1;
  /// A match whose yaw is known no better than this (the one-sigma half-width of its yaw interval,
  /// see `yawUncertainty`) is refused as kYawUncertain: on a narrow swath the translation can be
  /// right and the yaw several degrees off, and a near miss is worse than a refusal. 2° is the
  /// yaw a placed pair must be right to (the alignment tolerance every benchmark here counts
  /// with): a match whose one-sigma interval is wider cannot claim it. (It was first set after
  /// the Aalto near misses; this is the argument that keeps it.)
  double max_yaw_uncertainty_deg = 2.0;
  /// How far either side of the best yaw that interval is searched, in `yaw_uncertainty_step_deg`
  /// steps; an interval reaching the end counts as this wide.
  double yaw_uncertainty_range_deg = 8.0;
  double yaw_uncertainty_step_deg = 0.1;

  /// Where either map is one magnetometer's track (MagneticMap::single_track) its swath is a
  /// metre or two wide: two tracks share a few m² where two arrays share tens, and a z that
  /// counts one sample per m² cannot reach the array's threshold whatever the correlation. The
  /// search and the confidence rule then use these values instead of the ones above.
  /// The search values were first copied from a config chosen on the real Aalto recordings
  /// (commit 0cc4865); each follows from the single-track map's geometry instead, stated beside
  /// it, for a Gaussian-process length scale ℓ of 0.25-0.4 m (GaussianProcessMapConfig: 0.25 m).
  struct SingleTrack {
    /// About one length scale: the coarse grid samples the field as finely as it varies (the
    /// array's 0.5 m would leave one or two cells across a track's swath).
    double coarse_cell_size_m = 0.25;
    /// z counts one independent sample per πℓ² (MatchScoreConfig::area_per_sample_m2), ℓ the
    /// Gaussian-process map's length scale (0.25 m): its values decorrelate over that area, as
    /// the joint stage counts them (JointMatchConfig::single_track). A track's common swath with
    /// another is often 1-4 m² (one pass each), which one sample per m² left under the 3 samples
    /// z needs. Overlaps from 1 m² (5 samples), search and score alike.
    double min_overlap_m2 = 1.0;
    double area_per_sample_m2 = 0.196;
    /// Every second 5 cm cell: 0.1 m, at most 0.4 ℓ, below which a GP mean's neighbouring
    /// cells add little; three would thin a swath under a metre wide to a few samples across.
    int stride = 2;
    /// Modes 1 m apart (2.5-4 ℓ) lie on distinct correlation peaks: a field of length scale ℓ
    /// correlates with itself shifted by 1 m at exp(-1/(4ℓ²)), 0.2 at 0.4 m, 0.02 at 0.25 m.
    double mode_separation_m = 1.0;
    /// A coarse peak lies within half a coarse cell and one yaw step of the fine one: the
    /// refinement searches a little over a cell (0.3 m) and two yaw steps (4°) either side.
    double refine_window_m = 0.3;
    double refine_window_deg = 4.0;
    /// Chosen at this count on the procedural tuning worlds (seeds 1-20, imu and handheld rigs,
    /// the rule opened up: bench/matcher_thin_features.yaml) by scripts/choose_thresholds.py on
    /// docs/bench/field_thin_*.csv (docs/bench/field_thin_thresholds.md): no separate pair and no
    /// misplaced overlap accepted, with a step of margin in z and r. The field alone as it runs
    /// (yaw rule included) then aligns 78 of 108 overlapping pairs, against 68 at one sample per m²
    /// (z >= 2.5, r >= 0.825), none wrong; the field and joint stages together give the same
    /// answers as before (docs/bench/field_thin_joint_*.csv: 101 of 108).
    double min_z = 3.5;
    double min_r = 0.85;

    bool IsValid(std::string* error) const;
  } single_track;

  /// The probability that a match's best mode is right (match_confidence.hpp), reported with
  /// every match of the correlation search.
  MatchConfidenceConfig confidence_model;

  /// This config as it applies to maps `a` and `b`: the single-track values where either is one.
  MagneticMatcherConfig appliedTo(const MagneticMap& a, const MagneticMap& b) const;

  bool IsValid(std::string* error) const;
};

/// How the compass prior shaped a match.
enum class CompassUse {
  kOff,        ///< not used (use_compass_prior false, or the paper's PSO)
  kUntrusted,  ///< the heading was not trusted: the full circle was searched
  kWindow,     ///< the match was found within the compass window
  kFellBack,   ///< the window held no accepted place: the full circle was searched after it
};
std::string toString(CompassUse use);

/// How coarse to fine (CorrelationSearchConfig::pyramid_factor > 1) shaped a match.
enum class CoarseToFine {
  kOff,       ///< the exhaustive sweep alone
  kAccepted,  ///< coarse to fine found a place the confidence rule accepts
  kFellBack,  ///< it did not: the exhaustive sweep was run after it and decided
  kAlone,     ///< its answer stands whatever it is (matchForProposals: the modes are
              ///< proposals that another test decides among)
};
std::string toString(CoarseToFine use);

enum class MatchVerdict {
  kMatch,
  kNoOverlap,
  kAmbiguous,     ///< another distinct place correlates nearly as well
  kYawUncertain,  ///< one place, but its yaw is known no better than max_yaw_uncertainty_deg
};
std::string toString(MatchVerdict verdict);

struct MagneticMatchResult {
  MatchVerdict verdict = MatchVerdict::kNoOverlap;
  PlanarTransform T_a_b;  ///< best estimate, also when the verdict refuses it
  double z = 0.0;         ///< fine-stage correlation z-score of the best mode
  double r = 0.0;
  double overlap_m2 = 0.0;
  double fitness = 0.0;  ///< the configured score's value at the best mode
  /// z of the best credible mode that is distinct from the best, over the best's z (0 when none).
  double second_mode_ratio = 0.0;
  /// Half-width of the best mode's yaw interval (deg, see `yawUncertainty`); 0 when not computed
  /// (no overlap found, or the paper's PSO).
  double yaw_uncertainty_deg = 0.0;
  /// The confidence model's probability that the best mode is the right place (0 when there is
  /// no mode, or for the paper's PSO without its confidence rule).
  double probability = 0.0;
  /// The best mode's overlap: its extent and shape, and how much field it holds.
  OverlapStatistics overlap_statistics;
  int evaluations = 0;
  double seconds = 0.0;
  CompassUse compass = CompassUse::kOff;
  double compass_yaw_deg = 0.0;    ///< the compass's relative heading (when not kOff)
  double compass_resultant = 0.0;  ///< its trust: the smaller mean resultant length
  CoarseToFine coarse_to_fine = CoarseToFine::kOff;
  /// Where `seconds` went: both sessions' maps (matchSessions only), the global search, the
  /// refinement of its modes and the yaw interval of the best.
  struct StageSeconds {
    double maps = 0.0, search = 0.0, refine = 0.0, yaw_interval = 0.0;
  } stage_seconds;
  /// Every mode of the global search: the best first, then the other refined modes (those the
  /// confidence rule could accept first, then by score), then the unrefined ones at their coarse
  /// pose.
  std::vector<CorrelationMode> modes;

  bool overlap() const { return verdict == MatchVerdict::kMatch; }
};

/// How well the yaw of `T_a_b` is known (rad): the half-width of the yaw interval, turned about
/// the centroid of the overlap so that no translation is traded for yaw, over which the profile
/// log-likelihood of the correlation, −A/2 · log(1 − r²) for A independent samples (one per m²
/// of overlap at `T_a_b`, as z counts them), stays within 0.5 of its value at `T_a_b`: a one-sigma
/// interval by Wilks' theorem. The two sides are searched to `range_rad` in `step_rad` steps and
/// the wider side counts; an interval that reaches the end, or a pose that scores no overlap, is
/// `range_rad` wide.
double yawUncertainty(const MatchScorer& scorer, const PlanarTransform& T_a_b, double range_rad,
                      double step_rad);

/// Matches fine map b against fine map a. `seed` drives the PSO.
MagneticMatchResult matchMagneticMaps(const MagneticMap& a, const MagneticMap& b,
                                      const MagneticMatcherConfig& config);

/// As matchMagneticMaps, but where coarse to fine (search.pyramid_factor > 1) accepts no place its
/// answer stands (CoarseToFine::kAlone) instead of the exhaustive sweep's: for a caller that takes
/// only the modes, as proposals another test decides among (the joint stage's structure match,
/// JointMatchConfig::structure_pyramid_factor). Its verdict is then not the exhaustive sweep's,
/// and its modes may lack a place whose yaw no coarse peak ranked among the best.
MagneticMatchResult matchForProposals(const MagneticMap& a, const MagneticMap& b,
                                      const MagneticMatcherConfig& config);

/// A session's fine map with its magnetometers calibrated as `config.calibration` says (the
/// calibration used is returned in `calibration` when it is not null).
MagneticMap buildSessionMap(const Session& session, const MagneticMatcherConfig& config,
                            SessionCalibration* calibration = nullptr);

/// Builds both sessions' fine maps (calibrated) and matches them.
MagneticMatchResult matchSessions(const Session& a, const Session& b,
                                  const MagneticMatcherConfig& config);

}  // namespace mm4mm
