"""Evaluation: accuracy against the reference simulator, speed, stability (docs/accuracy.md, docs/stability.md)."""
