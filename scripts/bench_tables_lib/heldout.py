"""The held-out figures of issue 31 (docs/heldout_set.md): procedural worlds at seeds 2001 and up,
written by scripts/heldout.sh a seed and a part at a time, each row's commit in
docs/bench/heldout.commits. The tables say how many seeds each part has reached: the run
resumes across stops, and the figures are read as they stand, never tuned on.
"""
from .common import block, inline, one, pct, rows, select, table


def _seeds(data):
    seeds = sorted({int(r["seed"]) for r in data})
    return f"{seeds[0]}-{seeds[-1]} ({len(seeds)})" if seeds else "none yet"


def _placed_row(label, g):
    """A table row of overlapping pairs: label, seeds, pairs, both placed, aligned."""
    return [label, _seeds(g), len(g), sum(one(r, "connected") for r in g),
            pct(sum(one(r, "aligned") for r in g), len(g))]


RIGS = [("imu", "one sensor (imu robot)"), ("handheld", "one sensor (handheld)"),
        ("husky3", "3 sensors (husky3)"), ("array7", "7-sensor array")]


@block("heldout-procedural-match")
def heldout_procedural_match():
    """docs/bench/heldout_match.csv, method joint rows per rig (match_bench --methods joint: the
    field's match, then where it refused the field's choice among the structure maps' modes):
    overlapping = overlapping 1; field alone = stage field and accepted 1 (the field's own answer;
    its alignment is the row's); field then joint = accepted 1; aligned = aligned 1 (0.5 m, 2°);
    wrong = accepted 1 and not aligned among overlapping rows; wide = swath_overlap_m2 >= 15;
    separate = separate 1, accepted among them."""
    data = select(rows("heldout_match.csv"), method="joint")
    body = []
    for rig, label in RIGS:
        g = select(data, rig=rig)
        over = [r for r in g if one(r, "overlapping")]
        field = [r for r in over if r["stage"] == "field" and one(r, "aligned")]
        both = [r for r in over if one(r, "aligned")]
        wrong = [r for r in over if one(r, "accepted") and not one(r, "aligned")]
        wide = [r for r in over if float(r["swath_overlap_m2"]) >= 15.0]
        sep = [r for r in g if one(r, "separate")]
        body.append([label, _seeds(g), pct(len(field), len(over)), pct(len(both), len(over)),
                     pct(sum(one(r, "aligned") for r in wide), len(wide)), len(wrong),
                     f"{sum(one(r, 'accepted') for r in sep)} of {len(sep)}"])
    header = ["rig", "seeds", "field alone: overlapping pairs aligned",
              "field then joint: aligned", "of those sharing ≥ 15 m²", "accepted wrong",
              "separate pairs accepted"]
    return table(header, body)


@block("heldout-procedural-merge")
def heldout_procedural_merge():
    """docs/bench/heldout_merge.csv (merge_bench --presets procedural), rows whose pair is not
    'all', per seed set (2001-2030, then 3001 and up) and rig: every pair of the four sessions that overlaps by ground truth; connected 1
    (both placed) and aligned 1 (0.5 m, 2°) among them."""
    data = [r for r in rows("heldout_merge.csv") if r["pair"] != "all"]
    body = []
    # Seeds 3001 and up are the adds' second set (docs/heldout_set.md), merged beside them.
    for first in (True, False):
        for rig, label in RIGS:
            g = [r for r in select(data, rig=rig) if (int(r["seed"]) < 3000) == first]
            if g:
                body.append(_placed_row(label, g))
    header = ["rig", "seeds", "overlapping pairs", "both placed", "aligned"]
    return table(header, body)


def _add_sets():
    """heldout_add_pairs.csv split into its seed sets (docs/heldout_set.md): 2001-2030, run by the
    code before add matched refused sessions pair by pair, and 3001 and up, by the code after."""
    data = rows("heldout_add_pairs.csv")
    return [("before", [r for r in data if int(r["seed"]) < 3000]),
            ("after", [r for r in data if int(r["seed"]) >= 3000])]


@block("heldout-procedural-add")
def heldout_procedural_add():
    """docs/bench/heldout_add_pairs.csv (add_bench --preset procedural --sessions 4): per seed set
    (_add_sets) and atlas (grown: one session at a time, as mm4mm add; at_once: merged at once with
    growing-map matching), the pairs that overlap by ground truth, connected 1 and aligned 1 among
    them."""
    body = []
    for code, data in _add_sets():
        if not data:
            continue
        for atlas, label in [("grown", "grown by add"),
                             ("at_once", "merged at once (growing map)")]:
            body.append([f"{label}, {code} the change"] +
                        _placed_row(label, select(data, atlas=atlas))[1:])
    header = ["atlas", "seeds", "overlapping pairs", "both placed", "aligned"]
    return table(header, body)


@inline("heldout-procedural-seeds")
def heldout_procedural_seeds():
    """docs/bench/heldout_match.csv, method joint: the seeds the matching part has reached."""
    return _seeds(select(rows("heldout_match.csv"), method="joint"))


@inline("heldout-readme-match")
def heldout_readme_match():
    """docs/bench/heldout_match.csv, method joint (as heldout-procedural-match): overlapping
    pairs aligned per rig, accepted-wrong overlapping pairs and accepted separate pairs summed
    over the rigs."""
    data = select(rows("heldout_match.csv"), method="joint")
    parts, wrong, sep, sep_accepted = [], 0, 0, 0
    for rig, label in RIGS:
        g = select(data, rig=rig)
        over = [r for r in g if one(r, "overlapping")]
        parts.append(f"{label} {pct(sum(one(r, 'aligned') for r in over), len(over))}")
        wrong += sum(one(r, "accepted") and not one(r, "aligned") for r in over)
        seps = [r for r in g if one(r, "separate")]
        sep += len(seps)
        sep_accepted += sum(one(r, "accepted") for r in seps)
    return (", ".join(parts) + f"; {wrong} overlapping pairs accepted at a wrong place and "
            f"{sep_accepted} of {sep} separate pairs accepted")


@inline("heldout-readme-merge")
def heldout_readme_merge():
    """docs/bench/heldout_merge.csv (as heldout-procedural-merge, seeds 2001-2030): aligned of the
    overlapping pairs per rig; and docs/bench/heldout_add_pairs.csv, the atlas grown by add."""
    data = [r for r in rows("heldout_merge.csv") if r["pair"] != "all" and int(r["seed"]) < 3000]
    parts = []
    for rig, label in RIGS:
        g = select(data, rig=rig)
        if g:
            parts.append(f"{pct(sum(one(r, 'aligned') for r in g), len(g))} with {label}")
    sets = [data for _, data in _add_sets() if data]
    grown = select(sets[-1], atlas="grown")
    return (" and ".join(parts) + f"; grown one `add` at a time (imu, seeds {_seeds(grown)}), "
            f"{pct(sum(one(r, 'aligned') for r in grown), len(grown))}")



@block("heldout-procedural-offset")
def heldout_procedural_offset():
    """docs/bench/heldout_match_offset.csv (scripts/heldout.sh's offset part: match_bench --methods
    joint --vertical-offset-uT 10, imu and array7) joined pair by pair (rig, seed, pair) with
    heldout_match.csv's method joint rows: pairs compared; same decision = accepted equal; aligned
    (0.5 m, 2°) of the overlapping pairs without and with the offset; accepted wrong with the
    offset = accepted and not aligned among overlapping pairs, plus separate pairs accepted; the
    largest |Δz| and |Δr| of the field's own match (columns z, r) between the two runs."""
    base = {(r["rig"], r["seed"], r["pair"]): r
            for r in select(rows("heldout_match.csv"), method="joint")}
    data = rows("heldout_match_offset.csv")
    body = []
    for rig, label in RIGS:
        g = [(base[(r["rig"], r["seed"], r["pair"])], r) for r in select(data, rig=rig)
             if (r["rig"], r["seed"], r["pair"]) in base]
        if not g:
            continue
        over = [(b, o) for b, o in g if one(o, "overlapping")]
        same = sum(one(b, "accepted") == one(o, "accepted") for b, o in g)
        wrong = sum(one(o, "accepted") and not one(o, "aligned") for b, o in over)
        wrong += sum(one(o, "accepted") for b, o in g if one(o, "separate"))
        dz = max(abs(float(b["z"]) - float(o["z"])) for b, o in g)
        dr = max(abs(float(b["r"]) - float(o["r"])) for b, o in g)
        body.append([label, _seeds([o for _, o in g]), len(g), pct(same, len(g)),
                     pct(sum(one(b, "aligned") for b, _ in over), len(over)),
                     pct(sum(one(o, "aligned") for _, o in over), len(over)), wrong,
                     f"{dz:.2f} / {dr:.3f}"])
    header = ["rig", "seeds", "pairs", "same decision", "aligned without the offset",
              "aligned with 10 µT", "accepted wrong with it", "largest change of z / r (field, absolute)"]
    return table(header, body)


PEERS = [("pcl-gicp", "PCL GICP (identity and 8 headings)"),
         ("pcl-ndt", "PCL NDT (identity and 8 headings)"),
         ("pcl-fpfh-sacia-gicp", "PCL FPFH + SAC-IA + GICP (4 seeds)")]


def _within(r):
    """A row's answer, claimed or refused, within 0.5 m and 2° (match_bench's alignment)."""
    return float(r["overlap_error_m"]) <= 0.5 and float(r["overlap_error_deg"]) <= 2.0


@block("heldout-procedural-peers")
def heldout_procedural_peers():
    """docs/bench/heldout_peers.csv (scripts/heldout.sh's peers part: match_bench's cloud peers on
    the imu sessions' 0.5 m point maps, claiming by docs/bench/peer_ambiguity_rules.csv) beside
    heldout_match.csv's method joint imu rows on the same seeds: overlapping pairs claimed and
    aligned (accepted 1 and aligned 1), claimed wrong (accepted 1, aligned 0), best answer within
    0.5 m / 2° whether claimed or not (overlap_error_m <= 0.5 and overlap_error_deg <= 2: a row's
    errors are its answer's, claimed or refused), separate pairs claimed (separate 1, accepted
    1)."""
    peers = rows("heldout_peers.csv")
    seeds = {r["seed"] for r in peers}
    mine = [r for r in select(rows("heldout_match.csv"), method="joint", rig="imu")
            if r["seed"] in seeds]
    body = []
    for method, label in [("joint", "mm4mm (field, then joint)")] + PEERS:
        g = mine if method == "joint" else select(peers, method=method)
        over = [r for r in g if one(r, "overlapping")]
        sep = [r for r in g if one(r, "separate")]
        claimed = sum(one(r, "accepted") and one(r, "aligned") for r in over)
        wrong = sum(one(r, "accepted") and not one(r, "aligned") for r in over)
        body.append([label, _seeds(g), pct(claimed, len(over)), wrong,
                     pct(sum(_within(r) for r in over), len(over)),
                     f"{sum(one(r, 'accepted') for r in sep)} of {len(sep)}"])
    header = ["method", "seeds", "overlapping pairs claimed and aligned", "claimed wrong",
              "best answer aligned, claimed or not", "separate pairs claimed"]
    return table(header, body)


@inline("heldout-readme-peers")
def heldout_readme_peers():
    """As heldout-procedural-peers: per method, overlapping pairs claimed and aligned, and the
    wrong claims (overlapping claimed misaligned plus separate claimed) summed."""
    peers = rows("heldout_peers.csv")
    seeds = {r["seed"] for r in peers}
    mine = [r for r in select(rows("heldout_match.csv"), method="joint", rig="imu")
            if r["seed"] in seeds]
    parts = []
    for method, label in [("joint", "mm4mm")] + [(m, l.split(" (")[0]) for m, l in PEERS]:
        g = mine if method == "joint" else select(peers, method=method)
        over = [r for r in g if one(r, "overlapping")]
        wrong = sum(one(r, "accepted") and not one(r, "aligned") for r in over)
        wrong += sum(one(r, "accepted") for r in g if one(r, "separate"))
        claimed = sum(one(r, "accepted") and one(r, "aligned") for r in over)
        parts.append(f"{label} {pct(claimed, len(over))}, {wrong} wrong")
    return f"seeds {_seeds(mine)}: " + "; ".join(parts)


@block("heldout-procedural-seams")
def heldout_procedural_seams():
    """docs/bench/heldout_seams.csv (scripts/heldout.sh's seams part), tabled as field-seams."""
    from .matching import field_seams
    return field_seams("heldout_seams.csv")


@block("heldout-procedural-seams-hard-iron")
def heldout_procedural_seams_hard_iron():
    """docs/bench/heldout_seams_hard_iron.csv (heldout.sh's seams part), tabled as
    field-seams-hard-iron."""
    from .matching import field_seams_hard_iron
    return field_seams_hard_iron("heldout_seams_hard_iron.csv")


@block("heldout-procedural-placement")
def heldout_procedural_placement():
    """docs/bench/heldout_placement.csv (heldout.sh's placement part, seeds 7001 and up), tabled
    as field-seams-placement."""
    from .matching import field_seams_placement
    return field_seams_placement("heldout_placement.csv")
