"""Issue 13: the live view fits the terminal and says why a cue did or did not come."""

from __future__ import annotations

import io

import pytest

from prezence.config.load import load_config
from prezence.processor import Processor, make_policy
from prezence.samples import Sample

rich = pytest.importorskip("rich")

from rich.console import Console  # noqa: E402

from prezence.live_view import RichLiveView  # noqa: E402


def _view_after(width: int, seconds: float) -> tuple[str, RichLiveView]:
    config = load_config(None)
    proc = Processor(config, policy=make_policy("weighted"))
    buf = io.StringIO()
    console = Console(file=buf, width=width, record=True, color_system=None)
    view = RichLiveView(config, ["speech", "vision"], console=console)
    view.event(0.0, "module vision exited with status 1; restart in 1 s (metrics stale meanwhile)")
    t = 0.0
    while t < seconds:
        t = round(t + 0.5, 3)
        samples = [Sample("speech_speed", t, 230.0), Sample("cv_gestures", t, 5.0)]
        view.decision(proc.step(t, samples, free_since=0.0))
    console.print(view.renderable())
    return console.export_text(), view


@pytest.mark.parametrize("width", [80, 120])
def test_every_line_fits_the_terminal_and_each_metric_has_one_row(width: int) -> None:
    text, _ = _view_after(width, 30.0)
    lines = text.splitlines()
    assert max(len(ln) for ln in lines) <= width
    table = lines[lines.index(next(ln for ln in lines if ln.startswith("metric"))) :]
    for metric in ("speech_speed", "speech_volume", "cv_gestures"):
        assert sum(ln.startswith(metric) for ln in table) == 1


def test_the_view_shows_weight_toward_threshold_cues_and_module_health() -> None:
    text, view = _view_after(120, 30.0)
    assert "threshold 600" in text and "%" in text
    assert "CUE slowDown" in text  # the cue, with its reason
    assert "above 180" in text
    assert "vision down" in text  # the module that exited
    assert view.health["speech"] == "running"


def test_a_module_that_exited_0_is_shown_as_ended_not_running() -> None:
    # session 22: a module of one's own that exits 0 is not restarted; the view said "running"
    view = RichLiveView(load_config(None), ["speech", "fill"], stream=io.StringIO())
    view.event(30.2, "module fill ended (exit 0); its metrics are not measured from then")
    assert view.health == {"speech": "running", "fill": "ended (exit 0)"}
