"""usable_cpus: the process's affinity where the platform has one, else the machine's CPU count."""

from __future__ import annotations

from navlog.replay.runtime import cpus


def test_affinity_where_the_platform_has_it_else_the_cpu_count(monkeypatch):
    monkeypatch.setattr(cpus.os, "sched_getaffinity", lambda pid: {0, 3, 5}, raising=False)
    assert cpus.usable_cpus() == 3
    monkeypatch.delattr(cpus.os, "sched_getaffinity", raising=False)  # macOS, Windows
    monkeypatch.setattr(cpus.os, "cpu_count", lambda: 6)
    assert cpus.usable_cpus() == 6
    monkeypatch.setattr(cpus.os, "cpu_count", lambda: None)
    assert cpus.usable_cpus() == 1
