"""Analysis of run directories: published numbers, leaderboard, claims, figures.

Reads run files only (DESIGN Sec. 8); never imported by `cpg_suite` or `baselines`.
"""
