"""The study, claim by claim: verdicts, published numbers beside ours, and a report.

`python -m analysis.study` rebuilds `results/study/` (claims.csv, numbers.csv, report.md and
the cost-per-round figure) from the shipped run files, without training
(docs/study.md#claim-by-claim). The catalog of distinct claims is `analysis/catalog.csv`;
each testable claim's rule lives in the chapter module that owns its evidence.
"""
