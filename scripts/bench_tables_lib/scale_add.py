"""Generators of docs/benchmarks.md's (and README.md's) regions on scaling and adding sessions: the
scale bench (strategies by session count, matches, memory) and the add bench (times, write/load,
memory, accuracy).
"""
import re

from .common import block, f, fx, inline, md_table, rows, scaled, span, table


# ---------------------------------------------------------------------------------------------
# docs/benchmarks.md: scaling and add

@block("scale-bench")
def scale_bench():
    """docs/bench/scale_bench.csv, one row per (strategy, sessions): seconds (%.1f), magnetic
    matches, candidate pairs, connected / sessions, aligned_pairs / overlapping_pairs ('–' with
    none), rss_before_mb / peak_rss_mb (%.0f), added = peak - before (%.0f)."""
    body = []
    for r in rows("scale_bench.csv"):
        n_over = int(r["overlapping_pairs"])
        body.append([r["strategy"], r["sessions"], f"{fx(f(r, 'seconds'), 1)}", r["magnetic_matches"],
                     r["candidate_pairs"], f"{r['connected']}/{r['sessions']}",
                     f"{r['aligned_pairs']}/{n_over}" if n_over else "–",
                     f"{fx(f(r, 'rss_before_mb'), 0)} / {fx(f(r, 'peak_rss_mb'), 0)}",
                     f"{fx(f(r, 'peak_rss_mb') - f(r, 'rss_before_mb'), 0)}"])
    return table(["strategy", "sessions", "merge s", "magnetic matches", "candidate pairs", "connected",
                  "overlapping pairs aligned", "RSS before / peak (MB)", "added (MB)"], body)


def scale(strategy, sessions):
    return [r for r in rows("scale_bench.csv") if r["strategy"] == strategy and int(r["sessions"]) == sessions][0]


def largest_growing():
    return max((r for r in rows("scale_bench.csv") if r["strategy"] == "growing map"), key=lambda r: int(r["sessions"]))


@inline("scale-growing-summary")
def scale_growing_summary():
    """scale_bench.csv, growing map at the largest N: sessions, magnetic matches against all
    N (N - 1) / 2 pairs, seconds in minutes (%.1f), aligned / overlapping pairs in %, peak RSS
    in GB (MB / 1000, %.1f)."""
    r = largest_growing()
    n = int(r["sessions"])
    return (f"{n} sessions of a 170 m × 75 m warehouse merge with {r['magnetic_matches']} magnetic matches "
            f"instead of {n * (n - 1) // 2}, in {fx(f(r, 'seconds') / 60, 1)} minutes, "
            f"{fx(100.0 * int(r['aligned_pairs']) / int(r['overlapping_pairs']), 0)} % of their overlapping pairs "
            f"aligned ({fx(scaled(f(r, 'peak_rss_mb'), 0.001), 1)} GB peak")


@inline("scale-matches")
def scale_matches():
    """scale_bench.csv, growing map: magnetic matches at the largest N, all pairs N (N - 1) / 2,
    and the matches per N in order."""
    r = largest_growing()
    n = int(r["sessions"])
    series = ", ".join(x["magnetic_matches"] for x in rows("scale_bench.csv") if x["strategy"] == "growing map")
    return f"{r['magnetic_matches']} magnetic matches for {n} sessions where every pair would be {n * (n - 1) // 2}: linear in N ({series})"


@inline("scale-memory")
def scale_memory():
    """scale_bench.csv, growing map at the largest N: added (peak - before) and peak RSS, GB."""
    r = largest_growing()
    return (f"{fx((f(r, 'peak_rss_mb') - f(r, 'rss_before_mb')) / 1000, 1)} GB added at N = {r['sessions']} "
            f"({fx(scaled(f(r, 'peak_rss_mb'), 0.001), 1)} GB peak")


ADD_ROWS = [1, 4, 8, 12, 15]


def add_row(sessions_before):
    return [r for r in rows("add_bench.csv") if int(r["sessions_before"]) == sessions_before][0]


@block("add-bench")
def add_bench():
    """docs/bench/add_bench.csv, the adds with 1, 4, 8, 12 and 15 sessions before: stage seconds
    load_s, maps_s, matching_s, refinement_s (ICP-EM + edges), solve_s, write_s, total_s (%.1f),
    peak_rss_mb / 1000 (GB, %.1f), old_max_move_m (m, %.2f) and old_moved_beyond_5cm_at_30m of
    the sessions placed before."""
    body = []
    for k in ADD_ROWS:
        r = add_row(k)
        moved = f"{fx(f(r, 'old_max_move_m'), 2)} m" if f(r, "old_max_move_m") >= 0.005 else "0 m"
        body.append([k] + [f"{fx(f(r, c), 1)}" for c in ("load_s", "maps_s", "matching_s", "refinement_s", "solve_s",
                                                      "write_s", "total_s")] +
                    [f"{fx(scaled(f(r, 'peak_rss_mb'), 0.001), 1)}", f"{moved}; {r['old_moved_beyond_5cm_at_30m']} of {k}"])
    return table(["sessions before", "load", "maps", "matching", "ICP-EM + edges", "solve", "rewrite outputs",
                  "total (s)", "peak RSS (GB)",
                  "placed sessions moved (largest keyframe move; number > 5 cm at 30 m)"], body)


@inline("add-first")
def add_first():
    """add_bench.csv: total_s of the first add (one session before), %.0f s."""
    return f"{fx(f(add_row(1), 'total_s'), 0)} s"


@inline("add-from-eight")
def add_from_eight():
    """add_bench.csv: range of total_s over the adds with 8 or more sessions before, %.0f s."""
    return span([f(r, "total_s") for r in rows("add_bench.csv") if int(r["sessions_before"]) >= 8], 0, "–") + " s"


@inline("add-last")
def add_last():
    """add_bench.csv: total_s of the last add, %.0f s."""
    last = max(rows("add_bench.csv"), key=lambda r: int(r["sessions_before"]))
    return f"{fx(f(last, 'total_s'), 0)} s"


@inline("add-write")
def add_write():
    """add_bench.csv: write_s of the first and the last add."""
    last = max(rows("add_bench.csv"), key=lambda r: int(r["sessions_before"]))
    return f"{fx(f(add_row(1), 'write_s'), 1)} s → {fx(f(last, 'write_s'), 0)} s"


@inline("add-load")
def add_load():
    """add_bench.csv: load_s of the first and the last add."""
    last = max(rows("add_bench.csv"), key=lambda r: int(r["sessions_before"]))
    return f"{fx(f(add_row(1), 'load_s'), 1)} s → {fx(f(last, 'load_s'), 1)} s"


@inline("add-memory")
def add_memory():
    """add_bench.csv: peak_rss_mb of the first and the last add, GB (/ 1000)."""
    last = max(rows("add_bench.csv"), key=lambda r: int(r["sessions_before"]))
    return f"{fx(scaled(f(add_row(1), 'peak_rss_mb'), 0.001), 1)} → {fx(scaled(f(last, 'peak_rss_mb'), 0.001), 1)} GB"


def add_accuracy(label):
    """docs/bench/add_bench.md, second table (add_bench prints it; the CSV has no accuracy):
    the row whose atlas column starts with label."""
    return [r for r in md_table("add_bench.md", 1) if r["atlas"].startswith(label)][0]


@inline("add-accuracy")
def add_accuracy_figures():
    """add_bench.md (accuracy table, no CSV): the atlas grown by add: aligned pairs, median overlap
    error (cm / °), ATE against the odometry's."""
    r = add_accuracy("grown by add")
    aligned, total = [x.strip() for x in r["overlapping pairs aligned"].split("/")]
    t, deg = [float(x) for x in r["median overlap error (m / °)"].split("/")]
    ate, odo = re.match(r"([\d.]+) \(odometry ([\d.]+)\)", r["ATE (m)"]).groups()
    return (f"aligns {aligned} of their {total} overlapping pairs ({fx(100 * t, 1)} cm / {fx(deg, 2)}°, "
            f"ATE {ate} m against {odo} m for the odometry)")


@block("add-speed")
def add_speed():
    """docs/bench/add_speed.csv (scripts/add_speed.sh): one row per code label, seed and add (the
    sessions in the atlas before it): the wall-clock seconds of `mm4mm add` (the OctoMap left
    out) and of `mm4mm add --octomap` on the same atlas, their ratio, the OctoMap stage of the
    latter's timings.json, whether both wrote the same trajectories, and `mm4mm export octomap`
    of the seed's final atlas (six sessions)."""
    body = []
    for r in rows("add_speed.csv"):
        body.append([r["label"], r["seed"], r["sessions_before"], fx(f(r, "add_s"), 1),
                     fx(f(r, "add_octomap_s"), 1), fx(f(r, "add_s") / f(r, "add_octomap_s"), 2),
                     fx(f(r, "octomap_stage_s"), 1), r["same_poses"], fx(f(r, "export_s"), 1)])
    return table(["code", "seed", "sessions before", "add (s)", "add --octomap (s)",
                  "add / add --octomap", "OctoMap stage (s)", "same poses",
                  "export octomap, 6 sessions (s)"], body)


def _add_speed_rows():
    """The rows of the first label, 6f8116a: the measurement the OctoMap-on-request text cites."""
    data = rows("add_speed.csv")
    return [r for r in data if r["label"] == data[0]["label"]]


@block("add-stages")
def add_stages():
    """docs/bench/add_speed.csv, the rows with stage columns: per code label, seed and add, the
    add's wall-clock seconds (the OctoMap left out), the stages its timings.json times, and the
    rest (reading the atlas and sessions, calibration, the magnetic maps, writing the files)."""
    names = ["matching", "refinement_and_edges", "solve", "merged_cloud", "magnetic_map"]
    body = []
    for r in rows("add_speed.csv"):
        if not r.get("matching_s"):
            continue
        # The merged cloud and the fused map are built concurrently: the longer is on the clock.
        timed = (sum(f(r, n + "_s") for n in names[:3]) +
                 max(f(r, "merged_cloud_s"), f(r, "magnetic_map_s")))
        body.append([r["label"], r["seed"], r["sessions_before"], fx(f(r, "add_s"), 1)] +
                    [fx(f(r, n + "_s"), 1) for n in names] + [fx(f(r, "add_s") - timed, 1)])
    return table(["code", "seed", "sessions before", "add (s)", "matching (s)",
                  "refinement and edges (s)", "solve (s)", "merged cloud (s)",
                  "fused magnetic map (s)", "the rest (s)"], body)


@inline("add-speed-saved")
def add_speed_saved():
    """docs/bench/add_speed.csv: the span over every add of add --octomap's seconds minus add's."""
    return span([f(r, "add_octomap_s") - f(r, "add_s") for r in _add_speed_rows()]) + " s"


@inline("add-speed-octomap")
def add_speed_octomap():
    """docs/bench/add_speed.csv: the span of the OctoMap stage of `add --octomap`."""
    return span([f(r, "octomap_stage_s") for r in _add_speed_rows()]) + " s"


@inline("add-speed-without")
def add_speed_without():
    """docs/bench/add_speed.csv: the span of `mm4mm add`'s seconds (the OctoMap left out)."""
    return span([f(r, "add_s") for r in _add_speed_rows()]) + " s"


@inline("add-speed-export")
def add_speed_export():
    """docs/bench/add_speed.csv: the span over seeds of `mm4mm export octomap` of the final atlas."""
    return span([f(r, "export_s") for r in _add_speed_rows()]) + " s"


@block("eval-speed")
def eval_speed():
    """docs/bench/eval_speed.csv (scripts/eval_speed.sh): `mm4mm eval` of a 4-session warehouse
    atlas by an earlier build ("before") and the checkout's ("after"), alternating: the median wall
    time and peak memory over the runs, and the size of the sessions' files."""
    body = []
    for r in rows("eval_speed.csv"):
        body.append([r["label"], r["binary"], r["sessions"], r["session_files_mib"], r["runs"],
                     fx(f(r, "seconds_median"), 2), r["peak_rss_mib_median"]])
    return table(["code", "binary", "sessions", "session files (MiB)", "runs", "eval (s, median)",
                  "peak memory (MiB, median)"], body)


@block("kill-campaign")
def kill_campaign():
    """docs/bench/kill_campaign.csv (scripts/kill_campaign.py): one row per code label and writer:
    the kills, the writer's uninterrupted run (s), how many kills left the state before ("old"),
    the new atlas whole ("new") or anything else ("partial"), the kills that left a scratch
    directory (landed while the atlas was written), and those left after the next write."""
    body = []
    for r in rows("kill_campaign.csv"):
        body.append([r["label"], f"`{r['writer']}`", r["seed"], r["kills"], fx(f(r, "full_run_s"), 1),
                     r["old"], r["new"], r["partial"], r["kills_leaving_scratch"],
                     r["scratch_after_next_write"]])
    return table(["code", "writer", "seed", "kills", "uninterrupted run (s)", "old state",
                  "new atlas, whole", "partial", "kills that left scratch",
                  "scratch after the next write"], body)


@block("memory-bound")
def memory_bound():
    """docs/bench/memory_bound.csv (scripts/memory_bound.sh): one row per code label, case and
    command: the scan points and magnetometer rows the bound counted, the estimate the command
    logged (GiB), the peak resident memory GNU time measured (GiB) and the peak over the
    estimate."""
    body = []
    for r in rows("memory_bound.csv"):
        body.append([r["label"], r["case"], f"`{r['command']}`", f"{int(r['scan_points']):,}".replace(",", " "),
                     f"{int(r['magnetometer_rows']):,}".replace(",", " "), fx(f(r, "estimate_gib"), 2),
                     fx(f(r, "peak_rss_gib"), 2), fx(f(r, "peak_rss_gib") / f(r, "estimate_gib"), 2)])
    return table(["code", "case", "command", "scan points", "magnetometer rows", "estimate (GiB)",
                  "measured peak (GiB)", "peak / estimate"], body)
