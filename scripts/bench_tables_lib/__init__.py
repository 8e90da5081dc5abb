"""The generators of scripts/bench_tables.py, one module per group of generated regions.

common       registration (@block, @inline), readers of docs/bench/ and the bench programs'
             aggregations (median, fx, pct, select, table, MatchSummary, ...)
matching     realistic magnetometers (field statistics, tuning, held-out matching and merges,
             Aalto), simulator, matching on clean sensors and refinement
merge_peers  merges (merge_bench), featureless merges and the peer benchmark
scale_add    the scaling and add benches

Importing a generator module registers its regions in common.BLOCKS and common.INLINES;
scripts/bench_tables.py imports all of them.
"""
