"""Registration of the generated regions and the helpers every generator uses: the @block and
@inline decorators (BLOCKS, INLINES), the readers of docs/bench/ (rows for CSVs, md_table for the
Markdown tables some programs print) and the bench programs' aggregations (upper median, mean,
fx's rounding, pct, span, select, MatchSummary, table). Generates no region itself.
"""
import csv
import os
from collections import OrderedDict
from decimal import ROUND_HALF_UP, Decimal

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BENCH = os.path.join(ROOT, "docs", "bench")
FILES = ["docs/benchmarks.md", "README.md"]

BLOCKS = OrderedDict()
INLINES = OrderedDict()


def block(name):
    def register(function):
        BLOCKS[name] = function
        return function
    return register


def inline(name):
    def register(function):
        INLINES[name] = function
        return function
    return register


# ---------------------------------------------------------------------------------------------
# Readers and the bench programs' aggregations

_cache = {}


def rows(name):
    """The rows of docs/bench/NAME as dicts (csv.DictReader), read once."""
    if name not in _cache:
        with open(os.path.join(BENCH, name), newline="") as f:
            _cache[name] = list(csv.DictReader(f))
    return _cache[name]


def md_table(name, index=0):
    """The index-th Markdown table of docs/bench/NAME as a list of dicts keyed by header cell.
    For programs that print Markdown but write no CSV."""
    tables, current = [], None
    with open(os.path.join(BENCH, name)) as f:
        for line in f:
            line = line.strip()
            if line.startswith("|"):
                cells = [c.strip() for c in line.strip("|").split("|")]
                if current is None:
                    current = {"header": cells, "rows": []}
                elif not all(set(c) <= set("-: ") for c in cells):
                    current["rows"].append(dict(zip(current["header"], cells)))
            elif current is not None:
                tables.append(current["rows"])
                current = None
    if current is not None:
        tables.append(current["rows"])
    return tables[index]


def median(values):
    """Upper median, as bench::median: the element at len // 2 once sorted; 0 for none."""
    values = sorted(values)
    return values[len(values) // 2] if values else 0.0


def mean(values):
    return sum(values) / len(values) if values else 0.0


class Num(float):
    """A float read from a CSV that keeps the digits it was written with."""

    def __new__(cls, text):
        number = float.__new__(cls, text)
        number.text = text
        return number


def f(row, column):
    return Num(row[column])


def fx(x, digits):
    """x with `digits` decimals. A value read from a CSV (Num) is rounded half up from the digits
    the CSV holds (0.0355 -> 0.036), the reading of them closest to the program that wrote both the
    CSV and its table from the unrounded value; a computed value as printf would."""
    if isinstance(x, Num) and x.text.strip().lower() not in ("nan", "inf", "-inf"):
        quantum = Decimal(1).scaleb(-digits)
        return str(Decimal(x.text.strip()).quantize(quantum, rounding=ROUND_HALF_UP))
    return f"{float(x):.{digits}f}"


def one(row, column):
    return row[column] == "1"


def scaled(x, factor):
    """x * factor, exact on a CSV value's digits (Num stays Num: 0.0355 * 100 -> 3.55)."""
    if isinstance(x, Num):
        return Num(str(Decimal(x.text.strip()) * Decimal(str(factor))))
    return x * factor


def pct(k, n):
    """'k/n (p %)' as the bench programs print it (%.0f)."""
    return f"{k}/{n} ({fx(100.0 * k / n if n else 0.0, 0)} %)"


def span(values, digits=1, sep="-"):
    """'lo-hi' of the values with `digits` decimals, or one value when lo and hi print the same."""
    lo, hi = fx(min(values), digits), fx(max(values), digits)
    return lo if lo == hi else f"{lo}{sep}{hi}"


def select(data, **where):
    return [r for r in data if all(r.get(k) == v for k, v in where.items())]


class MatchSummary:
    """match_bench's summary of one group of CSV rows (bench/match_bench.cpp, the table it
    prints): overlapping = rows with overlapping 1, success = aligned 1 among them, wide = those
    with swath_overlap_m2 >= 15, medians of overlap_error_m/_deg and e_t_m/e_r_deg over the
    overlapping rows, disjoint = rows with separate 1, false overlaps = accepted 1 among them,
    median seconds over all rows."""

    def __init__(self, data):
        over = [r for r in data if one(r, "overlapping")]
        sep = [r for r in data if not one(r, "overlapping") and one(r, "separate")]
        self.rows, self.over, self.sep = data, over, sep
        self.overlapping = len(over)
        self.success = sum(one(r, "aligned") for r in over)
        wide = [r for r in over if "swath_overlap_m2" in r and f(r, "swath_overlap_m2") >= 15.0]
        self.wide, self.wide_success = len(wide), sum(one(r, "aligned") for r in wide)
        self.et = median([f(r, "overlap_error_m") for r in over])
        self.er = median([f(r, "overlap_error_deg") for r in over])
        self.ft = median([f(r, "e_t_m") for r in over])
        self.fr = median([f(r, "e_r_deg") for r in over])
        self.disjoint = len(sep)
        self.false_overlaps = sum(one(r, "accepted") for r in sep)
        self.seconds = median([f(r, "seconds") for r in data])
        # Accepted at a wrong place: an overlapping pair accepted but not aligned.
        self.wrong = [r for r in over if one(r, "accepted") and not one(r, "aligned")]

    def success_cell(self):
        return pct(self.success, self.overlapping)

    def wide_cell(self):
        return pct(self.wide_success, self.wide)

    def errors(self):
        return f"{fx(self.et, 3)} / {fx(self.er, 3)}"

    def frames(self):
        return f"{fx(self.ft, 3)} / {fx(self.fr, 3)}"

    def false_cell(self):
        return f"{self.false_overlaps} ({fx(100.0 * self.false_overlaps / self.disjoint if self.disjoint else 0, 0)} %)"


def summary(name, **where):
    return MatchSummary(select(rows(name), **where))


def table(header, body):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in body]
    return "\n".join(lines)
