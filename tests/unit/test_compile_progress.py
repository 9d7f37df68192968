"""A compile that takes long says so in the run's log while it lasts, and stops saying so when it
ends; one that ends quickly says nothing."""
from __future__ import annotations

import logging
import threading
import time

import pytest

from twmr.master import compile_progress as progress


def lines(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "twmr.run"]


@pytest.mark.timeout(60)
def test_a_long_compile_is_reported_until_it_ends(caplog, monkeypatch) -> None:
    monkeypatch.setattr(progress, "FIRST", 0.01)
    monkeypatch.setattr(progress, "EVERY", 0.01)
    caplog.set_level(logging.INFO, logger="twmr.run")
    with progress.compile_progress("the step loop"):
        end = time.monotonic() + 50
        while len(lines(caplog)) < 2 and time.monotonic() < end:  # however slow the machine
            time.sleep(0.01)
    said = lines(caplog)
    assert len(said) >= 2
    assert said[0].startswith("compiling the step loop (numba; what its cache holds is read "
                              "back): ") and "s so far" in said[0]
    time.sleep(0.1)
    assert lines(caplog) == said  # the reporting thread ended with the block


@pytest.mark.timeout(60)
def test_a_quick_compile_says_nothing(caplog) -> None:
    caplog.set_level(logging.INFO, logger="twmr.run")
    with progress.compile_progress("the step loop"):
        pass
    assert lines(caplog) == []


@pytest.mark.timeout(60)
def test_nothing_is_watched_where_no_compile_is_likely(caplog, monkeypatch) -> None:
    """Every kind held by the process: no thread is started (a sweep's later runs)."""
    monkeypatch.setattr(progress, "FIRST", 0.0)
    caplog.set_level(logging.INFO, logger="twmr.run")
    before = threading.active_count()
    with progress.compile_progress("the step loop", likely=False):
        assert threading.active_count() == before
        time.sleep(0.05)
    assert lines(caplog) == []
