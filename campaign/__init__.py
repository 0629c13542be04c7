"""Campaigns: many forward simulations over a parameter design, run in parallel into a resumable
store under ``runs/<name>/`` (ARCHITECTURE.md, "Results on disk")."""
