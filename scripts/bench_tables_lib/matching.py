"""Generators of docs/benchmarks.md's (and README.md's) regions on matching: realistic
magnetometers (issue 14: field statistics, threshold tuning, held-out matching, joint matching,
sensor variants, held-out merges, the Aalto sessions), the simulator bench, match_bench on clean
sensors (default, paper methods) and refinement.
"""
from .common import (MatchSummary, block, f, fx, inline, md_table, median, one, pct, rows, scaled, select,
                     span, summary, table)


# ---------------------------------------------------------------------------------------------
# docs/benchmarks.md: realistic magnetometers (issue 14)

def field_statistics_table(name):
    """One row per session of docs/bench/NAME (scripts/field_statistics.py): readings, bh_std_uT
    and bv_std_uT (%.1f), rho_0.25m..rho_2m (%.2f), correlation_length_m (%.1f; nan, no distance
    up to 3 m below 0.5, prints '> 3')."""
    body = []
    for r in rows(name):
        length = r["correlation_length_m"]
        length = "> 3" if length == "nan" else fx(f(r, "correlation_length_m"), 1)
        body.append([r["session"], r["readings"], f"{fx(f(r, 'bh_std_uT'), 1)}", f"{fx(f(r, 'bv_std_uT'), 1)}"]
                    + [f"{fx(f(r, c), 2)}" for c in ("rho_0.25m", "rho_0.5m", "rho_1m", "rho_2m")] + [length])
    return table(["session", "readings", "B_h std (µT)", "B_v std (µT)", "ρ(0.25 m)", "ρ(0.5 m)", "ρ(1 m)",
                  "ρ(2 m)", "correlation length (ρ < 0.5, m)"], body)


@block("field-statistics")
def field_statistics():
    """docs/bench/field_statistics.csv (scripts/field_statistics.py): field_statistics_table."""
    return field_statistics_table("field_statistics.csv")


@block("field-statistics-procedural")
def field_statistics_procedural():
    """docs/bench/field_statistics_procedural.csv (scripts/procedural_field_statistics.sh):
    field_statistics_table, one row per procedural building (clean sensors, tuning seeds 1-15) and
    per Aalto sequence."""
    return field_statistics_table("field_statistics_procedural.csv")


@block("procedural-tuning")
def procedural_tuning():
    """docs/bench/procedural_tuning_{imu,husky3,array7,handheld}.csv (scripts/procedural_tuning.sh,
    acceptance opened up): per rig, overlapping pairs (ground truth), those whose best mode is
    aligned (0.5 m, 2 deg), those the thresholds accept aligned and wrong (z >= 8, r >= 0.825;
    imu and handheld z >= 3, r >= 0.85, the rule of the length scale 0.4 m these rows were run
    at; second-mode ratio <= 0.75; yaw uncertainty <= 2 deg), separate pairs and those the
    thresholds accept."""
    body = []
    for rig in ("imu", "handheld", "husky3", "array7"):
        data = rows(f"procedural_tuning_{rig}.csv")
        single = rig in ("imu", "handheld")
        min_z, min_r = (3.0, 0.85) if single else (8.0, 0.825)

        def accept(r):
            return (f(r, "z") >= min_z and f(r, "r") >= min_r and f(r, "second_mode_ratio") <= 0.75
                    and f(r, "yaw_uncertainty_deg") <= 2.0)
        overlapping = [r for r in data if one(r, "overlapping")]
        separate = [r for r in data if one(r, "separate")]
        best = sum(one(r, "aligned") for r in overlapping)
        right = sum(accept(r) and one(r, "aligned") for r in overlapping)
        wrong = sum(accept(r) and not one(r, "aligned") for r in overlapping)
        false = sum(accept(r) for r in separate)
        body.append([rig, str(len(overlapping)), pct(best, len(overlapping)), pct(right, len(overlapping)),
                     str(wrong), str(len(separate)), str(false)])
    return table(["rig", "overlapping pairs", "best mode aligned", "thresholds accept, aligned",
                  "thresholds accept, misplaced", "separate pairs", "separate accepted"], body)


@block("gp-length-scale")
def gp_length_scale():
    """docs/bench/gp_length_scale_{0.25,0.6}_{imu,handheld}.csv and procedural_tuning_{imu,handheld}.csv
    (0.4 m) (scripts/choose_gp_length_scale.sh): per length scale, overlapping pairs whose best mode
    is aligned, the separate pairs' highest z (its r), and what two single-track rules accept
    aligned / wrong (misplaced overlaps and separate pairs), as scripts/choose_gp_length_scale.py
    counts them: the old one chosen at 0.4 m (z >= 3, r >= 0.85) and the one chosen at 0.25 m
    (z >= 2.5, r >= 0.825), both with second-mode ratio <= 0.75 and yaw <= 2 deg."""
    body = []
    for scale in ("0.25", "0.4", "0.6"):
        names = ([f"procedural_tuning_{rig}.csv" for rig in ("imu", "handheld")] if scale == "0.4"
                 else [f"gp_length_scale_{scale}_{rig}.csv" for rig in ("imu", "handheld")])
        data = [r for name in names for r in rows(name)]
        overlapping = [r for r in data if one(r, "overlapping")]
        separate = [r for r in data if one(r, "separate")]

        def outcome(min_z, min_r):
            def accept(r):
                return (f(r, "z") >= min_z and f(r, "r") >= min_r and f(r, "second_mode_ratio") <= 0.75
                        and f(r, "yaw_uncertainty_deg") <= 2.0)
            right = sum(accept(r) and one(r, "aligned") for r in overlapping)
            wrong = sum(accept(r) and not one(r, "aligned") for r in overlapping) + sum(accept(r) for r in separate)
            return f"{right} / {wrong}"
        aligned = sum(one(r, "aligned") for r in overlapping)
        worst = max(separate, key=lambda r: f(r, "z"))
        body.append([scale, f"{aligned} of {len(overlapping)}", str(len(separate)),
                     f"{fx(f(worst, 'z'), 2)} ({fx(f(worst, 'r'), 3)})", outcome(3.0, 0.85), outcome(2.5, 0.825)])
    return table(["length scale (m)", "overlapping pairs, best mode aligned", "separate pairs",
                  "highest separate z (its r)", "z >= 3, r >= 0.85 accept aligned / wrong",
                  "z >= 2.5, r >= 0.825 accept aligned / wrong"], body)


def threshold_outcome(name, min_z, min_r, max_second_ratio=0.75):
    """scripts/choose_thresholds.py's outcome(): over docs/bench/NAME, a row is accepted when
    z >= min_z, r >= min_r and second_mode_ratio <= 0.75; returns (accepted and aligned,
    accepted and not aligned, overlapping rows, separate rows accepted, separate rows)."""
    right = wrong = overlapping = false = disjoint = 0
    for r in rows(name):
        accept = f(r, "z") >= min_z and f(r, "r") >= min_r and f(r, "second_mode_ratio") <= max_second_ratio
        if one(r, "overlapping"):
            overlapping += 1
            right += accept and one(r, "aligned")
            wrong += accept and not one(r, "aligned")
        elif one(r, "separate"):
            disjoint += 1
            false += accept
    return right, wrong, overlapping, false, disjoint


@inline("tuning-imu-pick")
def tuning_imu_pick():
    """docs/bench/match_tuning.csv under the picked rule z >= 3, r >= 0.85 (threshold_outcome)."""
    right, wrong, n, false, d = threshold_outcome("match_tuning.csv", 3.0, 0.85)
    return f"{right} of {n} overlapping pairs aligned, {wrong} wrong, {false} of {d} disjoint accepted"


@inline("tuning-array-pick")
def tuning_array_pick():
    """docs/bench/match_tuning_array.csv under the picked rule z >= 8, r >= 0.825."""
    right, wrong, n, false, d = threshold_outcome("match_tuning_array.csv", 8.0, 0.825)
    return f"{right} of {n} aligned, {wrong} wrong, {false} of {d} disjoint"


@inline("tuning-array-old")
def tuning_array_old():
    """docs/bench/match_tuning_array.csv under the old rule z >= 9, r >= 0.9: aligned of overlapping."""
    right, _, n, _, _ = threshold_outcome("match_tuning_array.csv", 9.0, 0.9)
    return f"{right} of those {n}"


JOINT_METHODS = [("default", "field alone"), ("joint", "joint"), ("geometry", "geometry alone")]


@block("heldout-joint")
def heldout_joint():
    """docs/bench/match_heldout_joint.csv, per preset (warehouse, corridor) and method:
    MatchSummary; 'accepted at a wrong place' = overlapping rows accepted but not aligned (with
    overlap_error_m / _deg when there are any); median seconds over all of the group's rows."""
    body = []
    for preset in ("warehouse", "corridor"):
        for method, label in JOINT_METHODS:
            s = summary("match_heldout_joint.csv", preset=preset, method=method)
            wrong = str(len(s.wrong))
            if s.wrong:
                wrong += " (" + ", ".join(f"{fx(f(r, 'overlap_error_m'), 0)} m, {fx(f(r, 'overlap_error_deg'), 0)}° off"
                                          for r in s.wrong) + ")"
            body.append([preset, label, f"{s.success}/{s.overlapping}", f"{s.wide_success}/{s.wide}", wrong,
                         f"{s.false_overlaps}/{s.disjoint}", f"{fx(s.seconds, 1)}"])
    return table(["preset", "method", "overlapping pairs aligned", "of those sharing ≥ 15 m²",
                  "accepted at a wrong place", "disjoint pairs accepted", "median s per pair"], body)


HELDOUT = [("warehouse", "imu"), ("warehouse", "array7"), ("random", "imu"), ("random", "array7"),
           ("corridor", "imu"), ("corridor", "array7")]


def heldout(preset, rig):
    return summary(f"match_heldout_{rig}.csv", preset=preset, rig=rig)


@block("heldout-matching")
def heldout_matching():
    """docs/bench/match_heldout_imu.csv and match_heldout_array7.csv, per preset and rig:
    MatchSummary (aligned of overlapping, aligned of those with swath_overlap_m2 >= 15, median
    overlap error over the overlapping pairs, accepted of the separate pairs)."""
    body = []
    for preset, rig in HELDOUT:
        s = heldout(preset, rig)
        wide = s.wide_cell() if s.wide else "0/0 (no pair shares 15 m²)"
        label = "imu (1 sensor)" if (preset, rig) == ("warehouse", "imu") else rig
        body.append([preset, label, s.success_cell(), wide, s.errors(), f"{s.false_overlaps}/{s.disjoint}"])
    return table(["preset", "rig", "overlapping pairs aligned (< 0.5 m, 2°)",
                  "of those whose swaths share ≥ 15 m² at the truth", "median overlap error (m / °)",
                  "disjoint pairs accepted"], body)


def heldout_imu_all():
    return [heldout(p, "imu") for p in ("warehouse", "random", "corridor")]


@inline("heldout-imu-false")
def heldout_imu_false():
    """match_heldout_imu.csv: separate pairs accepted of separate pairs, all presets."""
    ss = heldout_imu_all()
    return f"{sum(s.false_overlaps for s in ss)} false overlaps in {sum(s.disjoint for s in ss)} disjoint single-sensor pairs"


@inline("heldout-imu-wide-range")
def heldout_imu_wide_range():
    """match_heldout_imu.csv: the range over presets of aligned / overlapping pairs with
    swath_overlap_m2 >= 15 (presets with no such pair left out), in %."""
    return span([100.0 * s.wide_success / s.wide for s in heldout_imu_all() if s.wide], 0) + " %"


@inline("heldout-imu-range")
def heldout_imu_range():
    """match_heldout_imu.csv: the range over presets of aligned / overlapping pairs, in %."""
    return span([100.0 * s.success / s.overlapping for s in heldout_imu_all()], 0) + " %"


@inline("heldout-array-range")
def heldout_array_range():
    """match_heldout_array7.csv: the range over presets of aligned / overlapping pairs, in %."""
    ss = [heldout(p, "array7") for p in ("warehouse", "random", "corridor")]
    return span([100.0 * s.success / s.overlapping for s in ss], 0) + " %"


@inline("heldout-array-wide-range")
def heldout_array_wide_range():
    """match_heldout_array7.csv: the range over presets of aligned / overlapping pairs with
    swath_overlap_m2 >= 15, in %."""
    ss = [heldout(p, "array7") for p in ("warehouse", "random", "corridor")]
    return span([100.0 * s.wide_success / s.wide for s in ss if s.wide], 0) + " %"


@inline("heldout-imu-misses")
def heldout_imu_misses():
    """match_heldout_imu.csv: overlapping pairs not aligned, counted by verdict."""
    misses = [r for s in heldout_imu_all() for r in s.over if not one(r, "aligned")]
    count = lambda v: sum(r["verdict"] == v for r in misses)
    return (f"the {len(misses)} misses: {count('no overlap')} refused as no overlap, "
            f"{count('ambiguous')} ambiguous, and {count('yaw uncertain')} refused as yaw uncertain")


SENSOR_VARIANTS = [("clean", "none", "clean"), ("realistic", "none", "uncalibrated"),
                   ("realistic", "true", "true calibration given"),
                   ("realistic", "estimated", "calibrated by the pipeline")]


@block("heldout-sensors")
def heldout_sensors():
    """docs/bench/match_heldout_sensors_{imu,array7}.csv (clean, uncalibrated, true calibration)
    and, for 'calibrated by the pipeline', the rows of seeds 1001-1003 of the warehouse in
    match_heldout_{imu,array7}.csv: aligned of overlapping pairs; accepted not aligned with their
    overlap_error_m / _deg; separate pairs accepted."""
    body = []
    for rig, label in (("imu", "one magnetometer"), ("array7", "7-sensor array")):
        cells = [label]
        false = disjoint = 0
        for sensors, calibration, _ in SENSOR_VARIANTS:
            if calibration == "estimated":
                data = [r for r in rows(f"match_heldout_{rig}.csv")
                        if r["preset"] == "warehouse" and r["sensors"] == sensors
                        and r["calibration"] == calibration and 1001 <= int(r["seed"]) <= 1003]
            else:
                data = select(rows(f"match_heldout_sensors_{rig}.csv"), sensors=sensors, calibration=calibration)
            s = MatchSummary(data)
            cell = f"{s.success}/{s.overlapping}"
            if s.wrong:
                cell += ", **" + ", ".join(f"1 accepted {fx(f(r, 'overlap_error_m'), 2)} m / "
                                           f"{fx(f(r, 'overlap_error_deg'), 1)}° off" for r in s.wrong) + "**"
            elif s.success == 0:
                cell += " (all refused)"
            cells.append(cell)
            false += s.false_overlaps
            disjoint += s.disjoint
        cells.append(f"{false}/{disjoint}")
        body.append(cells)
    return table(["warehouse seeds 1001-1003"] + [v[2] for v in SENSOR_VARIANTS] +
                 ["disjoint pairs accepted (all four)"], body)


MERGE_VARIANTS = [("clean", "none", "clean"), ("realistic", "estimated", "realistic, calibrated"),
                  ("realistic", "none", "realistic, uncalibrated")]


def merge_heldout(preset, sensors, calibration):
    """docs/bench/merge_heldout.csv (merge_bench --csv): pair rows (pair != all) give aligned of
    overlapping and, over connected pairs only, the median overlap error; the per-seed 'all'
    rows give ate_m and odometry_ate_m, of which the medians."""
    data = select(rows("merge_heldout.csv"), preset=preset, sensors=sensors, calibration=calibration)
    pairs = [r for r in data if r["pair"] != "all"]
    seeds = [r for r in data if r["pair"] == "all"]
    connected = [r for r in pairs if one(r, "connected")]
    return dict(pairs=len(pairs), aligned=sum(one(r, "aligned") for r in pairs), connected=len(connected),
                et=median([f(r, "overlap_error_m") for r in connected]),
                er=median([f(r, "overlap_error_deg") for r in connected]),
                ate=median([f(r, "ate_m") for r in seeds]), odo=median([f(r, "odometry_ate_m") for r in seeds]))


@block("merge-heldout")
def merge_heldout_table():
    """docs/bench/merge_heldout.csv per preset and sensor variant (merge_heldout())."""
    body = []
    for preset in ("warehouse", "corridor"):
        for sensors, calibration, label in MERGE_VARIANTS:
            m = merge_heldout(preset, sensors, calibration)
            aligned = f"{m['aligned']}/{m['pairs']}" + (" (nothing connected)" if not m["connected"] else "")
            errors = f"{fx(m['et'], 3)} / {fx(m['er'], 3)}" if m["connected"] else "–"
            body.append([preset, label, aligned, errors, f"{fx(m['ate'], 3)} / {fx(m['odo'], 3)}"])
    return table(["preset", "sensors", "overlapping pairs aligned",
                  "median overlap error after the solve (m / °)",
                  "ATE after solve / odometry at true frames (m)"], body)


@inline("merge-heldout-translation")
def merge_heldout_translation():
    """merge_heldout.csv: median overlap translation error of the calibrated rows, warehouse and
    corridor, in cm."""
    return " and ".join(f"{fx(scaled(merge_heldout(p, 'realistic', 'estimated')['et'], 100), 1)}"
                        for p in ("warehouse", "corridor")) + " cm"


@inline("merge-heldout-rotation")
def merge_heldout_rotation():
    """merge_heldout.csv: range of the median overlap rotation errors of every connected row."""
    values = [merge_heldout(p, s, c)["er"] for p in ("warehouse", "corridor") for s, c, _ in MERGE_VARIANTS
              if merge_heldout(p, s, c)["connected"]]
    return span(values, 2) + "°"


AALTO_GROUPS = [("1-5", "1–5, unchanged field"), ("6-9", "6–9, shelves brought in"),
                ("across", "across the two groups")]


def aalto(group):
    """docs/bench/aalto_invensense.csv (scripts/eval_aalto.py --csv), rows of one group: best mode
    right = best_mode_correct 1 (< 0.5 m, 2°); accepted = verdict 'match'."""
    g = select(rows("aalto_invensense.csv"), group=group)
    accepted = [r for r in g if r["verdict"] == "match"]
    right = [r for r in accepted if one(r, "best_mode_correct")]
    return dict(n=len(g), best=sum(one(r, "best_mode_correct") for r in g), accepted=len(accepted),
                right=len(right), wrong=len(accepted) - len(right), rows=g)


@block("aalto-default")
def aalto_default():
    """docs/bench/aalto_invensense.csv per group (aalto())."""
    body = []
    for group, label in AALTO_GROUPS:
        a = aalto(group)
        body.append([f"{label} ({a['n']})", a["best"], a["accepted"], a["right"], a["wrong"]])
    return table(["pairs", "best mode right (< 0.5 m, 2°)", "accepted", "accepted and right",
                  "accepted and wrong"], body)


@inline("aalto-unchanged-accepted")
def aalto_unchanged_accepted():
    """aalto_invensense.csv, group 1-5: accepted of all pairs."""
    a = aalto("1-5")
    return f"{a['accepted']} of {a['n']}"


@inline("aalto-unchanged-right")
def aalto_unchanged_right():
    """aalto_invensense.csv, group 1-5: accepted and right (< 0.5 m, 2°)."""
    return str(aalto("1-5")["right"])


@inline("aalto-unchanged-best")
def aalto_unchanged_best():
    """aalto_invensense.csv, group 1-5: best_mode_correct of all pairs."""
    a = aalto("1-5")
    return f"{a['best']} of {a['n']}"


@inline("aalto-unchanged-swath")
def aalto_unchanged_swath():
    """aalto_invensense.csv, group 1-5, every pair: range of overlap_m2 (the best mode's common
    swath)."""
    g = aalto("1-5")["rows"]
    return f"{span([f(r, 'overlap_m2') for r in g], 1)} m²"


# ---------------------------------------------------------------------------------------------
# docs/benchmarks.md: simulator, matching on clean sensors

@block("sim-bench")
def sim_bench():
    """docs/bench/sim_bench.md (sim_bench prints Markdown only; no CSV): its table as printed,
    the last column's '(all threads)' read as this machine's 2."""
    t = md_table("sim_bench.md")
    header = list(t[0].keys())
    header[-1] = header[-1].replace("(all threads)", "(2 threads)")
    return table(header, [list(r.values()) for r in t])


@inline("sim-warehouse-seconds")
def sim_warehouse_seconds():
    """docs/bench/sim_bench.md (no CSV): the warehouse row's seconds per session, rounded to 0.1 s."""
    row = [r for r in md_table("sim_bench.md") if r["world"] == "warehouse"][0]
    return f"{fx(float(list(row.values())[-1]), 1)} s"


PRESETS = ["corridor", "random", "warehouse"]


@block("match-default")
def match_default():
    """docs/bench/match_bench_default.csv per preset (method default): MatchSummary."""
    body = []
    for preset in PRESETS:
        s = summary("match_bench_default.csv", preset=preset, method="default")
        body.append([preset, s.overlapping, s.success_cell(), s.wide_cell(), s.errors(), s.frames(),
                     s.disjoint, s.false_cell(), f"{fx(s.seconds, 2)}"])
    return table(["preset", "overlapping pairs", "success", "success where the swath is >= 15 m²",
                  "median overlap error (m / °)", "median e_t (m) / e_r (°)", "pairs without overlap",
                  "false overlaps", "median s per match"], body)


def plain_rows(name, method_presets):
    body = []
    for preset, method in method_presets:
        s = summary(name, preset=preset, method=method)
        body.append([preset, method, s.overlapping, s.success_cell(), s.errors(), s.frames(), s.disjoint,
                     s.false_cell(), f"{fx(s.seconds, 2)}"])
    return table(["preset", "method", "overlapping pairs", "success", "median overlap error (m / °)",
                  "median e_t (m) / e_r (°)", "pairs without overlap", "false overlaps",
                  "median s per match"], body)


@block("match-paper")
def match_paper():
    """docs/bench/match_bench_paper.csv per preset, method paper: MatchSummary."""
    return plain_rows("match_bench_paper.csv", [(p, "paper") for p in PRESETS])


REFINERS = ["compass", "concordance", "default", "grid", "none"]


@block("match-refinement")
def match_refinement():
    """docs/bench/match_refinement.csv, warehouse, per method: MatchSummary."""
    return plain_rows("match_refinement.csv", [("warehouse", m) for m in REFINERS])


def default_summaries():
    return {p: summary("match_bench_default.csv", preset=p, method="default") for p in PRESETS}


@inline("match-default-false")
def match_default_false():
    """match_bench_default.csv: accepted separate pairs of separate pairs, all presets."""
    ss = default_summaries().values()
    return f"{sum(s.false_overlaps for s in ss)} false overlaps in {sum(s.disjoint for s in ss)} pairs without overlap"


@inline("match-default-refusals")
def match_default_refusals():
    """match_bench_default.csv: overlapping pairs not aligned, all presets."""
    return str(sum(s.overlapping - s.success for s in default_summaries().values()))


@inline("match-default-disjoint")
def match_default_disjoint():
    """match_bench_default.csv: the number of separate pairs, all presets."""
    return str(sum(s.disjoint for s in default_summaries().values()))


def rate(s):
    return f"{fx(100.0 * s.success / s.overlapping, 0)} %"


@inline("match-first-run")
def match_first_run():
    """match_bench_paper.csv, method default (the first run's default rows): success rate per
    preset, warehouse / random / corridor."""
    return " / ".join(rate(summary("match_bench_paper.csv", preset=p, method="default"))
                      for p in ("warehouse", "random", "corridor"))


@inline("match-warehouse")
def match_warehouse():
    """match_bench_default.csv, warehouse: success rate."""
    return rate(default_summaries()["warehouse"])


@inline("match-warehouse-wide")
def match_warehouse_wide():
    """match_bench_default.csv, warehouse: success rate among pairs with swath_overlap_m2 >= 15."""
    s = default_summaries()["warehouse"]
    return f"{fx(100.0 * s.wide_success / s.wide, 0)} %"


@inline("match-random")
def match_random():
    """match_bench_default.csv, random: success rate."""
    return rate(default_summaries()["random"])


@inline("match-corridor")
def match_corridor():
    """match_bench_default.csv, corridor: success rate."""
    return rate(default_summaries()["corridor"])


@inline("match-paper-range")
def match_paper_range():
    """match_bench_paper.csv, method paper: range of the success rates over presets."""
    values = [100.0 * s.success / s.overlapping for s in
              (summary("match_bench_paper.csv", preset=p, method="paper") for p in PRESETS)]
    return span(values, 0, "–") + " %"


@inline("refinement-default-seconds")
def refinement_default_seconds():
    """match_refinement.csv, method default: median seconds per match."""
    return f"{fx(summary('match_refinement.csv', method='default').seconds, 2)} s"


@inline("refinement-compass-seconds")
def refinement_compass_seconds():
    """match_refinement.csv, method compass: median seconds per match."""
    return f"{fx(summary('match_refinement.csv', method='compass').seconds, 2)} s"


@inline("match-default-warehouse-seconds")
def match_default_warehouse_seconds():
    """match_bench_default.csv, warehouse: median seconds per match."""
    return f"{fx(default_summaries()['warehouse'].seconds, 2)} s"


# README's summary of issue 14's held-out figures

@inline("readme-joint-warehouse")
def readme_joint_warehouse():
    """match_heldout_joint.csv, warehouse: MatchSummary's aligned / overlapping of method joint,
    then of method default (the field alone), and the seeds."""
    joint = summary("match_heldout_joint.csv", preset="warehouse", method="joint")
    field = summary("match_heldout_joint.csv", preset="warehouse", method="default")
    seeds = sorted({int(r["seed"]) for r in select(rows("match_heldout_joint.csv"), preset="warehouse")})
    return (f"{joint.success}/{joint.overlapping} warehouse pairs instead of {field.success}/{field.overlapping} "
            f"(seeds {seeds[0]}-{seeds[-1]})")


@inline("readme-geometry-warehouse")
def readme_geometry_warehouse():
    """match_heldout_joint.csv, warehouse, method geometry: aligned of overlapping, and the
    accepted-not-aligned rows' overlap_error_m."""
    s = summary("match_heldout_joint.csv", preset="warehouse", method="geometry")
    wrong = ", ".join(f"{fx(f(r, 'overlap_error_m'), 0)} m off" for r in s.wrong)
    return f"place {s.success} of {s.overlapping} right and accept {len(s.wrong)}" + (f" ({wrong})" if wrong else "")


@inline("readme-uncalibrated-imu")
def readme_uncalibrated_imu():
    """match_heldout_sensors_imu.csv, sensors realistic, calibration none: aligned of overlapping,
    and the accepted-not-aligned rows' overlap_error_m."""
    s = MatchSummary(select(rows("match_heldout_sensors_imu.csv"), sensors="realistic", calibration="none"))
    wrong = ", ".join(f"{fx(f(r, 'overlap_error_m'), 1)} m off" for r in s.wrong)
    return f"aligns {s.success} of {s.overlapping} warehouse pairs and accepts {len(s.wrong)}" + (f" ({wrong})" if wrong else "")


@inline("readme-merge-heldout")
def readme_merge_heldout():
    """merge_heldout.csv (merge_heldout()), sensors realistic, calibration estimated: warehouse
    aligned / pairs with its median overlap error (cm / °), then corridor aligned / pairs."""
    w = merge_heldout("warehouse", "realistic", "estimated")
    c = merge_heldout("corridor", "realistic", "estimated")
    return (f"{w['aligned']}/{w['pairs']} warehouse pairs ({fx(scaled(w['et'], 100), 1)} cm / {fx(w['er'], 2)}° median "
            f"overlap error) and {c['aligned']}/{c['pairs']} corridor pairs")


@block("match-speed")
def match_speed():
    """docs/bench/match_speed.csv (scripts/match_speed.sh): per label (the code's commit, "+" for
    uncommitted changes on it) and thread count, over warehouse seeds 1-5 (s0 + s1): median match
    time and its global search, median of the per-seed ratios to PCL GICP on the same pair's point
    maps in the same run, and the pairs whose verdict and pose (0.01 m, 0.01 deg) equal the first
    label's."""
    data = rows("match_speed.csv")
    labels = list(dict.fromkeys(r["label"] for r in data))
    reference = {(r["seed"], r["threads"]): r for r in data if r["label"] == labels[0]}

    def same(r, ref):
        return (r["verdict"] == ref["verdict"] and abs(f(r, "x_m") - f(ref, "x_m")) <= 0.01
                and abs(f(r, "y_m") - f(ref, "y_m")) <= 0.01
                and abs(f(r, "yaw_deg") - f(ref, "yaw_deg")) <= 0.01)
    body = []
    for label in labels:
        for threads in sorted({r["threads"] for r in data if r["label"] == label}, key=int, reverse=True):
            runs = [r for r in data if r["label"] == label and r["threads"] == threads]
            ratios = [f(r, "match_s") / f(r, "gicp_s") for r in runs]
            kept = sum(same(r, reference[(r["seed"], threads)]) for r in runs
                       if (r["seed"], threads) in reference)
            body.append([label, threads, str(len(runs)), fx(median([f(r, "match_s") for r in runs]), 2),
                         fx(median([f(r, "search_s") for r in runs]), 2), fx(median(ratios), 2),
                         f"{kept} of {len(runs)}"])
    return table(["code", "threads", "pairs", "match (s, median)", "global search (s)",
                  "match / GICP (median ratio)", "same answer as " + labels[0]], body)


@block("refusal-cost")
def refusal_cost():
    """docs/bench/refusal_cost.csv (bench/refusal_cost_bench): per label and the field's verdict
    (accepted, refused), over the six pairs of warehouse seeds 1-2: the pairs, the median field
    match as merge runs it, the median exhaustive sweep alone and the median per-pair ratio of the
    two (the ratio is the figure to compare across runs), the pairs whose answer the default and the
    exhaustive sweep share, and the medians of the structure maps (both sessions) and their match,
    which merge's joint stage adds to a refused pair."""
    data = rows("refusal_cost.csv")
    body = []
    for label in dict.fromkeys(r["label"] for r in data):
        for kind, refused in (("accepted", False), ("refused", True)):
            runs = [r for r in data if r["label"] == label and (r["verdict"] != "match") == refused]
            if not runs:
                continue
            body.append([label, kind, str(len(runs)), fx(median([f(r, "match_s") for r in runs]), 2),
                         fx(median([f(r, "exhaustive_s") for r in runs]), 2),
                         fx(median([f(r, "match_s") / f(r, "exhaustive_s") for r in runs]), 2),
                         f"{sum(r['same'] == 'yes' for r in runs)} of {len(runs)}",
                         fx(median([f(r, "structure_maps_s") for r in runs]), 2),
                         fx(median([f(r, "structure_match_s") for r in runs]), 2)])
    return table(["code", "field says", "pairs", "field match (s, median)", "exhaustive sweep alone (s)",
                  "match / exhaustive (median ratio)", "same answer", "structure maps (s)",
                  "structure match (s)"], body)


@block("change-bench")
def change_bench():
    """docs/bench/change_bench.csv (bench/change_bench): per label and rig, over the seeds run, the
    pairs of connected sessions on one side of the change (both before or both after: every region
    they report is false) and across it: how many, how many report a region, their regions' summed
    area, and the area of cells past the threshold outside regions and in them."""
    data = rows("change_bench.csv")
    body = []
    for label in dict.fromkeys(r["label"] for r in data):
        for rig in dict.fromkeys(r["rig"] for r in data if r["label"] == label):
            for side, across in (("one side", "0"), ("across", "1")):
                runs = [r for r in data if r["label"] == label and r["rig"] == rig and r["across_change"] == across]
                if not runs:
                    continue
                seeds = sorted({int(r["seed"]) for r in runs})
                body.append([label, rig, f"{seeds[0]}-{seeds[-1]}", side, str(len(runs)),
                             str(sum(int(r["regions"]) > 0 for r in runs)),
                             fx(sum(f(r, "region_area_m2") for r in runs), 1),
                             fx(sum(f(r, "changed_m2") for r in runs), 1),
                             fx(sum(f(r, "compared_m2") for r in runs), 0)])
    return table(["code", "rig", "seeds", "pairs", "pairs compared", "with a region", "region area (m², sum)",
                  "cells past the threshold (m², sum)", "compared (m², sum)"], body)


@block("change-score")
def change_score():
    """docs/bench/change_score.csv: the tuning cases (change_score_table)."""
    return change_score_table("change_score.csv")


@block("heldout-change")
def heldout_change():
    """docs/bench/heldout_change.csv: the held-out cases (SEEDS=heldout scripts/change_score.sh,
    docs/heldout_set.md), as change_score_table."""
    return change_score_table("heldout_change.csv")


def change_score_table(name):
    """docs/bench/NAME (scripts/change_score.sh, bench/change_bench): per label, world,
    rig and side of the change, over the seeds run, the connected session pairs: how many share
    cells (and were compared: a pair with a session whose calibration could not check itself is
    not), how many report a region, their regions' summed area, the truly changed area both sessions cover (|ΔB| >= 1 µT,
    and >= 5 µT), recall (the truly changed area inside a region over the truly changed area
    compared, at each threshold) and precision (region area on truly changed cells over all region
    area). On one side of the change nothing changed: every region is false."""
    data = rows(name)
    body = []

    def ratio(x, y):
        return f"{100.0 * x / y:.0f} %" if y > 0 else "–"

    for label in dict.fromkeys(r["label"] for r in data):
        for world in ("changed", "unchanged"):
            for rig in dict.fromkeys(r["rig"] for r in data if r["label"] == label):
                for side, across in (("one side", "0"), ("across", "1")):
                    runs = [r for r in data if r["label"] == label and r["world"] == world and
                            r["rig"] == rig and r["across_change"] == across]
                    if not runs:
                        continue
                    seeds = sorted({int(r["seed"]) for r in runs})
                    region = sum(f(r, "region_area_m2") for r in runs)
                    true, found = sum(f(r, "true_m2") for r in runs), sum(f(r, "true_found_m2") for r in runs)
                    strong = sum(f(r, "strong_m2") for r in runs)
                    strong_found = sum(f(r, "strong_found_m2") for r in runs)
                    body.append([label, world, rig, f"{seeds[0]}-{seeds[-1]}", side, str(len(runs)),
                                 str(sum(f(r, "compared_m2") > 0 for r in runs)),
                                 str(sum(int(r["regions"]) > 0 for r in runs)), fx(region, 1),
                                 fx(true, 1), fx(strong, 1), ratio(found, true), ratio(strong_found, strong),
                                 ratio(found, region) if across == "1" else "–"])
    return table(["code", "world", "rig", "seeds", "pairs", "pairs placed", "compared", "with a region",
                  "region area (m², sum)", "truly changed, compared (m², ≥ 1 µT)", "(m², ≥ 5 µT)",
                  "recall ≥ 1 µT", "recall ≥ 5 µT", "precision"], body)


def search_check(name, fast, label, short, seeds=None, alignment=False, base="exhaustive"):
    """docs/bench/NAME (scripts/search_check.sh FAST): per world and rig, the pairs match_bench
    forms (four per world, overlapping or not) matched with the faster search FAST and with the
    exhaustive search; for the compass, how often the window found the match (not falling back to
    the full circle); the pairs where both gave the same accept/refuse decision, among the pairs
    both accepted those whose poses agree within 0.1 m and 0.5 deg, the pairs where only one
    accepted with that one's aligned count, the ratio of the summed match times (FAST /
    exhaustive), and the median seconds of the global search and of the whole match per method.
    With ALIGNMENT, also each method's accepted pairs that are aligned with the truth and those
    that are not (wrong acceptances). BASE names the method FAST is compared with (exhaustive; joint
    for the joint stage's proposals, which adds how many pairs the field refused, the pairs the
    joint stage ran on)."""
    data = [r for r in rows(name) if seeds is None or int(r["seed"]) in seeds]
    pairs = {}
    for r in data:
        world = "warehouse" if r["preset"] == "warehouse" else "procedural"
        pairs.setdefault((world, r["rig"], r["seed"], r["pair"]), {})[r["method"]] = r
    body = []
    groups = list(dict.fromkeys((k[0], k[1]) for k in pairs))
    for world, rig in groups:
        both = [v for k, v in pairs.items() if (k[0], k[1]) == (world, rig) and len(v) == 2]
        window = sum(v[fast]["compass"] == "window" for v in both)
        same_decision = sum(v[fast]["accepted"] == v[base]["accepted"] for v in both)
        accepted = [v for v in both if v[fast]["accepted"] == "1" and v[base]["accepted"] == "1"]

        def close(v):
            c, e = v[fast], v[base]
            dyaw = abs((f(c, "yaw_deg") - f(e, "yaw_deg") + 180.0) % 360.0 - 180.0)
            return (((f(c, "x_m") - f(e, "x_m")) ** 2 + (f(c, "y_m") - f(e, "y_m")) ** 2) ** 0.5 <= 0.1
                    and dyaw <= 0.5)
        only_fast = [v for v in both if v[fast]["accepted"] == "1" and v[base]["accepted"] == "0"]
        only_exhaustive = [v for v in both if v[fast]["accepted"] == "0" and v[base]["accepted"] == "1"]
        seconds = [sum(f(v[m], "seconds") for v in both) for m in (fast, base)]
        refused = sum(v[base]["accepted"] == "0" or v[base].get("stage") == "joint" for v in both)
        body.append([world, rig, str(len(both))] + ([str(window)] if fast == "compass" else []) +
                    ([str(refused)] if base == "joint" else []) +
                    [str(same_decision),
                     f"{sum(close(v) for v in accepted)} of {len(accepted)}",
                     f"{len(only_fast)} ({sum(v[fast]['aligned'] == '1' for v in only_fast)} aligned)",
                     f"{len(only_exhaustive)} ({sum(v[base]['aligned'] == '1' for v in only_exhaustive)} aligned)",
                     fx(seconds[0] / seconds[1], 2)] +
                    ([" / ".join(str(sum(v[m]["accepted"] == "1" and v[m]["aligned"] == aligned
                                         for v in both)) for m in (fast, base))
                      for aligned in ("1", "0")] if alignment else []) +
                    [" / ".join(fx(median([f(v[m], column) for v in both]), 2) for m in (fast, base))
                     for column in ("search_s", "seconds")])
    return table(["world", "rig", "pairs"] + (["found in the window"] if fast == "compass" else []) +
                 (["refused by the field"] if base == "joint" else []) +
                 ["same decision", "same pose (both accepted)", f"accepted by {label} only",
                  f"accepted by {base} only", f"time {short} / {base}"] +
                 ([f"accepted and aligned ({short} / {base})", "accepted, not aligned (the same)"]
                  if alignment else []) +
                 [f"global search, s ({short} / {base}, median)", "whole match, s (the same)"], body)


@block("compass-check")
def compass_check():
    """search_check of docs/bench/compass_check.csv: the compass window (issue 33 slice 2)."""
    return search_check("compass_check.csv", "compass", "the compass", "compass")


@block("pyramid-check")
def pyramid_check():
    """search_check of docs/bench/pyramid_check.csv: coarse to fine over x, y (issue 33 slice 3)."""
    return search_check("pyramid_check.csv", "pyramid", "coarse to fine", "coarse to fine")


@block("pyramid-check-z")
def pyramid_check_z():
    """search_check of docs/bench/pyramid_check_z.csv (NAME=pyramid_check_z
    scripts/search_check.sh pyramid): coarse to fine with its coarse peaks ranked by z alone."""
    return search_check("pyramid_check_z.csv", "pyramid", "coarse to fine", "coarse to fine")


@block("pyramid-check-cells")
def pyramid_check_cells():
    """search_check of docs/bench/pyramid_check_cells.csv (NAME=pyramid_check_cells
    scripts/search_check.sh pyramid): coarse to fine whose coarse peaks count as credible only
    with the cells of the fine search's smallest overlap."""
    return search_check("pyramid_check_cells.csv", "pyramid", "coarse to fine", "coarse to fine")


@block("refine-all-check")
def refine_all_check():
    """search_check of docs/bench/refine_all_check.csv (scripts/search_check.sh refine_all): every
    mode of the exhaustive sweep refined (refine_modes = max_modes) against the best three."""
    return search_check("refine_all_check.csv", "refine_all", "every mode refined", "every mode",
                        alignment=True)


@block("joint-pyramid-check")
def joint_pyramid_check():
    """search_check of docs/bench/joint_pyramid_check.csv (scripts/search_check.sh joint_pyramid):
    the joint stage with its structure modes proposed by coarse to fine, against the joint stage
    as merge runs it (the exhaustive sweep of the structure maps)."""
    return search_check("joint_pyramid_check.csv", "joint_pyramid", "coarse-to-fine proposals",
                        "proposals by coarse to fine", alignment=True, base="joint")


@block("heldout-joint-pyramid")
def heldout_joint_pyramid():
    """search_check of docs/bench/heldout_joint_pyramid.csv (scripts/heldout.sh's joint_pyramid
    part, seeds 16001-16005, docs/heldout_set.md)."""
    return search_check("heldout_joint_pyramid.csv", "joint_pyramid", "coarse-to-fine proposals",
                        "proposals by coarse to fine", alignment=True, base="joint")


@block("heldout-refine-all")
def heldout_refine_all():
    """search_check of docs/bench/heldout_refine_all.csv (scripts/heldout.sh's refine_all part,
    seeds 12001-12010, docs/heldout_set.md)."""
    return search_check("heldout_refine_all.csv", "refine_all", "every mode refined", "every mode",
                        alignment=True)


@inline("refine-all-cost")
def refine_all_cost():
    """refine_all_check.csv and heldout_refine_all.csv: the summed match time of refine_all over
    the exhaustive (three-mode) sweep's in the same runs, tuning and held out."""
    ratios = []
    for name in ("refine_all_check.csv", "heldout_refine_all.csv"):
        data = rows(name)
        total = {m: sum(f(r, "seconds") for r in data if r["method"] == m)
                 for m in ("refine_all", "exhaustive")}
        ratios.append(fx(total["refine_all"] / total["exhaustive"], 2))
    return f"was {ratios[0]}× (tuning) and {ratios[1]}× (held out)"


@block("pyramid-check-all-modes")
def pyramid_check_all_modes():
    """search_check of docs/bench/pyramid_check_all_modes.csv (NAME=pyramid_check_all_modes
    scripts/search_check.sh pyramid): coarse to fine that falls back, both searches refining every
    mode (docs/heldout_set.md, seeds 11001-11010 fixed for its held-out run)."""
    return search_check("pyramid_check_all_modes.csv", "pyramid", "coarse to fine",
                        "coarse to fine", alignment=True)


@block("field-seams-mixed-heights")
def field_seams_mixed_heights():
    """field_seams of docs/bench/field_seams_mixed_heights.csv: the mixed sets (a handheld first
    session, imu robots) on the tuning worlds, the fused map at one height (78d6b40)."""
    return field_seams("field_seams_mixed_heights.csv")


@block("field-seams-mixed-heights-hard-iron")
def field_seams_mixed_heights_hard_iron():
    """field_seams_hard_iron of docs/bench/field_seams_mixed_heights_hard_iron.csv."""
    return field_seams_hard_iron("field_seams_mixed_heights_hard_iron.csv")


@block("field-seams-procedural-handheld")
def field_seams_procedural_handheld():
    """field_seams of docs/bench/field_seams_procedural_handheld.csv: handheld sessions in the
    procedural buildings at tuning seeds, the Earth's field stated, anchored on it (3ddb859) and on
    the sessions' own vertical estimates (fbfc95f)."""
    return field_seams("field_seams_procedural_handheld.csv")


@block("field-seams-procedural-handheld-hard-iron")
def field_seams_procedural_handheld_hard_iron():
    """field_seams_hard_iron of docs/bench/field_seams_procedural_handheld_hard_iron.csv."""
    return field_seams_hard_iron("field_seams_procedural_handheld_hard_iron.csv")


@block("heldout-pyramid")
def heldout_pyramid():
    """search_check of docs/bench/heldout_pyramid.csv (scripts/heldout.sh's pyramid part): coarse
    to fine against the exhaustive sweep on the held-out seeds 2001-2010 (the version of 41a34de;
    a later version's seeds, 4001 and up, get a table of their own)."""
    return search_check("heldout_pyramid.csv", "pyramid", "coarse to fine", "coarse to fine",
                        seeds=range(2001, 3001))


@block("heldout-pyramid-4001")
def heldout_pyramid_4001():
    """search_check of docs/bench/heldout_pyramid.csv at seeds 4001 and up: coarse to fine with a
    coarse peak credible only with enough cells (5e9628e), on the held-out set fixed for it."""
    return search_check("heldout_pyramid.csv", "pyramid", "coarse to fine", "coarse to fine",
                        seeds=range(4001, 5001))


@block("heldout-pyramid-5001")
def heldout_pyramid_5001():
    """search_check of docs/bench/heldout_pyramid.csv at seeds 5001 and up: coarse to fine that
    falls back on the exhaustive sweep wherever it accepts no place, on the held-out set fixed
    for it."""
    return search_check("heldout_pyramid.csv", "pyramid", "coarse to fine", "coarse to fine",
                        seeds=range(5001, 6001))


@block("heldout-pyramid-11001")
def heldout_pyramid_11001():
    """search_check of docs/bench/heldout_pyramid.csv at seeds 11001 and up: coarse to fine that
    falls back, both searches refining every mode, on the held-out set fixed for it."""
    return search_check("heldout_pyramid.csv", "pyramid", "coarse to fine", "coarse to fine",
                        seeds=range(11001, 12001), alignment=True)


@block("field-height")
def field_height():
    """docs/bench/field_height.csv (bench/field_height_bench on the tuning worlds): per height,
    over the worlds, the median and the lowest of each world's median local r (B_v, B_h) between
    the true field at the robot's magnetometer height and at that height."""
    data = rows("field_height.csv")
    body = []
    for height in sorted({r["height_m"] for r in data}, key=float):
        mine = [r for r in data if r["height_m"] == height]
        base = float(mine[0]["base_height_m"])
        cells = []
        for column in ("median_r_vertical", "median_r_horizontal"):
            values = [f(r, column) for r in mine]
            cells.append(f"{fx(median(values), 3)} ({fx(min(values, key=float), 3)})")
        body.append([height, f"{float(height) - base:.1f}", str(len(mine))] + cells)
    return table(["height above the floor (m)", "apart from the robot's (m)", "worlds",
                  "B_v: median r over the worlds (lowest world)", "B_h: the same"], body)



@block("floor-height")
def floor_height():
    """docs/bench/floor_height.csv (bench/floor_height_bench on the tuning worlds): per rig, over
    every session and frame height, how many found a floor, the median and largest
    |estimate - truth| of the frame's height above the floor from the scans, and the lowest and
    median contrast of the floors found; then the real scans' rows (no truth)."""
    data = rows("floor_height.csv")
    body = []
    simulated = [r for r in data if r["preset"] != "real"]
    for rig in dict.fromkeys(r["rig"] for r in simulated):
        mine = [r for r in simulated if r["rig"] == rig]
        found = [r for r in mine if r["found"] == "1"]
        errors = [abs(float(r["error_m"])) for r in found]
        contrasts = [float(r["contrast"]) for r in found]
        heights = sorted({float(r["true_m"]) for r in mine})
        body.append([rig, ", ".join(sorted({r["preset"] for r in mine})),
                     ", ".join(f"{h:g}" for h in heights),
                     str(len({(r["preset"], r["seed"], r["session"]) for r in mine})),
                     f"{len(found)} of {len(mine)}",
                     f"{median(errors) * 100:.1f}" if errors else "–",
                     f"{max(errors) * 100:.1f}" if errors else "–",
                     f"{min(contrasts):.0f} / {median(contrasts):.0f}" if contrasts else "–"])
    for r in data:
        if r["preset"] != "real":
            continue
        body.append([f"real scan ({r['session']})", "koide3's pair, outdoors", "unknown", "1",
                     "found" if r["found"] == "1" else "none",
                     f"(lowest surface {float(r['estimate_m']):.2f} m below)" if r["estimate_m"]
                     else "–", "–", r["contrast"] or "–"])
    return table(["rig", "worlds", "frame above the floor (m)", "sessions", "floor found",
                  "median error (cm)", "largest error (cm)", "contrast, lowest / median"], body)

def field_seams_placement(name="field_seams_placement.csv"):
    """docs/bench/field_seams_placement.csv (scripts/placement_check.sh; `name` another file of
    its rows, written by field_seams_bench --placement-csv): per code label, preset and rig, the
    merges, their sessions, how many were placed against how many the first session's group of
    the spanning tree held (what the atlas placed while it took the first session's frame), the
    merges whose frame is another session's, the placed pairs that overlap by the truth and how
    many are aligned (0.5 m, 2 deg), and the largest frame error over the merges."""
    data = rows(name)
    keys = list(dict.fromkeys((r["label"], r["preset"], r["rig"]) for r in data))
    body = []
    for label, preset, rig in keys:
        mine = [r for r in data if (r["label"], r["preset"], r["rig"]) == (label, preset, rig)]
        sessions = sum(int(r["sessions"]) for r in mine)
        placed = sum(int(r["placed"]) for r in mine)
        first = sum(int(r["first_session_group"]) for r in mine)
        moved = sum(r["frame"] != "s0" for r in mine)
        pairs = sum(int(r["true_pairs"]) for r in mine)
        aligned = sum(int(r["aligned_pairs"]) for r in mine)
        e_t = max(float(r["largest_e_t_m"]) for r in mine)
        e_r = max(float(r["largest_e_r_deg"]) for r in mine)
        body.append([label, preset, rig, str(len(mine)), f"{placed} of {sessions}",
                     f"{first} of {sessions}", f"{moved} of {len(mine)}", pct(aligned, pairs),
                     f"{e_t:.2f} m / {e_r:.2f}°"])
    return table(["code", "world", "rig", "merges", "sessions placed",
                  "in the first session's group", "frame not the first session's",
                  "placed pairs overlapping by the truth: aligned", "largest frame error"], body)


@block("field-seams-placement")
def field_seams_placement_tuning():
    """The tuning worlds' rows (scripts/placement_check.sh), tabled as field_seams_placement."""
    return field_seams_placement()


@block("field-seams")
def field_seams(name="field_seams.csv"):
    """docs/bench/field_seams.csv (scripts/field_seams.sh; `name` another file of its rows): per code label, preset and rig, the
    sessions' pairs placed in one atlas that share cells, the median over those pairs of the
    median absolute cell difference in B_F, B_v and B_h (the seams), and the median over seeds of
    the fused map's median absolute error against the simulator's true field, and where the rows
    have it (site), the range over seeds of the true field's median at the covered cells minus
    the Earth's main field, in B_v and B_F."""
    data = rows(name)
    keys = list(dict.fromkeys((r["label"], r["preset"], r["rig"]) for r in data))
    body = []
    for label, preset, rig in keys:
        mine = [r for r in data if (r["label"], r["preset"], r["rig"]) == (label, preset, rig)]
        pairs = [r for r in mine if r["row"] == "pair"]
        fused = [r for r in mine if r["row"] == "fused"]

        def med(rs, column):
            return fx(median([f(r, column) for r in rs]), 1) if rs else "–"
        site = [r for r in mine if r["row"] == "site"]
        steel = ("–" if not site else
                 f"{span([f(r, 'd_vertical_uT') for r in site], 1, ' to ')} / "
                 f"{span([f(r, 'd_total_uT') for r in site], 1, ' to ')}")
        body.append([label, preset, rig, str(len(fused)), str(len(pairs)),
                     " / ".join(med(pairs, c) for c in ("abs_total_uT", "abs_vertical_uT", "abs_horizontal_uT")),
                     " / ".join(med(fused, c) for c in ("abs_total_uT", "abs_vertical_uT", "abs_horizontal_uT")),
                     steel])
    return table(["code", "world", "rig", "seeds", "pairs sharing cells",
                  "between sessions, absolute ΔB_F / ΔB_v / ΔB_h (µT, median)",
                  "fused map against the truth, the same",
                  "true field's median − Earth's, B_v / B_F (µT, seeds' range)"], body)


@block("field-seams-hard-iron")
def field_seams_hard_iron(name="field_seams_hard_iron.csv"):
    """docs/bench/field_seams_hard_iron.csv (scripts/field_seams.sh; `name` another file of its
    rows): per code label (":sum0" =
    no Earth field stated), world and rig, the placed sessions' first sensor's vertical bias (the
    error along z in the Earth's vertical field, which a level body cannot observe): what the
    calibration alone leaves, |true_vertical_bias_uT - calibrated_vertical_bias_uT|, and what is
    left in the atlas's B_v once the fused map's offset is added, |residual_after_offset_uT|:
    median and largest, and how many within 1 µT, all and split by whether the session observed
    its own vertical (a tilting body) or was level; then, where the rows have it, what is left at
    the session's typical forward speed (|residual_at_speed_uT|: the drive current's field along z
    included, which the map's B_v is read with)."""
    data = [r for r in rows(name) if one(r, "placed")]
    keys = list(dict.fromkeys((r["label"], r["preset"], r["rig"]) for r in data))
    body = []
    for label, preset, rig in keys:
        mine = [r for r in data if (r["label"], r["preset"], r["rig"]) == (label, preset, rig)]
        alone = [abs(float(r["true_vertical_bias_uT"]) - float(r["calibrated_vertical_bias_uT"]))
                 for r in mine]
        after = [abs(float(r["residual_after_offset_uT"])) for r in mine]
        moving = [abs(float(r["residual_at_speed_uT"])) for r in mine
                  if r.get("residual_at_speed_uT") not in (None, "")]
        within = [abs(float(r["residual_after_offset_uT"])) <= 1.0 for r in mine]
        observing = [w for w, r in zip(within, mine) if r["vertical_observed"] == "1"]
        level = [w for w, r in zip(within, mine) if r["vertical_observed"] != "1"]
        body.append([label, preset, rig, len(mine),
                     f"{fx(median(alone), 1)} / {fx(max(alone), 1)}",
                     f"{fx(median(after), 1)} / {fx(max(after), 1)}",
                     f"{sum(within)} of {len(within)}",
                     f"{sum(observing)} of {len(observing)} / {sum(level)} of {len(level)}",
                     "–" if len(moving) < len(mine) else
                     f"{fx(median(moving), 1)} / {fx(max(moving), 1)}, "
                     f"{sum(e <= 1.0 for e in moving)} of {len(moving)}"])
    return table(["code", "world", "rig", "sessions placed",
                  "calibration alone: vertical bias left, median / largest (µT)",
                  "with the fused map's offset: median / largest (µT)", "within 1 µT",
                  "of them, sessions that observed their vertical / level ones",
                  "at the typical speed (with the drive current's field): median / largest (µT), "
                  "within 1 µT"], body)


@block("merge-speed")
def merge_speed():
    """docs/bench/merge_speed.csv (scripts/merge_speed.sh): per code label, over warehouse seeds
    1-2 (4 sessions), the median wall-clock time of `mm4mm merge` with every output, the median of
    the per-seed ratios to PCL GICP on s0 and s1's point maps in the same run, and the median
    seconds of each stage in timings.json (the outputs are built concurrently, so the stages can
    add up to more than the wall time)."""
    data = rows("merge_speed.csv")
    stages = [("matching_s", "matching"), ("refinement_and_edges_s", "refinement and edges"),
              ("octomap_s", "OctoMap"), ("merged_cloud_s", "merged cloud"),
              ("magnetic_maps_s", "session maps"), ("magnetic_map_s", "fused map"), ("solve_s", "solve")]
    body = []
    for label in dict.fromkeys(r["label"] for r in data):
        runs = [r for r in data if r["label"] == label]
        body.append([label, str(len(runs)), fx(median([f(r, "wall_s") for r in runs]), 1),
                     fx(median([f(r, "wall_s") / f(r, "gicp_s") for r in runs]), 1)] +
                    [fx(median([f(r, column) for r in runs]), 1) for column, _ in stages])
    return table(["code", "seeds", "merge (s, median)", "merge / GICP"] +
                 [f"{name} (s)" for _, name in stages], body)


@block("demo-speed")
def demo_speed():
    """docs/bench/demo_speed.csv (scripts/demo_speed.sh): per code label, the runs and the median
    seconds of each step of scripts/demo.sh after the build, and of the four together."""
    data = rows("demo_speed.csv")
    steps = [("simulate_s", "simulate"), ("merge_s", "merge"), ("eval_s", "eval"),
             ("render_s", "render"), ("total_s", "the four")]
    body = []
    for label in dict.fromkeys(r["label"] for r in data):
        runs = [r for r in data if r["label"] == label]
        body.append([label, str(len(runs))] + [fx(median([f(r, c) for r in runs]), 1) for c, _ in steps])
    return table(["code", "runs"] + [f"{name} (s, median)" for _, name in steps], body)
