"""``report.versions`` (every run folder's versions and commit) is found once per process:
one git call however many seeds ask, and each caller gets its own copy."""

from __future__ import annotations

import subprocess

from cmdp_pymunk import report


def test_one_git_call_for_many_seeds_and_a_copy_each(monkeypatch):
    calls = []

    def git(*args, **kwargs):
        calls.append(args[0])
        return subprocess.CompletedProcess(args[0], 0, stdout="abc123\n")

    monkeypatch.setattr(report.subprocess, "run", git)
    report._versions.cache_clear()
    try:
        first = report.versions()
        first["commit"] = "changed by a caller"
        again = [report.versions() for _ in range(5)]
    finally:
        report._versions.cache_clear()  # the next caller finds the real commit
    assert calls == [["git", "rev-parse", "HEAD"]]
    assert all(v["commit"] == "abc123" for v in again)
    assert again[0]["python"] and again[0]["pymunk"]
