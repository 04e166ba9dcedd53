"""Report plots as PNG bytes (matplotlib, the ``report`` extra).

matplotlib is imported inside each function, and only its object-oriented API is used (a
:class:`~matplotlib.figure.Figure` with an Agg canvas, no ``pyplot``): no global state, no GUI
backend, safe in worker processes. :func:`available` tells whether plots can be drawn.
"""

from __future__ import annotations

import importlib.util
import io
from collections.abc import Mapping, Sequence
from typing import Any

from prezence.samples import Sample

#: Colours: in range, out of range, cue markers, the ideal band.
GOOD = "#2e7d32"
BAD = "#c62828"
CUE = "#1565c0"
BAND = "#c8e6c9"
NEUTRAL = "#757575"


def available() -> bool:
    """True when matplotlib is installed (``pip install "prezence[report]"``)."""
    return importlib.util.find_spec("matplotlib") is not None


def plain(text: object) -> str:
    """``text`` as matplotlib shows it literally: ``$`` would start math mode (a unit such as
    ``US$ $5`` or ``$\\frac$`` made the whole report fail)."""
    return str(text).replace("$", r"\$")


def _png(fig: Any) -> bytes:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return buf.getvalue()


#: Candidate spacings of the time axis's ticks, seconds.
TICK_STEPS_S = (1.0, 2.0, 5.0, 10.0, 15.0, 30.0, 60.0, 120.0, 300.0, 600.0, 900.0, 1800.0)
#: The time axis gets at most this many intervals between ticks.
MAX_TICKS = 10


def tick_step(talk_s: float) -> float:
    """Tick spacing for a talk of ``talk_s`` seconds: the smallest of :data:`TICK_STEPS_S`
    that gives at most :data:`MAX_TICKS` intervals (so a 36 s clip is not labelled "0:00" only).

    Example:
        >>> [tick_step(t) for t in (8, 36, 95, 600, 1500, 3600)]
        [1.0, 5.0, 10.0, 60.0, 300.0, 600.0]
    """
    for step in TICK_STEPS_S:
        if talk_s / step <= MAX_TICKS:
            return step
    return TICK_STEPS_S[-1]


def _minutes_axis(ax: Any, talk_s: float) -> None:
    from matplotlib.ticker import FuncFormatter, MultipleLocator

    ax.xaxis.set_major_locator(MultipleLocator(tick_step(talk_s)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{int(x // 60)}:{int(x % 60):02d}"))
    ax.set_xlim(0.0, max(talk_s, 1.0))


def no_data_spans(
    ts: Sequence[float], talk_s: float, stale_s: float | None, cuts: Sequence[float] = ()
) -> list[tuple[float, float]]:
    """The stretches of the talk no sample holds: before the first, and wherever a sample
    held (until the next, ``stale_s`` after it, the next of ``cuts``: its module died) ends
    before the next one; the report's time in range counts them as no data. A plot leaves
    them blank rather than draw a line across them.

    Example:
        >>> no_data_spans([2.0, 3.0, 20.0, 21.0], 30.0, 6.0)
        [(0.0, 2.0), (9.0, 20.0), (27.0, 30.0)]
    """
    out: list[tuple[float, float]] = []
    t = sorted(x for x in ts if x < talk_s)
    if not t:
        return [(0.0, talk_s)] if talk_s > 0 else []
    if t[0] > 0.0:
        out.append((0.0, t[0]))
    stale = float("inf") if stale_s is None else float(stale_s)
    ends = sorted(cuts)
    for i, a in enumerate(t):
        nxt = t[i + 1] if i + 1 < len(t) else talk_s
        held = min(nxt, a + stale, talk_s)
        died = [c for c in ends if c >= a]
        if died:
            held = min(held, died[0])
        if held < nxt:
            out.append((held, nxt))
    return out


def timeline_png(
    metric: Mapping[str, Any],
    samples: Sequence[Sample],
    cues: Sequence[Mapping[str, Any]],
    *,
    talk_s: float,
    allocated_s: float | None = None,
    width_in: float = 10.0,
    height_in: float = 2.4,
) -> bytes:
    """One metric over the talk: samples, its ideal band, and the cues about it.

    Args:
        metric: the report's entry for the metric (``label``, ``unit``, ``low``, ``high``).
        samples: the metric's samples.
        cues: the cues about this metric (``t``, ``command``).
        talk_s: the talk's length (x range).
        allocated_s: drawn as a dashed line when inside the x range.
    """
    import numpy as np
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in))
    # Fixed margins (not a constrained layout) so that the timelines of all metrics line up
    # one under the other on the page, whatever the width of their tick labels.
    fig.subplots_adjust(left=0.075, right=0.985, top=0.84, bottom=0.14)
    ax = fig.add_subplot()
    low, high = metric.get("low"), metric.get("high")
    t = np.array([s.t for s in samples], dtype=float)
    v = np.array([s.value for s in samples], dtype=float)
    finite = [x for x in (low, high) if x is not None]
    lo_y = min([*v.tolist(), *finite]) if len(v) or finite else 0.0
    hi_y = max([*v.tolist(), *finite]) if len(v) or finite else 1.0
    pad = 0.08 * (hi_y - lo_y or 1.0)
    y0, y1 = lo_y - pad, hi_y + pad
    band_lo = low if low is not None else y0
    band_hi = high if high is not None else y1
    ax.axhspan(band_lo, band_hi, color=BAND, alpha=0.7, lw=0, label="ideal range")
    for b in finite:
        ax.axhline(b, color=GOOD, lw=0.8, alpha=0.8)
    if len(t):
        out = np.zeros(t.shape, dtype=bool)
        if low is not None:
            out |= v < low
        if high is not None:
            out |= v > high
        cuts = [float(sp["from"]) for sp in metric.get("lost") or () if "from" in sp]
        gaps = no_data_spans(t.tolist(), talk_s, metric.get("stale_after_s"), cuts)
        # the line breaks where no sample held: a straight line across a silence would read
        # as measured
        line_t, line_v = t.tolist(), v.tolist()
        for a, _ in reversed(gaps):
            i = int(np.searchsorted(t, a, side="right"))
            if 0 < i < len(t):
                line_t.insert(i, a)
                line_v.insert(i, float("nan"))
        ax.plot(line_t, line_v, color=NEUTRAL, lw=0.8, alpha=0.8)
        for j, (a, b) in enumerate(gaps):
            ax.axvspan(a, b, color=NEUTRAL, alpha=0.12, lw=0, label="no data" if j == 0 else None)
        ax.scatter(t[out], v[out], s=6, color=BAD, zorder=3, label="out of range")
    last_x: float | None = None
    row = 0
    for i, c in enumerate(sorted(cues, key=lambda c: float(c["t"]))):
        tc = float(c["t"])
        ax.axvline(tc, color=CUE, lw=1.4, alpha=0.9, label="cue" if i == 0 else None)
        right_edge = tc > 0.85 * talk_s  # keep the name inside the plot near the end
        # Names of cues close together go on successive rows instead of on top of each other.
        row = row + 1 if last_x is not None and tc - last_x < 0.12 * talk_s else 0
        last_x = tc
        ax.annotate(
            plain(c["command"]),
            (tc, 1.0),
            xycoords=("data", "axes fraction"),
            xytext=(-3 if right_edge else 3, -3 - 11 * (row % 3)),
            textcoords="offset points",
            fontsize=8,
            color=CUE,
            va="top",
            ha="right" if right_edge else "left",
            bbox={"boxstyle": "square,pad=0.1", "fc": "white", "ec": "none", "alpha": 0.8},
        )
    if allocated_s and allocated_s < talk_s:
        ax.axvline(allocated_s, color="black", lw=1.0, ls="--", label="time allocated")
    ax.set_ylim(y0, y1)
    _minutes_axis(ax, talk_s)
    unit = metric.get("unit") or ""
    ax.set_ylabel(plain(unit))
    ax.set_title(plain(metric.get("label", "")), loc="left", fontsize=11, fontweight="bold")
    ax.grid(axis="x", alpha=0.3)
    # Above the plot, right of the title: never over the data or the cue names.
    ax.legend(
        loc="lower right",
        bbox_to_anchor=(1.0, 1.0),
        fontsize=8,
        ncols=4,
        frameon=False,
        borderaxespad=0.2,
    )
    return _png(fig)


def summary_png(report: Mapping[str, Any], *, width_in: float = 10.0) -> bytes:
    """Time in range per metric (bars) and deviation per minute of talk (what to work on)."""
    from matplotlib.figure import Figure

    metrics = list(report["metrics"].values())
    labels = [plain(m.get("label")) for m in metrics]
    # A metric without data has no bar, and says so: 0% would read as "always out of range".
    measured = [m.get("time_in_range") is not None for m in metrics]
    m_state = [m.get("data") if m.get("data") not in (None, "ok") else "no data" for m in metrics]
    tir = [100.0 * (m.get("time_in_range") or 0.0) for m in metrics]
    # seconds out of range: a figure a presenter reads without a glossary
    dev = [float(m.get("out_of_range_s") or 0.0) for m in metrics]
    fig = Figure(figsize=(width_in, 0.45 * len(metrics) + 1.3), layout="constrained")
    a1, a2 = fig.subplots(1, 2, sharey=True)
    y = list(range(len(metrics)))
    colours = [GOOD if x >= 90 else "#f9a825" if x >= 70 else BAD for x in tir]
    a1.barh(y, [x if ok else 0.0 for x, ok in zip(tir, measured, strict=True)], color=colours)
    for yi, x, ok in zip(y, tir, measured, strict=True):
        inside = ok and x > 15
        a1.text(
            x - 1.5 if inside else x + 1.5,
            yi,
            f"{x:.0f}%" if ok else str(m_state[yi]),
            va="center",
            fontsize=9,
            ha="right" if inside else "left",
            color="white" if inside else "black" if ok else NEUTRAL,
        )
    a1.set_xlim(0, 100)
    a1.set_yticks(y, labels)
    a1.invert_yaxis()
    a1.set_title("time in the ideal range", loc="left", fontsize=10)
    a2.barh(y, dev, color=BAD)
    top = max(dev, default=0.0) or 1.0
    a2.set_xlim(0, 1.15 * top)
    for yi, x, ok in zip(y, dev, measured, strict=True):
        a2.text(
            x + 0.01 * top,
            yi,
            f"{x:.0f} s" if ok else str(m_state[yi]),
            va="center",
            fontsize=9,
            color="black" if ok else NEUTRAL,
        )
    a2.set_title("time out of the ideal range", loc="left", fontsize=10)
    for a in (a1, a2):
        a.grid(axis="x", alpha=0.3)
    return _png(fig)
