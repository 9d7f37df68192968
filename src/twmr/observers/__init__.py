"""Observers: what watches a run — the result store, summary, pacing statistics, progress."""
from twmr.observers.base import Observer, Outcome, RunStart

__all__ = ["Observer", "Outcome", "RunStart"]
