"""Regions of the registration comparisons: ICP-EM against PCL's GICP on the same input
(icp_bench.csv) and the peers' claim rules with their held-out verdicts (peer_claim_rules.csv,
peer_heldout.csv, peer_heldout_pairs.csv; scripts/peer_claim_rules.sh writes them).
"""
from .common import block, f, fx, inline, one, pct, rows, select, table

ICP_CASES = ["koide LiDAR pair", "warehouse maps, 150 m routes", "corridor maps, pillars",
             "corridor maps, no pillars"]


def icp_row(case, method):
    found = select(rows("icp_bench.csv"), case=case, method=method)
    return found[0] if found else None


def dash(row, column, digits):
    return "-" if f(row, column) < 0 else fx(f(row, column), digits)


@block("icp-bench")
def icp_bench():
    """icp_bench.csv, every row in file order: seconds_median (%.3f), translation_median_m /
    translation_max_m (%.3f), rotation_median_deg / rotation_max_deg (%.3f), converged and
    degenerate out of seeds (- where the method reports none)."""
    body = []
    for r in rows("icp_bench.csv"):
        seeds = r["seeds"]
        converged = "-" if int(r["converged"]) < 0 else f"{r['converged']}/{seeds}"
        degenerate = "-" if int(r["degenerate"]) < 0 else f"{r['degenerate']}/{seeds}"
        body.append([r["case"], f"{r['target_points']} / {r['source_points']}", r["method"],
                     dash(r, "seconds_median", 3),
                     f"{fx(f(r, 'translation_median_m'), 3)} / {fx(f(r, 'translation_max_m'), 3)}",
                     f"{fx(f(r, 'rotation_median_deg'), 3)} / {fx(f(r, 'rotation_max_deg'), 3)}",
                     converged, degenerate])
    return table(["case", "points (target / source)", "method", "s (median)",
                  "translation error at the source centroid, m (median / max)",
                  "rotation error, ° (median / max)", "converged", "degenerate"], body)


@block("icp-same-input")
def icp_same_input():
    """icp_bench.csv: per case, GICP's median seconds over ICP-EM's on the same input, the whole
    clouds ('PCL GICP (1 m gate)' / 'ICP-EM (1, 0.5, 0.25 m)') and the overlap region ('PCL GICP
    + overlap region (8 m margin)' / 'ICP-EM + overlap region (8 m margin)'), %.1f; and which of
    the two has the smaller median translation error on each input (a tie within 0.0005 m says
    so)."""
    pairs = [("whole clouds", "ICP-EM (1, 0.5, 0.25 m)", "PCL GICP (1 m gate)"),
             ("overlap region", "ICP-EM + overlap region (8 m margin)",
              "PCL GICP + overlap region (8 m margin)")]
    body = []
    for case in ICP_CASES:
        for label, icp, gicp in pairs:
            a, b = icp_row(case, icp), icp_row(case, gicp)
            if a is None or b is None:
                continue
            ta, tb = f(a, "translation_median_m"), f(b, "translation_median_m")
            better = "tie" if abs(ta - tb) < 0.0005 else ("ICP-EM" if ta < tb else "GICP")
            body.append([case, label, fx(f(b, "seconds_median") / f(a, "seconds_median"), 1),
                         f"{fx(ta, 3)} / {fx(tb, 3)}", better])
    return table(["case", "input (both methods)", "GICP s / ICP-EM s", "median translation error, m "
                  "(ICP-EM / GICP)", "more accurate"], body)


PEER_CLOUD_METHODS = [("pcl-gicp", "PCL GICP"), ("pcl-ndt", "PCL NDT"),
                      ("pcl-fpfh-sacia-gicp", "PCL FPFH + SAC-IA + GICP"),
                      ("open3d-fpfh-ransac-icp", "Open3D FPFH + RANSAC + ICP"),
                      ("mm4mm-icp-identity", "ICP-EM from identity")]


def label_of(method):
    return dict(PEER_CLOUD_METHODS).get(method, method)


@block("peer-claim-rules")
def peer_claim_rules():
    """peer_claim_rules.csv (scripts/choose_peer_rules.py on peer_tuning_pairs.csv, seeds 1-20
    only): per method its min_fitness and max_inlier_rmse_m (1e9: none), the tuning pairs and how
    many truly overlap, and its correct and wrong claims there."""
    body = []
    for r in rows("peer_claim_rules.csv"):
        rmse = "none" if float(r["max_inlier_rmse_m"]) >= 1e8 else r["max_inlier_rmse_m"]
        body.append([label_of(r["method"]), r["min_fitness"], rmse,
                     f"{r['pairs']} ({r['overlapping']})", r["correct_claims"], r["wrong_claims"]])
    return table(["method", "min fitness", "max inlier RMSE (m)", "tuning pairs (overlapping)",
                  "correct claims", "wrong claims"], body)


@block("peer-heldout-pairs")
def peer_heldout_pairs():
    """peer_heldout_pairs.csv (held-out seeds from 1001, the tuned rules applied): per method,
    over the pairs that truly overlap, claimed and aligned / all; over every pair, wrong claims
    (claimed, and not overlapping or not aligned); the disjoint pairs refused / all."""
    data = rows("peer_heldout_pairs.csv")
    body = []
    for method, label in PEER_CLOUD_METHODS:
        mine = select(data, method=method)
        if not mine:
            continue
        overlapping = [r for r in mine if one(r, "overlaps")]
        right = sum(one(r, "claimed") and one(r, "aligned") for r in overlapping)
        wrong = sum(one(r, "claimed") and not (one(r, "overlaps") and one(r, "aligned")) for r in mine)
        disjoint = [r for r in mine if r["preset"] == "disjoint"]
        refused = sum(not one(r, "claimed") for r in disjoint)
        body.append([label, pct(right, len(overlapping)), f"{wrong}/{len(mine)}",
                     pct(refused, len(disjoint))])
    return table(["method", "overlapping pairs claimed and aligned", "wrong claims / pairs",
                  "disjoint pairs refused"], body)


def heldout_seeds():
    seeds = sorted({int(r["seed"]) for r in rows("peer_heldout.csv")})
    return f"{seeds[0]}–{seeds[-1]}"


@inline("peer-heldout-seeds")
def peer_heldout_seeds():
    """peer_heldout.csv: the seeds run."""
    return heldout_seeds()


@block("peer-heldout")
def peer_heldout():
    """peer_heldout.csv: per preset and comparison (file order), each method's successes / rows
    (a row per seed whose comparison peer_bench counts); mm4mm and its ablations first, then the
    cloud methods, each in file order."""
    data = rows("peer_heldout.csv")
    methods = list(dict.fromkeys(r["method"] for r in data))
    methods.sort(key=lambda m: not (m.startswith("mm4mm") and m != "mm4mm-icp-identity"))  # mm4mm's first
    keys = list(dict.fromkeys((r["preset"], r["comparison"]) for r in data))
    body = []
    for preset, comparison in keys:
        cells = [preset, comparison]
        for m in methods:
            mine = select(data, preset=preset, comparison=comparison, method=m)
            cells.append(f"{sum(one(r, 'success') for r in mine)}/{len(mine)}" if mine else "–")
        body.append(cells)
    return table(["preset", "comparison"] + [label_of(m) for m in methods], body)


@inline("icp-ratio-range")
def icp_ratio_range():
    """icp_bench.csv: the range (%.1f) of icp_same_input()'s GICP s / ICP-EM s over every case and
    input, as 'lo-hi×'."""
    values = []
    for case in ICP_CASES:
        for icp, gicp in (("ICP-EM (1, 0.5, 0.25 m)", "PCL GICP (1 m gate)"),
                          ("ICP-EM + overlap region (8 m margin)", "PCL GICP + overlap region (8 m margin)")):
            a, b = icp_row(case, icp), icp_row(case, gicp)
            if a is not None and b is not None:
                values.append(f(b, "seconds_median") / f(a, "seconds_median"))
    return f"{fx(min(values), 1)}-{fx(max(values), 1)}×"


def heldout_total(method):
    mine = select(rows("peer_heldout.csv"), method=method)
    return sum(one(r, "success") for r in mine), len(mine)


@inline("peer-heldout-mm4mm")
def peer_heldout_mm4mm():
    """peer_heldout.csv, method mm4mm: successes of rows, 'k of n'."""
    k, n = heldout_total("mm4mm")
    return f"{k} of {n}"


@inline("peer-heldout-best-peer")
def peer_heldout_best_peer():
    """peer_heldout.csv: the outside peer (PCL's three, Open3D) with the most successes over
    every row ('k of n (name)', or how many tie at the most)."""
    peers = [m for m in PEER_CLOUD_METHODS if m[0] != "mm4mm-icp-identity"]
    best = max(peers, key=lambda m: heldout_total(m[0])[0])
    k, n = heldout_total(best[0])
    tied = [m for m in peers if heldout_total(m[0])[0] == k]
    return f"{k} of {n} ({best[1]})" if len(tied) == 1 else f"{k} of {n} (each of the {len(tied)} tied)"


@block("peer-tuning-fits")
def peer_tuning_fits():
    """peer_tuning_pairs.csv (tuning seeds): per method, the answers aligned to the truth, the
    answers on truly overlapping pairs that are not, and the answers on pairs that do not overlap:
    how many, and their fitness range (min-max, %.2f)."""
    data = rows("peer_tuning_pairs.csv")
    body = []
    for method, label in PEER_CLOUD_METHODS:
        mine = select(data, method=method)
        groups = [[r for r in mine if one(r, "overlaps") and one(r, "aligned")],
                  [r for r in mine if one(r, "overlaps") and not one(r, "aligned")],
                  [r for r in mine if not one(r, "overlaps")]]
        cells = [label]
        for g in groups:
            fits = [f(r, "fitness") for r in g]
            cells.append(f"{len(g)}" + (f" ({fx(min(fits), 2)}-{fx(max(fits), 2)})" if fits else ""))
        body.append(cells)
    return table(["method", "aligned answers (fitness)", "wrong answers on overlapping pairs (fitness)",
                  "answers on pairs that do not overlap (fitness)"], body)
