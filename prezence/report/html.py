"""The report as one self-contained HTML page (inline CSS, plots inline as base64 PNG)."""

from __future__ import annotations

import base64
import html
from collections.abc import Mapping
from typing import Any

from prezence.report.speech import (
    EDGE_HEAD,
    cue_count_parts,
    cue_mark,
    edge_text,
    heard_none,
    listed_coverage,
    measured_s,
    measured_share,
    metric_notes,
    mmss,
    off_sides_text,
    praise_line,
    priority_sides,
    summary_phrase,
    time_sentence,
    trouble_sentences,
    unmeasured_labels,
    unmeasured_line,
    was,
)

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; margin: 0;
       background: #f5f6f8; color: #1d2129; }
main { max-width: 1040px; margin: 0 auto; padding: 24px 28px 48px; }
h1 { font-size: 26px; margin: 0 0 4px; }
h2 { font-size: 19px; margin: 32px 0 10px; border-bottom: 1px solid #d6d9de; padding-bottom: 4px; }
.sub { color: #5f6773; font-size: 14px; margin-bottom: 18px; }
.note { background: #fff4e5; border-left: 4px solid #f9a825; padding: 8px 12px; margin: 12px 0; }
.cards { display: flex; gap: 14px; flex-wrap: wrap; }
.card { background: #fff; border-radius: 8px; padding: 12px 16px; flex: 1 1 200px;
        box-shadow: 0 1px 2px rgba(0,0,0,.08); }
.card .big { font-size: 26px; font-weight: 600; }
.card .lbl { color: #5f6773; font-size: 13px; }
.over { color: #c62828; } .under { color: #1565c0; } .ok { color: #2e7d32; }
ol.work { background: #fff; border-radius: 8px; padding: 12px 16px 12px 40px; margin: 0;
          box-shadow: 0 1px 2px rgba(0,0,0,.08); }
ol.work li { margin: 6px 0; font-size: 16px; }
ol.work .why { color: #5f6773; font-size: 13px; }
table { border-collapse: collapse; width: 100%; background: #fff; font-size: 14px;
        box-shadow: 0 1px 2px rgba(0,0,0,.08); }
th, td { padding: 6px 10px; border-bottom: 1px solid #eceef1; text-align: right; }
th { background: #eef0f3; font-weight: 600; }
td.l, th.l { text-align: left; }
img { width: 100%; height: auto; background: #fff; border-radius: 6px; display: block;
      margin: 8px 0 14px; box-shadow: 0 1px 2px rgba(0,0,0,.08); }
.yes { color: #2e7d32; font-weight: 600; } .no { color: #5f6773; }
.fa { color: #c62828; font-weight: 600; }
.reason { color: #7a828e; font-size: 12px; }
.nodata { color: #7a828e; }
.said { font-style: italic; color: #37474f; }
footer { color: #5f6773; font-size: 12px; margin-top: 36px; }
"""


def _e(x: object) -> str:
    return html.escape(str(x))


def _mmss(t: float | None) -> str:
    """:func:`prezence.report.speech.mmss` (h:mm:ss past an hour), "–" for none."""
    return "–" if t is None else mmss(t)


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100.0 * x:.0f}%"


def _num(x: float | None) -> str:
    if x is None:
        return "–"
    return f"{x:.3g}" if abs(x) < 10 else f"{x:.0f}"


def _img(png: bytes | None, alt: str) -> str:
    if not png:
        return ""
    data = base64.b64encode(png).decode("ascii")
    return f'<img alt="{_e(alt)}" src="data:image/png;base64,{data}">'


def _band(m: Mapping[str, Any]) -> str:
    low, high, unit = m.get("low"), m.get("high"), m.get("unit") or ""
    if m.get("where"):  # a rule's offset: the band applies to the shifted values
        unit = f"{unit} {m['where']}".strip()
    if low is not None and high is not None:
        return f"{_num(low)}–{_num(high)} {unit}".strip()
    if low is not None:
        return f"≥ {_num(low)} {unit}".strip()
    if high is not None:
        return f"≤ {_num(high)} {unit}".strip()
    return "–"


def _time_card(report: Mapping[str, Any]) -> str:
    t = report["time"]
    alloc = t.get("allocated_s")
    pct = t.get("over_under_pct")
    if alloc and pct is not None:
        cls = "ok" if abs(pct) < 5 else "over" if pct > 0 else "under"
        word = "over" if pct > 0 else "under"
        detail = f'<span class="{cls}">{abs(pct):.0f}% {word}</span> the {_mmss(alloc)} allocated'
        if t.get("stopped_at_limit"):
            detail = (
                f'<span class="{cls}">at least {abs(pct):.0f}% over</span> the {_mmss(alloc)} '
                "allocated: still going when the time limit stopped the talk"
            )
    else:
        detail = "no time allocated"
    return (
        f'<div class="card"><div class="lbl">time used</div>'
        f'<div class="big">{_mmss(t["used_s"])}</div><div>{detail}</div></div>'
    )


def render_html(report: Mapping[str, Any], images: Mapping[str, bytes] | None = None) -> str:
    """The report page.

    Args:
        report: from :func:`prezence.report.build.build_report`.
        images: PNG bytes by name: ``summary`` and ``timeline_<metric>``; missing ones are
            left out (without matplotlib the page has tables only).
    """
    images = images or {}
    counts = report["counts"]
    title = "Post-speech report"
    who = report.get("scenario") or report.get("session")
    sub = [f"talk: {_e(who)}"]
    if report.get("seed") is not None:
        sub.append(f"seed {_e(report['seed'])}")
    if report.get("policy"):
        sub.append(f"policy {_e(report['policy'])}")
    if report.get("backend"):
        sub.append(f"robot {_e(report['backend'])}")
    if report.get("replay_of"):
        sub.append(f"a replay of {_e(report['replay_of'])}")
    out: list[str] = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{title}: {_e(who)}</title><style>{_CSS}</style></head><body><main>",
        f"<h1>{title}</h1>",
        f'<div class="sub">{" · ".join(sub)}</div>',
    ]
    if not report.get("complete", True):
        out.append(
            f'<div class="note">The record stops at {_mmss(report["talk_s"])} of a planned '
            f"{_mmss(report.get('planned_s'))} (the coach stopped early). The figures cover "
            "what was recorded.</div>"
        )
    for sentence in trouble_sentences(report) + metric_notes(report):
        out.append(f'<div class="note">{_e(sentence[0].upper() + sentence[1:])}.</div>')
    if report.get("plots_missing"):
        install = (
            '<code>pip install "prezence[report]"</code>, then '
            if "not installed" in report["plots_missing"]
            else ""
        )
        out.append(
            f'<div class="note">No plots in this report: {_e(report["plots_missing"])}. '
            f"To get them: {install}<code>prezence report {_e(report.get('session'))}</code>"
            f"{'' if install else ' (or run the talk with <code>--plots</code>)'}.</div>"
        )
    out.append('<div class="cards">')
    out.append(_time_card(report))
    parts = "".join(
        f'<div class="fa">{_e(p)}</div>'
        if "false alarm" in p or "stale" in p
        else f"<div>{_e(p[0].upper() + p[1:])}.</div>"
        for p in cue_count_parts(report)
    )
    out.append(
        f'<div class="card"><div class="lbl">cues from the robot</div>'
        f'<div class="big">{counts.get("cues", 0)}</div>{parts}</div>'
    )
    tirs = [m.get("time_in_range") for m in report["metrics"].values()]
    tirs_ok = [x for x in tirs if x is not None]
    overall = sum(tirs_ok) / len(tirs_ok) if tirs_ok else None
    measured = (
        f"{len(tirs_ok)} metric{'' if len(tirs_ok) == 1 else 's'} measured"  # not "1 metrics"
    )
    out.append(
        f'<div class="card"><div class="lbl">time in the ideal range (mean of metrics)</div>'
        f'<div class="big">{_pct(overall)}</div><div>{measured}</div></div>'
    )
    out.append("</div>")

    out.append("<h2>Work on first</h2>")
    if none := unmeasured_labels(report):  # named before the advice or the praise
        out.append(f'<p class="fa">{_e(unmeasured_line(none))}</p>')
    pri = report.get("priorities") or []
    if pri:
        out.append('<ol class="work">')
        for p in pri:
            m = report["metrics"][p["metric"]]
            why = priority_sides(p, m)
            out.append(
                f"<li><b>{_e(p['advice'][0].upper() + p['advice'][1:])}</b> "
                f'({_e(p["label"])}). <span class="why">{_e(why[0].upper() + why[1:])} in all; '
                f"the longest stretch lasted {m.get('longest_out_of_range_s', 0.0):.0f} s.</span>"
                + (f" {_e(p['noise'][0].upper() + p['noise'][1:])}." if p.get("noise") else "")
                + _coverage(report, p)
                + "</li>"
            )
        out.append("</ol>")
        out.append(
            '<p class="sub">Listed: every metric cued by the robot, off by a cue\'s worth or '
            "more, or out of its ideal range for half the time it was measured or more; where "
            "its median read within the measuring error of its range, only its readings beyond "
            "that error count, and where it read in its range, only those count towards half "
            "the time. First come those out of their ideal range the longest and the "
            "farthest.</p>"
        )
    elif not report.get("slightly_off") and not report.get("at_edge"):
        out.append(
            {
                "none": (
                    "<p><b>Nothing was judged</b>: no metric was measured long enough.</p>"
                    if any(m.get("samples") for m in report["metrics"].values())
                    else "<p><b>Nothing was measured</b>: no metric has a sample.</p>"
                )
                + (
                    ""
                    if metric_notes(report) or not report.get("logs")
                    else f"<p>{_e(', '.join(report['logs']))} in the session folder may say "
                    "why.</p>"
                ),
                "some": f"<p>{_e(_praised(report, 'some'))}</p>",
                "all": f"<p>{_e(_praised(report, 'all'))}</p>",
            }[measured_share(report)]
        )
    off = [o for o in report.get("slightly_off") or [] if isinstance(o, dict)]
    if off:
        out.append(
            "<p>A little off, not enough to work on:</p>"
            if pri
            else "<p>Nothing was far off, but:</p>"
        )
        out.append('<ul class="work">')
        for o in off:
            noise = f" {_e(o['noise'][0].upper() + o['noise'][1:])}." if o.get("noise") else ""
            out.append(
                f"<li>{_e(off_sides_text(o))} (<b>{_e(o['advice'])}</b>){noise}"
                f"{_coverage(report, o)}</li>"
            )
        out.append("</ul>")
    edge = [o for o in report.get("at_edge") or [] if isinstance(o, dict)]
    if edge:
        head = f"{EDGE_HEAD}:" if pri or off else "Nothing was clearly off, but:"
        out.append(f"<p>{_e(head)}</p>")
        out.append('<ul class="work">')
        for o in edge:
            text = edge_text(o)
            out.append(f"<li>{_e(text[0].upper() + text[1:])}.{_coverage(report, o)}</li>")
        out.append("</ul>")
    stopped = [n for n in report.get("stopped_repeating") or [] if isinstance(n, dict)]
    if stopped:
        from prezence.report.build import metric_label

        out.append('<ul class="work">')
        for n in stopped:
            if heard_none(report, [str(n.get("metric"))]):  # a rehearsal: nobody was reminded
                label = metric_label(str(n.get("metric")))
                out.append(
                    f"<li>Your <b>{_e(label)}</b> {was(label)} cued {_e(str(n.get('cues')))} "
                    f"times without getting back in range, and the coach stopped cueing it "
                    f"from {float(n.get('t') or 0.0) / 60:.0f} min on (you heard none of these "
                    "cues): work on it before the next rehearsal.</li>"
                )
                continue
            out.append(
                f"<li>The robot stopped reminding you about your "
                f"<b>{_e(metric_label(str(n.get('metric'))))}</b> after "
                f"{_e(str(n.get('cues')))} reminders that did not help (from "
                f"{float(n.get('t') or 0.0) / 60:.0f} min on): work on it before the next "
                f"rehearsal.</li>"
            )
        out.append("</ul>")
    post = report.get("post_talk") or {}
    unknown = post.get("ok") is False and post.get("speech_outcome") == "unknown"
    said = post.get("speech_ok") is True
    if unknown:  # the link was lost while the robot spoke: it may have said it all
        out.append(
            f'<p>What the robot was saying when it was lost, <b class="fa">outcome unknown</b> '
            f"({_e(post.get('speech_error') or 'robot lost')}): "
            f'<span class="said">“{_e(post.get("phrase") or summary_phrase(report))}”</span></p>'
        )
    elif post.get("ok") is False and not said:  # these words were never heard
        out.append(
            f'<p>What the robot was to say, <b class="fa">not said</b> '
            f"({_e(post.get('drop_reason') or 'cut short')}): "
            f'<span class="said">“{_e(post.get("phrase") or summary_phrase(report))}”</span></p>'
        )
    else:
        out.append(
            f'<p>What the robot says: <span class="said">“{_e(summary_phrase(report))}”</span></p>'
        )

    out.append("<h2>Overview</h2>")
    out.append(_img(images.get("summary"), "time in range and deviation per metric"))
    out.append(
        '<table><tr><th class="l">metric</th><th class="l">ideal</th>'
        f"<th>measured (of {_mmss(report.get('talk_s'))})</th><th>in range</th>"
        "<th>mean</th><th>10th pct</th><th>median</th><th>90th pct</th>"
        "<th>longest out</th><th>samples</th></tr>"
    )
    for m in report["metrics"].values():
        state = m.get("data") or ("ok" if m.get("samples") else "no data")
        tir = (
            ("–*" if m.get("too_brief") else _pct(m.get("time_in_range")))  # * : not judged
            if m.get("samples")
            else f'<span class="nodata">{_e(state)}</span>'
        )
        covered = _mmss(measured_s(m)) if m.get("samples") else "–"
        out.append(
            f'<tr><td class="l">{_e(m.get("label"))}</td><td class="l">{_e(_band(m))}</td>'
            f"<td>{covered}</td><td>{tir}</td><td>{_num(m.get('mean'))}</td>"
            f"<td>{_num(m.get('p10'))}</td><td>{_num(m.get('p50'))}</td>"
            f"<td>{_num(m.get('p90'))}</td>"
            + (
                f"<td>{m.get('longest_out_of_range_s', 0.0):.0f} s</td>"
                if m.get("samples")
                else "<td>–</td>"
            )
            + f"<td>{m.get('samples', 0)}</td>"
            "</tr>"
        )
    out.append("</table>")

    timelines = [(k, images.get(f"timeline_{k}")) for k in report["metrics"]]
    if any(png for _, png in timelines):
        out.append("<h2>Timelines</h2>")
        out.append(
            '<p class="sub">Green band: the ideal range. Red dots: samples out of range. '
            "Blue lines: the robot's cues about that metric. Grey: no data (nothing measured "
            "there, the line breaks).</p>"
        )
        for k, png in timelines:
            m = report["metrics"][k]
            if png:
                out.append(_img(png, f"{m.get('label')} over the talk"))
            elif not m.get("samples") and m.get("not_measured_why"):
                out.append(
                    f'<p class="nodata"><b>{_e(m.get("label"))}</b>: not measured: '
                    f"{_e(m['not_measured_why'])}</p>"
                )
            elif not m.get("samples") and m.get("data") == "not measured":
                out.append(
                    f'<p class="nodata"><b>{_e(m.get("label"))}</b>: not measured (no module '
                    "wrote it in this session: its module was not started, or could not "
                    "measure it)</p>"
                )
            elif not m.get("samples"):
                out.append(
                    f'<p class="nodata"><b>{_e(m.get("label"))}</b>: no data (its module ran '
                    "but wrote no sample during the talk)</p>"
                )

    out.append(_head_section(report.get("head") or {}))
    out.append(_progress_section(report.get("progress")))
    out.append("<h2>Cues</h2>")
    cues = report.get("cues") or []
    if cues:
        w = report.get("effect_window_s", 30.0)
        out.append(
            f'<p class="sub">Delay: from the start of the problem to the cue. Before / after: '
            f"how far out of its ideal range the metric was, on average, in the {w:g} s "
            f"before and the {w:g} s after the cue (0% = in range). What followed: what the "
            f"metric did in those {w:g} s, which the cue may or may not have caused.</p>"
        )
        out.append(
            '<table><tr><th>time</th><th class="l">cue</th><th class="l">why</th>'
            "<th>delay</th><th>out of range before</th><th>after</th><th>what followed</th></tr>"
        )
        for c in cues:
            lat = c.get("latency_s") if c.get("metric") else None  # a time warning: none
            mark = cue_mark(c)
            eff = c.get("improved")
            eff_html = f'<span class="{"yes" if eff else "no"}">{_e(mark)}</span>' if mark else "–"
            if c.get("false_alarm") or c.get("stale") or c.get("unmeasured") or c.get("dropped"):
                shown = mark.replace("FALSE ALARM", "false alarm").replace("STALE", "stale")
                shown = shown.replace("NOT JUDGED", "not judged")
                shown = shown.replace("DROPPED", "dropped")
                eff_html = f'<span class="fa">{_e(shown)}</span>'
            cut = c.get("cut_short")
            cut_html = f'<br><span class="fa">cut short: {_e(cut)}</span>' if cut else ""
            if c.get("outcome_unknown"):
                cut_html = (
                    f'<br><span class="fa">outcome unknown: {_e(c["outcome_unknown"])}</span>'
                )

            if c.get("dropped"):  # the robot never said the phrase
                why = c.get("drop_reason") or "dropped"
                cut_html = f'<br><span class="fa">not given: {_e(why)}</span>'

            before, after = c.get("deviation_before"), c.get("deviation_after")
            out.append(
                f'<tr><td>{_mmss(c["t"])}</td><td class="l">{_e(c["command"])}'
                f'<br><span class="said">{_e(c.get("phrase") or "")}</span>{cut_html}</td>'
                # the coach's technical reason (weights, percentages) only on hover
                f'<td class="l" title="{_e(c.get("reason") or "")}">{_e(c.get("why") or "")}'
                "</td>"
                f"<td>{'–' if lat is None else f'{int(lat + 0.5)} s'}</td>"  # halves up
                f"<td>{'–' if before is None else f'{before:.0f}%'}</td>"
                f"<td>{'–' if after is None else f'{after:.0f}%'}</td><td>{eff_html}</td></tr>"
            )
        out.append("</table>")
    else:
        out.append("<p>The robot gave no cue.</p>")
    out.append(
        "<footer>Rebuilt from the session's module files (streams/), cues.jsonl and "
        f"config.toml. {_e(time_sentence(report))}</footer>"
    )
    out.append("</main></body></html>")
    return "\n".join(out) + "\n"


def _coverage(report: Mapping[str, Any], row: Mapping[str, Any]) -> str:
    """`` " Pace measured over 0:49 of 2:03 (silence for 0:40)."`` for a listed row
    (:func:`prezence.report.speech.listed_coverage`; "" where it says nothing)."""
    cov = listed_coverage(report, str(row.get("metric")))
    return f" {_e(cov[0].upper() + cov[1:])}." if cov else ""


def _praised(report: Mapping[str, Any], share: str) -> str:
    """The written praise (:func:`prezence.report.speech.praise_line`): "Well done" only when
    every judged metric covered the talk."""
    line = praise_line(report, share)
    partial = "while it was measured" in line or unmeasured_labels(report)
    return line if partial else f"{line[:-1]}. Well done."


def _head_section(head: Mapping[str, Any]) -> str:
    """Head turns: facing the audience, turned left / right (the vision module's yaw)."""
    out = ["<h2>Head turns</h2>"]
    if not head.get("measured"):
        # why, in words that fit the command that made the talk (build.no_camera_why)
        why = head.get("not_measured_why") or (
            "no camera module ran (give --video cam or a video file to prezence up; head pose "
            "needs the vision env)"
        )
        out.append(f'<p class="nodata">Not measured: {_e(why)}.</p>')
        return "\n".join(out)
    rows = []
    if head.get("facing_share") is not None:
        rows.append(("facing the audience", _pct(head["facing_share"])))
    if head.get("yaw_samples"):
        deg = head.get("turned_deg", 20.0)
        rows.append((f"head turned to your left (more than {deg:g}°)", _pct(head["left_share"])))
        rows.append((f"head turned to your right (more than {deg:g}°)", _pct(head["right_share"])))
        rows.append(("times you turned away", str(head.get("turns_away", 0))))
        rows.append(("typical turn (median)", f"{head['median_abs_yaw_deg']:.0f}°"))
    if not rows and head.get("not_measured_why"):
        out.append(f'<p class="nodata">Not measured: {_e(head["not_measured_why"])}.</p>')
        return "\n".join(out)
    if not rows:
        out.append('<p class="nodata">No data: the camera module saw no face.</p>')
        return "\n".join(out)
    out.append('<table><tr><th class="l">head</th><th>share of the talk</th></tr>')
    out += [f'<tr><td class="l">{_e(a)}</td><td>{_e(b)}</td></tr>' for a, b in rows]
    out.append("</table>")
    return "\n".join(out)


def _progress_section(progress: Mapping[str, Any] | None) -> str:
    """Each metric's time in range over the speaker's rehearsals, oldest first; a cell judged
    by another band than the newest rehearsal's is marked † and left out of the trend, one
    not judged (measured too briefly) is "–*" (:func:`prezence.progress.cell`)."""
    if not progress or len(progress.get("sessions", [])) < 2:
        return ""
    sessions = progress["sessions"]
    out = [
        "<h2>Progress across rehearsals</h2>",
        f'<p class="sub">{len(sessions)} rehearsals of {_e(progress.get("speaker") or "?")}, '
        "oldest first: time in the ideal range; the trend is the newest against the one "
        "before.</p>",
        '<table><tr><th class="l">metric</th>'
        + "".join(
            f'<th>{_e(s.get("name") or "")}<br><span class="reason">{_e(s["label"])}</span></th>'
            for s in sessions
        )
        + "<th>trend</th></tr>",
    ]
    from prezence.progress import cell

    for row in progress["rows"]:
        cells = "".join(f"<td>{_e(cell(row, i))}</td>" for i in range(len(row["values"])))
        out.append(
            f'<tr><td class="l">{_e(row["label"])}</td>{cells}<td>{_e(row["trend"])}</td></tr>'
        )
    out.append("</table>")
    out += [f'<p class="sub">{_e(n)}</p>' for n in progress.get("notes") or ()]
    return "\n".join(out)
