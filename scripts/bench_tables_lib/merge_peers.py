"""Generators of docs/benchmarks.md's (and README.md's) regions on merges and peers: merge_bench's
tables and figures (parsed from its Markdown output), the featureless merges, and the peer
benchmark (peer_bench --csv: summary, the paper's Table I, the reduced run).
"""
import re

from .common import block, f, fx, inline, md_table, mean, one, rows, select, table


# ---------------------------------------------------------------------------------------------
# docs/benchmarks.md: merges (merge_bench prints Markdown only)

def merge_md(name, preset, variant="magnetic"):
    return [r for r in md_table(name) if r["preset"] == preset and r["variant"] == variant][0]


@block("merge-bench")
def merge_bench():
    """docs/bench/merge_bench.md (merge_bench prints Markdown only, no CSV without --csv): its
    rows for warehouse and corridor, the atlas write column without the OctoMap share."""
    body = []
    for preset in ("warehouse", "corridor"):
        r = merge_md("merge_bench.md", preset)
        cols = list(r.values())
        body.append([preset, r["seeds"], cols[3], cols[4], cols[5], cols[6], cols[7], cols[8].split(" / ")[0]])
    return table(["preset", "seeds", "overlapping pairs aligned", "median overlap error after solve (m / °)",
                  "median e_t (m) / e_r (°)",
                  "ATE after solve / odometry at true frames / rigid tree (m, median)", "merge s (median)",
                  "atlas write s (median)"], body)


@block("merge-featureless")
def merge_featureless():
    """docs/bench/merge_featureless.md (Markdown only): variant magnetic and geometric; aligned
    pairs without the percentage, the first figure of the ATE column."""
    body = []
    for variant, label in (("magnetic", "with magnetic residuals"), ("geometric", "without")):
        cols = list(merge_md("merge_featureless.md", "featureless", variant).values())
        body.append([label, cols[3].split(" ")[0], cols[4], cols[5], cols[6].split(" / ")[0]])
    return table(["variant", "overlapping pairs aligned", "median overlap error after solve (m / °)",
                  "median e_t (m) / e_r (°)", "ATE median (m)"], body)


def merge_fig(preset, column_index, part):
    cols = list(merge_md("merge_bench.md", preset).values())
    return cols[column_index].split(" / ")[part].split(" ")[0]


@inline("merge-warehouse-aligned")
def merge_warehouse_aligned():
    """merge_bench.md, warehouse: the percentage of overlapping pairs aligned."""
    return re.search(r"\((\d+ %)\)", merge_fig("warehouse", 3, 0) + " " +
                     list(merge_md("merge_bench.md", "warehouse").values())[3]).group(1)


@inline("merge-warehouse-overlap")
def merge_warehouse_overlap():
    """merge_bench.md, warehouse: median overlap error after the solve, cm / °."""
    return f"{fx(100 * float(merge_fig('warehouse', 4, 0)), 1)} cm / {merge_fig('warehouse', 4, 1)}°"


@inline("merge-warehouse-ate")
def merge_warehouse_ate():
    """merge_bench.md, warehouse: ATE after the solve against the odometry at its true frames."""
    return f"ATE {merge_fig('warehouse', 6, 0)} m against {merge_fig('warehouse', 6, 1)} m"


@inline("merge-corridor-aligned")
def merge_corridor_aligned():
    """merge_bench.md, corridor: the percentage of overlapping pairs aligned."""
    return re.search(r"\((\d+ %)\)", list(merge_md("merge_bench.md", "corridor").values())[3]).group(1)


@inline("merge-corridor-overlap")
def merge_corridor_overlap():
    """merge_bench.md, corridor: median overlap translation error after the solve, cm."""
    return f"{fx(100 * float(merge_fig('corridor', 4, 0)), 1)} cm"


@inline("merge-corridor-ate")
def merge_corridor_ate():
    """merge_bench.md, corridor: ATE after the solve against the odometry at its true frames."""
    return f"ATE {merge_fig('corridor', 6, 0)} m against {merge_fig('corridor', 6, 1)} m"


# ---------------------------------------------------------------------------------------------
# docs/benchmarks.md: peers (peer_bench --csv)

PEER_SOURCES = {
    # preset -> CSV holding its latest run (the warehouse rerun after the review fix of b9f3621,
    # the corridor and disjoint session at 10 seeds, the random starts of the first reduced run)
    "warehouse": "peer_bench_warehouse.csv",
    "corridor": "peer_bench_corridor_disjoint.csv",
    "disjoint": "peer_bench_corridor_disjoint.csv",
    "random": "peer_bench.csv",
}
PEER_SCENARIOS = [("warehouse", "1+2", "warehouse 1+2"), ("warehouse", "3+4", "warehouse 3+4"),
                  ("warehouse", "(1+2)+(3+4)", "warehouse (1+2)+(3+4)"), ("warehouse", "all", "warehouse all"),
                  ("corridor", "1+2", "corridor 1+2"), ("corridor", "2+3", "corridor 2+3"),
                  ("corridor", "all", "corridor all"), ("random", "*", "random starts (all four)"),
                  ("disjoint", "1+disjoint", "disjoint session left out")]
MM4MM_METHODS = ["mm4mm", "mm4mm-magnetic-only", "mm4mm-icp-identity", "mm4mm-paper",
                 "mm4mm-no-magnetic-residuals"]
PEERS = [("pcl-gicp", "PCL GICP"), ("pcl-ndt", "PCL NDT"), ("pcl-fpfh-sacia-gicp", "PCL FPFH + SAC-IA + GICP"),
         ("open3d-fpfh-ransac-icp", "Open3D")]


def peer_rows(preset, comparison, method):
    """The rows of one (preset, comparison, method) in PEER_SOURCES[preset] (comparison '*': all
    four of the preset's comparisons together); peer_bench writes a row only for comparisons it
    counts (a judged pair truly overlaps), success 0/1."""
    data = select(rows(PEER_SOURCES[preset]), preset=preset, method=method)
    return data if comparison == "*" else select(data, comparison=comparison)


def peer_success(preset, comparison, method):
    data = peer_rows(preset, comparison, method)
    return sum(one(r, "success") for r in data), len(data)


def peer_seeds(preset):
    seeds = sorted({int(r["seed"]) for r in rows(PEER_SOURCES[preset]) if r["preset"] == preset})
    return f"{seeds[0]}–{seeds[-1]}"


@block("peer-summary")
def peer_summary():
    """PEER_SOURCES per scenario: successes / counted rows for mm4mm and its ablations; best peer =
    the peer method with the most successes (ties: the first in PEERS order), named when > 0."""
    body = []
    for preset, comparison, label in PEER_SCENARIOS:
        cells = [label, peer_seeds(preset)]
        for method in MM4MM_METHODS:
            k, n = peer_success(preset, comparison, method)
            cells.append(f"{k}/{n}")
        best = max(PEERS, key=lambda p: peer_success(preset, comparison, p[0])[0])
        k, n = peer_success(preset, comparison, best[0])
        cells.append(f"{k}/{n}" + (f" ({best[1]})" if k else ""))
        body.append(cells)
    return table(["scenario", "seeds", "mm4mm", "magnetic only", "ICP-EM from identity", "paper's Eq. 4–5 + PSO",
                  "no magnetic residuals", "best peer"], body)


def table_one_comparisons():
    return [c for p, c, _ in PEER_SCENARIOS if p == "warehouse" and c != "all"]


@inline("peer-mm4mm-total")
def peer_mm4mm_total():
    """PEER_SOURCES: mm4mm's successes / counted rows over every scenario of PEER_SCENARIOS."""
    k = n = 0
    for preset, comparison, _ in PEER_SCENARIOS:
        a, b = peer_success(preset, comparison, "mm4mm")
        k, n = k + a, n + b
    return f"{k} of {n}"


@inline("peer-warehouse-seeds")
def peer_warehouse_seeds():
    """peer_bench_warehouse.csv: the warehouse seeds run."""
    return peer_seeds("warehouse")


@inline("peer-warehouse-errors")
def peer_warehouse_errors():
    """peer_bench_warehouse.csv, method mm4mm: mean e_t_m / e_r_deg over seeds (rows with e_t_m
    >= 0) for 1+2, 3+4 and (1+2)+(3+4)."""
    parts = []
    for c in table_one_comparisons():
        data = [r for r in peer_rows("warehouse", c, "mm4mm") if f(r, "e_t_m") >= 0]
        parts.append(f"{c} {fx(mean([f(r, 'e_t_m') for r in data]), 3)} m / {fx(mean([f(r, 'e_r_deg') for r in data]), 2)}°")
    return ", ".join(parts)


@inline("peer-34-rotation")
def peer_34_rotation():
    """peer_bench_warehouse.csv, mm4mm, comparison 3+4: mean e_r_deg over seeds."""
    data = [r for r in peer_rows("warehouse", "3+4", "mm4mm") if f(r, "e_t_m") >= 0]
    return f"{fx(mean([f(r, 'e_r_deg') for r in data]), 2)}°"


PAPER_TABLE_ONE = [  # the paper's Table I, quoted (not measured here)
    ("GICP (paper)", "1.513 / 0.595", "0.793 / 0.300", "2.769 / 182.610"),
    ("NDT (paper)", "1.146 / 0.647", "0.231 / 0.253", "2.713 / 180.350"),
    ("MM4MM (paper)", "1.162 / 0.472", "0.177 / 0.192", "0.150 / 0.378"),
]


@block("peer-table-one")
def peer_table_one():
    """The paper's Table I rows (quoted) and, from peer_bench_warehouse.csv, the mean over seeds
    of e_t_m (%.3f) / e_r_deg (%.2f) of pcl-gicp, pcl-ndt and mm4mm per comparison."""
    body = [list(r) for r in PAPER_TABLE_ONE]
    for method, label in (("pcl-gicp", "PCL GICP (here)"), ("pcl-ndt", "PCL NDT (here)"), ("mm4mm", "mm4mm (here)")):
        cells = [label]
        for c in table_one_comparisons():
            data = [r for r in peer_rows("warehouse", c, method) if f(r, "e_t_m") >= 0]
            cells.append(f"{fx(mean([f(r, 'e_t_m') for r in data]), 3)} / {fx(mean([f(r, 'e_r_deg') for r in data]), 2)}")
        body.append(cells)
    return table(["method", "1+2 (m / °)", "3+4 (m / °)", "(1+2)+(3+4) (m / °)"], body)


@block("peer-reduced")
def peer_reduced():
    """docs/bench/peer_bench.csv (the first reduced run, seeds 1-2 of each preset): per preset and
    comparison, successes / counted rows of mm4mm and of each peer."""
    data = rows("peer_bench.csv")
    body = []
    for preset in ("warehouse", "corridor", "random", "disjoint"):
        comparisons = []
        for r in data:
            if r["preset"] == preset and r["comparison"] not in comparisons:
                comparisons.append(r["comparison"])
        for c in comparisons:
            cells = [preset, c]
            for method in ["mm4mm"] + [p for p, _ in PEERS]:
                d = select(data, preset=preset, comparison=c, method=method)
                cells.append(f"{sum(one(r, 'success') for r in d)}/{len(d)}")
            body.append(cells)
    return table(["preset", "comparison", "mm4mm"] + [label for _, label in PEERS], body)
