"""A second results folder and report of the same study compiles nothing (issue 19: a cold
``lumijax demo`` compiled 159 programs; every one should be compiled once per shape, not per
call): the results' document, patches.vtp (its operator product, figured in a thread) and the
report's photometry (beam angles from the polar curves) reuse the first pass's programs.
Pictures are left out to keep it cheap."""

from __future__ import annotations

import warnings

import jax.monitoring as mon
import pytest

pytest.importorskip("pyvista")

from lumijax.report import write_report, write_results  # noqa: E402


def test_a_second_report_of_the_same_study_compiles_nothing(two_rooms, tmp_path):
    study, results = two_rooms
    compiled = []

    def listen(event, duration, **_):
        if event == "/jax/core/compile/backend_compile_duration":
            compiled.append(duration)

    def once(name):
        out = tmp_path / name
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            paths = write_results(results, out, images=False)
            write_report(study, results, out / "report.html", pictures=False)
        return paths

    first = once("a")
    assert "patches.vtp" in first  # the threaded operator product ran
    mon.register_event_duration_secs_listener(listen)
    try:
        second = once("b")
    finally:
        mon.unregister_event_duration_listener(listen)
    assert sorted(second) == sorted(first)
    assert (tmp_path / "a" / "patches.vtp").read_bytes() == (
        tmp_path / "b" / "patches.vtp").read_bytes()
    assert compiled == []
