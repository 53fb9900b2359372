"""Analysis of run directories: published numbers, leaderboard, claims, figures.

Reads run files only (docs/architecture.md#packages-and-data-flow); never imported by
`cpg_suite` or `baselines`.
"""
