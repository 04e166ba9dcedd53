"""The live terminal view of ``prezence up``, drawn with `rich`_: it fits the terminal's width.

One row per metric: its newest value, its ideal band, whether it is fresh or stale (and for how
long no new value came), and its weight toward the cue threshold (a bar: when it is full the
robot gives the cue, unless another cue, the quiet gap or the metric's refractory time holds it
back, which the row also says). Below: the last cues with their reasons, and each module's
health (running, restarted, finished, failed). Module events scroll above the table.

Without a terminal (output to a file or a pipe), or without ``rich``, the view prints events
and cues as plain lines, never the redrawn table.

.. _rich: https://github.com/Textualize/rich
"""

from __future__ import annotations

import re
import sys
from collections import deque
from typing import IO, Any

from prezence.config.model import Config
from prezence.processor import Decision

#: Redraw at most this often (seconds of talk).
REDRAW_S = 0.5
#: Cues kept in the view.
LAST_CUES = 4
#: Width of the weight bar, characters.
BAR = 10


def _mmss(t: float) -> str:
    t = max(0.0, t)
    return f"{int(t // 60)}:{t % 60:04.1f}"


def weight_bar(weight: float, threshold: float, width: int = BAR) -> str:
    """``█████░░░░░ 50%``: ``weight`` as a share of ``threshold`` (capped at 100%).

    Example:
        >>> weight_bar(300.0, 600.0, 4)
        '██░░  50%'
    """
    share = 0.0 if threshold <= 0 else max(0.0, min(1.0, weight / threshold))
    full = int(round(share * width))
    return "█" * full + "░" * (width - full) + f" {100 * share:3.0f}%"


class RichLiveView:
    """The live view: ``decision(d)`` and ``event(now, text)`` from the talk loop, :meth:`close`.

    Args:
        config: the rules (bands, units, strictness) and the threshold.
        modules: the names of the supervised modules (their health rows).
        console: a ``rich.console.Console`` (tests and screenshots give one with a fixed width
            that records); None: the terminal.
        stream: the plain output when there is no terminal.
    """

    def __init__(
        self,
        config: Config,
        modules: tuple[str, ...] | list[str] = (),
        *,
        console: Any = None,
        stream: IO[str] | None = None,
        measured: set[str] | None = None,
    ) -> None:
        self.config = config
        #: the metrics some module writes (None: unknown); the others are "not measured"
        self.measured = measured
        self.out = stream or sys.stdout
        self.health: dict[str, str] = {m: "running" for m in modules}
        self.cues: deque[tuple[float, str, str]] = deque(maxlen=LAST_CUES)
        self.last_change: dict[str, tuple[float | None, float]] = {}
        self._last_draw = -1.0
        self._decision: Decision | None = None
        self._live: Any = None
        self.console: Any = console
        if console is None and self.out.isatty():
            from rich.console import Console

            self.console = Console(file=self.out)
        if self.console is not None and console is None:
            from rich.live import Live

            self._live = Live(
                console=self.console, auto_refresh=False, transient=False, redirect_stdout=False
            )
            self._live.start()

    # -- the calls of the talk loop ----------------------------------------------------------

    def event(self, now: float, text: str) -> None:
        """A module or talk event: printed above the table; module health updated."""
        m = re.match(r"module (\S+) (.*)", text)
        if m:
            name, rest = m.group(1), m.group(2)
            if "cannot use its input" in rest:
                self.health[name] = "FAILED: " + rest.split(": ", 1)[-1]
            elif "restarted" in rest:
                self.health[name] = f"running (restart {rest.split('attempt ')[-1].rstrip(')')})"
            elif "finished" in rest:
                self.health[name] = "finished its input"
            elif rest.startswith("ended (exit 0)"):  # a module that stopped by itself
                self.health[name] = "ended (exit 0)"
            elif "exited" in rest or "hung" in rest:
                self.health[name] = "down: " + rest.split(";")[0]
        self._print(f"{_mmss(now)}  {text}")

    def decision(self, d: Decision) -> None:
        """Each decision point: a cue is printed at once; the table is redrawn every 0.5 s."""
        for mv in d.metrics:
            prev = self.last_change.get(mv.metric)
            if prev is None or prev[0] != mv.value:
                self.last_change[mv.metric] = (mv.value, d.t)
        self._decision = d
        if d.cue is not None:
            self.cues.append((d.t, d.cue.command, d.cue.reason))
            self._print(f"{_mmss(d.t)}  CUE {d.cue.command}: {d.cue.reason}")
        if self.console is not None and (d.cue is not None or d.t - self._last_draw >= REDRAW_S):
            self._last_draw = d.t
            self.refresh()

    def close(self) -> None:
        """Stop redrawing (the last table stays on the screen)."""
        if self._live is not None:
            self.refresh()
            self._live.stop()
            self._live = None

    # -- drawing -------------------------------------------------------------------------------

    def _print(self, line: str) -> None:
        if self.console is not None:
            self.console.print(line, markup=False, highlight=False, overflow="fold")
        else:
            print(line, file=self.out, flush=True)

    def refresh(self) -> None:
        if self.console is None:
            return
        view = self.renderable()
        if self._live is not None:
            self._live.update(view, refresh=True)

    def renderable(self) -> Any:
        """The table, the last cues and the modules' health as one rich renderable."""
        from rich.console import Group
        from rich.table import Table
        from rich.text import Text

        d = self._decision
        thr = self.config.processor.threshold
        now = d.t if d is not None else 0.0
        head = Text.assemble(
            (f" {_mmss(now)} ", "bold reverse"),
            "  robot ",
            ("busy" if d is not None and d.busy else "free", "yellow" if d and d.busy else "green"),
            f"   a cue comes when a bar is full (threshold {thr:g})",
            no_wrap=True,
            overflow="ellipsis",
        )
        table = Table(expand=True, pad_edge=False, box=None, show_edge=False, header_style="bold")
        table.add_column("metric", no_wrap=True, overflow="ellipsis", ratio=3)
        table.add_column("now", justify="right", no_wrap=True, ratio=2)
        table.add_column("ideal", no_wrap=True, overflow="ellipsis", ratio=3)
        table.add_column("state", no_wrap=True, overflow="ellipsis", ratio=3)
        table.add_column("toward a cue", no_wrap=True, overflow="ellipsis", ratio=4)
        views = {m.metric: m for m in d.metrics} if d is not None else {}
        for r in self.config.rules:
            mv = views.get(r.metric)
            unit = f" {r.unit}" if r.unit else ""
            lo = "" if r.low is None else f"{r.low:g}"
            hi = "" if r.high is None else f"{r.high:g}"
            if lo and hi:
                band = f"{lo}..{hi}{unit}"
            else:
                band = f">= {lo}{unit}" if lo else f"<= {hi}{unit}"
            if r.offset:  # the value shown is as judged: shifted by the offset
                band += " at listener" if r.at else f" offset {r.offset:+g}"
            if mv is None or mv.value is None:
                absent = self.measured is not None and r.metric not in self.measured
                why = "not measured" if absent else "no data yet"
                table.add_row(r.metric, "--", band, Text(why, "dim"), "")
                continue
            age = now - self.last_change.get(r.metric, (None, now))[1]
            if mv.stale:
                state = Text(f"stale {age:.0f}s", "dim")
            elif mv.deviation > 0:
                state = Text(f"OUT {mv.deviation:.0f}%", "bold red")
            else:
                state = Text("ok", "green")
            if r.strict:
                toward = Text("strict: cue at once" if mv.deviation > 0 else "strict", "magenta")
            elif mv.refractory:
                toward = Text(weight_bar(mv.weight, thr) + " (just cued)", "dim")
            else:
                style = "red" if mv.weight >= thr else "yellow" if mv.weight > 0 else "dim"
                toward = Text(weight_bar(mv.weight, thr), style)
            table.add_row(r.metric, f"{mv.value:.4g}", band, state, toward)
        parts: list[Any] = [head, table]
        if d is not None and d.cue is None and d.reason:
            parts.append(Text(f" no cue now: {d.reason}", "dim", no_wrap=True, overflow="ellipsis"))
        for t, cmd, why in reversed(self.cues):
            parts.append(
                Text.assemble(
                    (f" {_mmss(t)} {cmd}", "bold cyan"),
                    f"  {why}",
                    no_wrap=True,
                    overflow="ellipsis",
                )
            )
        if self.health:
            mods = Text(" modules: ", "bold", no_wrap=True, overflow="ellipsis")
            for i, (name, h) in enumerate(self.health.items()):
                style = "red" if h.startswith(("FAILED", "down")) else "green"
                mods.append(("  " if i else "") + f"{name} {h}", style)
            parts.append(mods)
        return Group(*parts)
