"""The ``prezence`` command line.

Heavy modules (the simulator, pybullet, qi) are imported inside the subcommand that needs them.
A :class:`PrezenceError` prints ``error: …`` and exits 2 with no traceback; ``--debug`` re-raises.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import re
import shlex
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from prezence import __version__
from prezence.argtypes import non_negative_float, non_negative_int, speed_fraction
from prezence.errors import PrezenceError, unknown_message
from prezence.sessiondir import drop_if_left_empty
from prezence.talk import DEFAULT_POLICY, DEFAULT_SPEED_FRACTION, Terminated

if TYPE_CHECKING:
    from prezence.config.model import Config
    from prezence.feedback.gestures import GestureLibrary
    from prezence.live_view import RichLiveView
    from prezence.talk import RunOptions

log = logging.getLogger(__name__)

DEMO_SCENARIO = "demo"
#: ``prezence run``: the talk ran but missed what its scenario expects of the coach.
EXIT_EXPECTATIONS = 3
#: A talk ran (and, for ``run``, met its expectations) but the robot did not give every cue
#: the coach chose, or its post-talk summary: cut short (a motion that never ended), dropped
#: (the robot was gone) or of unknown outcome (the link was lost while the cue ran: the robot
#: may have given it in full, but nothing says it did, so it counts). A scenario missed is 3
#: all the same.
EXIT_ROBOT = 4
#: Stopped by Ctrl-C (128 + SIGINT) or by SIGTERM (128 + SIGTERM), as a shell reports a process
#: the signal killed; the talk's folder is written up to where it stopped.
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143
#: What each of those exit statuses is said to have been stopped by.
STOPPED_BY = {EXIT_INTERRUPTED: "Ctrl-C", EXIT_TERMINATED: "SIGTERM"}


#: What ``-q`` does (the result a command prints on stdout stays: it is what it was run for).
QUIET_HELP = (
    "errors only on stderr: no warnings, progress bars or live view; the result (the "
    "timeline, a table) is still printed on stdout (skipped lines and robot faults are still "
    "counted in summary.json and the report)"
)


def _mmss(t: float | None) -> str:
    if t is None:
        return "  -  "
    sign = "-" if t < 0 else ""
    t = abs(t)
    if t >= 3600:  # a talk of hours: "1:00:00.5", not "60:00.5"
        return f"{sign}{int(t // 3600)}:{int(t % 3600 // 60):02d}:{t % 60:04.1f}"
    return f"{sign}{int(t // 60)}:{t % 60:04.1f}"


def talk_label(summary: dict[str, Any]) -> str:
    """What the talk was, for the timeline's header: its scenario, recording, the folder it
    replays, or its kind (``up`` of files played to their end is no live speaker).

    Example:
        >>> talk_label({"scenario": "demo"}), talk_label({"kind": "live"})
        ('demo', 'live')
        >>> talk_label({"kind": "live", "recording_s": 60.0})
        'live, from recordings played to their end'
    """
    name = next(
        (summary[k] for k in ("scenario", "recording", "replay_of", "kind") if summary.get(k)), "?"
    )
    if name == "live" and summary.get("recording_s") is not None:
        return "live, from recordings played to their end"
    return str(name)


def format_timeline(summary: dict[str, Any], root: Path | None = None) -> str:
    """A readable timeline of the cues and a short per-metric table."""
    lines = []
    head = (
        f"Talk: {talk_label(summary)}  "
        f"seed {summary.get('seed', '-')}  "
        f"backend {summary.get('backend', '?')}  policy {summary.get('policy', '?')}"
    )
    lines.append(head)
    if summary.get("gestures"):
        g = summary["gestures"]
        mine = ", ".join(g.get("defines") or ())
        # a whole library leaves none built in (an older folder does not say: "the others")
        rest = "" if g.get("built_in") == [] else "; the others built in"
        lines.append(f"gestures: {mine} from {g.get('file')}{rest}")
    lines.append(f"{'time':>7}  {'cue':<12} {'metric':<16} {'lat':>6} {'ok':>3}  reason")
    for c in summary["cues"]:
        lat = c.get("latency_s")
        ok = "yes" if c.get("relevant") in (True, None) else "NO"
        if c.get("cue_class") == "unmeasured":  # its metric was not measured then: unknown
            ok = "?"
        if c.get("dropped"):
            ok = "drp"
        lines.append(
            f"{_mmss(c['t']):>7}  {c['command']:<12} {c.get('metric') or '-':<16} "
            f"{(f'{lat:.1f}s' if lat is not None else '-'):>6} {ok:>3}  {c.get('reason', '')}"
        )
        given = c.get("measured_s")
        # when the failure was noticed (a heartbeat, a deadline), not when the motion stopped
        of = f" (noticed after {given:.1f} s)" if isinstance(given, int | float) else ""
        if c.get("cut_short"):  # "ok" says whether the cue was right; this, whether it was given
            lines.append(f"{'':>7}  ^ cut short{of}: {c['cut_short']}")
        elif c.get("outcome_unknown"):  # the robot may well have finished it
            lines.append(f"{'':>7}  ^ outcome unknown{of}: {c['outcome_unknown']}")
    if not summary["cues"]:
        lines.append("   (no cues)")
    lines.append("")
    lines.append(f"{'metric':<18} {'in range':>9} {'truth':>7} {'mean':>9} {'longest out':>12}")
    for name, m in summary["metrics"].items():
        tir = m.get("time_in_range")
        tt = m.get("truth_time_in_range")
        mean = m.get("mean")
        if not m.get("samples"):  # nothing measured: no figure to show
            tir = None
        nothing = "no data"
        if m.get("measured") is False:  # no module writes it (the persona does not play it)
            tt, nothing = None, "-"
        # * : counted, but by a fallback (less reliable) or for too little time to judge; a
        # metric not judged has no share to show (an 11 s clip's pace read "0%*")
        if tir is None:
            shown = "-"
        elif m.get("too_brief"):
            shown = "-*"
        else:
            shown = f"{100 * tir:.0f}%" + ("*" if m.get("less_reliable") else "")
        lines.append(
            f"{name:<18} {shown:>9} "
            f"{(f'{100 * tt:.0f}%' if tt is not None else '-'):>7} "
            f"{(f'{mean:.2f}' if mean is not None else nothing):>9} "
            + (
                f"{m.get('longest_out_of_range_s', 0):>11.1f}s"
                if m.get("samples")
                else f"{'-':>12}"
            )
        )
    from prezence.report.speech import metric_notes

    lines += [f"  {n}" for n in metric_notes(summary)]  # the dashes and stars, in words
    tm = summary["time"]
    if tm.get("allocated_s"):
        cut = ", or more: stopped at the time limit" if tm.get("stopped_at_limit") else ""
        lines.append(
            f"time used {_mmss(tm['used_s'])} of {_mmss(tm['allocated_s'])} "
            f"({tm['over_under_pct']:+.1f}%{cut})"
        )
    c = summary["counts"]
    cut = f", cut short {c['cues_cut_short']}" if c.get("cues_cut_short") else ""
    if c.get("cues_outcome_unknown"):
        cut += f", outcome unknown {c['cues_outcome_unknown']}"
    stale = f", stale {c['stale']}" if c.get("stale") else ""  # as evaluate counts them
    if c.get("cues_unmeasured"):  # given while its metric was not measured: not judged
        stale += f", not judged {c['cues_unmeasured']}"
    lines.append(
        f"cues {c['cues']} (dropped {c['cues_dropped']}{cut}, false alarms {c['false_alarms']}"
        f"{stale}), "
        f"malformed samples {c['malformed_samples']}, "
        + (f"out-of-order times {c['out_of_order']}, " if c.get("out_of_order") else "")
        + f"stale episodes {c['stale_episodes']}, "
        f"joint-limit violations {_violations(summary)}"
    )
    lines += [f"note: {n}" for n in _trouble_notes(summary, root)]
    if summary.get("analysis_wall_s") is not None:  # a rehearsal: the modules took most of it
        whole = float(summary["analysis_wall_s"]) + float(summary.get("wall_s") or 0.0)
        lines.append(
            f"rehearsed {summary['talk_s']:.0f} s of recording in {whole:.1f} s wall "
            f"({summary['talk_s'] / max(whole, 1e-6):.1f}x real time: the modules' analysis "
            f"{summary['analysis_wall_s']:.1f} s, the coaching {summary.get('wall_s', 0.0):.2f} s)"
        )
    elif summary.get("realtime_factor"):
        lines.append(
            f"simulated {summary['talk_s']:.0f} s in {summary['wall_s']:.2f} s wall "
            f"({summary.get('realtime_factor')}x real time)"
        )
    return "\n".join(lines)


def post_talk_line(post: dict[str, Any]) -> str:
    """What the robot said after the talk, or that it did not say it (robot lost…)."""
    if post.get("ok") is False and post.get("speech_ok") is True:  # said; its gesture failed
        why = post.get("gesture_error") or "cut short"
        return f'robot: "{post["phrase"]}" (its gesture was cut short: {why})'
    if post.get("ok") is False and post.get("speech_outcome") == "unknown":
        why = post.get("speech_error") or "robot lost"
        return f'robot lost while saying its summary, outcome unknown ({why}): "{post["phrase"]}"'
    if post.get("ok") is False:
        why = post.get("drop_reason") or post.get("speech_error") or "cut short"
        return f'robot did NOT say its summary ({why}): "{post["phrase"]}"'
    return f'robot: "{post["phrase"]}"'


def robot_shortfall(summary: dict[str, Any]) -> str | None:
    """What the robot did not give of what the coach chose (None: it gave everything).

    Counts the cues cut short and dropped and a post-talk summary not said, with the first
    reason (the summary's cue rows keep why each was cut short or dropped).

    Example:
        >>> robot_shortfall({"counts": {"cues_dropped": 0}}) is None
        True
        >>> robot_shortfall({"counts": {"cues_dropped": 2, "cues_cut_short": 1},
        ...                  "cues": [{"cut_short": "robot lost: reset"}],
        ...                  "post_talk": {"ok": False, "drop_reason": "robot lost: gone"}})
        '1 cue cut short, 2 dropped, the post-talk summary not said (robot lost: reset)'
    """
    counts = summary.get("counts") or {}
    cut = int(counts.get("cues_cut_short") or 0)
    unknown = int(counts.get("cues_outcome_unknown") or 0)
    dropped = int(counts.get("cues_dropped") or 0)
    post = summary.get("post_talk") or {}
    parts = [f"{cut} cue{'s' if cut != 1 else ''} cut short"] if cut else []
    if unknown:
        cue = "" if cut else (" cue" if unknown == 1 else " cues")
        parts.append(f"{unknown}{cue} of unknown outcome (robot lost during the cue)")
    if dropped:
        cue = "" if cut or unknown else (" cue" if dropped == 1 else " cues")
        parts.append(f"{dropped}{cue} dropped")
    if post.get("ok") is False:
        if post.get("speech_ok") is True:
            parts.append("the post-talk summary's gesture cut short")
        elif post.get("speech_outcome") == "unknown":
            parts.append("the post-talk summary of unknown outcome (robot lost)")
        else:
            parts.append("the post-talk summary not said")
    if not parts:
        return None
    rows = summary.get("cues") or ()
    reasons = [c.get("cut_short") for c in rows]
    reasons += [c.get("outcome_unknown") for c in rows]
    reasons += [c.get("drop_reason") for c in rows if c.get("dropped")]
    reasons += [post.get("drop_reason"), post.get("speech_error"), post.get("gesture_error")]
    why = next((str(r) for r in reasons if r), "")
    return ", ".join(parts) + (f" ({why})" if why else "")


def outage_note(summary: dict[str, Any]) -> str | None:
    """For a talk that missed its expectations while the robot was lost: the outage, not the
    coach, is the likely cause (a cue the robot could not give stays due and is chosen again,
    and may beat the one the scenario expects). None when no chosen cue was lost.

    Example:
        >>> outage_note({"counts": {"cues_dropped": 5}})[:47]
        'the robot was lost during the talk (5 cues drop'
    """
    counts = summary.get("counts") or {}
    dropped = int(counts.get("cues_dropped") or 0)
    unknown = int(counts.get("cues_outcome_unknown") or 0)
    if not dropped and not unknown:
        return None
    parts = [f"{dropped} cue{'s' if dropped != 1 else ''} dropped"] if dropped else []
    if unknown:
        parts.append(f"{unknown} of unknown outcome")
    return (
        f"the robot was lost during the talk ({', '.join(parts)}): the outage is the likely "
        "cause of what was missed, not the coach (a cue the robot could not give stays due, is "
        "chosen again and may beat the one expected)"
    )


def _violations(summary: dict[str, Any]) -> str:
    """The joint-limit violations, or that the backend did not measure them (only the sim does).

    Example:
        >>> _violations({"backend": "fake", "counts": {"joint_limit_violations": None}})
        'not measured (fake backend: --backend sim measures them)'
        >>> _violations({"backend": "sim", "counts": {"joint_limit_violations": 0}})
        '0'
    """
    n = summary["counts"].get("joint_limit_violations")
    if n is not None:
        return str(n)
    backend = summary.get("backend")
    return f"not measured ({f'{backend} backend: ' if backend else ''}--backend sim measures them)"


#: A module that exited 0 this long or more before the talk's end is said to have ended while
#: the talk went on (seconds): sooner, it ended with the others (a file's end).
ENDED_BEFORE_S = 2.0


def _ended_sentences(modules: Any, end_s: float) -> list[str]:
    """One sentence per module that exited 0 (``modules.NAME.ended_t``) while the talk went on
    to ``end_s`` (the talk's end; the recordings' when every input ended by itself, as files
    do: the others may take seconds more to finish their analysis).

    Example:
        >>> _ended_sentences({"fill": {"ended_t": 30.2, "metrics": ["speech_fillers"]}}, 60.0)
        ['module fill ended (exit 0) at 0:30 while the talk went on; speech_fillers were not measured from then']
    """  # noqa: E501 - a doctest output line
    from prezence.report.speech import mmss, was

    out = []
    for name, rec in (modules or {}).items() if isinstance(modules, dict) else ():
        t = rec.get("ended_t") if isinstance(rec, dict) else None
        if not isinstance(t, int | float) or end_s - float(t) < ENDED_BEFORE_S:
            continue
        metrics = rec.get("metrics")
        names = ", ".join(map(str, metrics)) if isinstance(metrics, list) else ""
        what = (
            f"{names} {was(names) if len(metrics) == 1 else 'were'}"
            if names
            else "its metrics were"
        )
        out.append(
            f"module {name} ended (exit 0) at {mmss(t)} while the talk went on; {what} not "
            "measured from then"
        )
    return out


def _trouble_notes(summary: dict[str, Any], root: Path | None = None) -> list[str]:
    """Modules that crashed or hung (and what they left unmeasured), metrics that went stale
    (with the speech module's reasons, read from the session folder at ``root``), unreadable
    lines and damaged cue and ground-truth lines."""
    from prezence.report.speech import (
        module_sentences,
        skipped_sentences,
        stale_sentences,
        truth_skipped_sentences,
    )
    from prezence.summary import module_notes

    metrics = summary.get("metrics") or {}
    if root is not None and metrics:
        from prezence.report.build import stale_reasons

        why = stale_reasons(root, summary)
        metrics = {k: {**m, "stale_spans": why[k]} if k in why else m for k, m in metrics.items()}
    notes = module_notes(summary.get("modules"), metrics)
    talk_s = float(summary.get("talk_s") or 0.0)
    # a talk whose every input ended by itself ended with the recordings (`up` of files)
    end_s = float(summary.get("recording_s") or talk_s)
    out = module_sentences(notes, end_s) + _ended_sentences(summary.get("modules"), end_s)
    out += stale_sentences(metrics, notes, end_s)
    problems = [str(p) for p in summary.get("stream_problems") or []]
    for name, m in metrics.items():
        n = int((m.get("stream") or {}).get("malformed") or 0)
        if n:
            first = next((p for p in problems if f"{name}.txt:" in p), None)
            out.append(
                f"{n} unreadable line{'s' if n != 1 else ''} of {name} skipped"
                + (f" (e.g. {first})" if first else "")
            )
    out += [f"a module's clock went back: {x}" for x in summary.get("out_of_order_times") or []]
    return (
        out
        + skipped_sentences(summary.get("skipped_records") or [])
        + truth_skipped_sentences(summary.get("truth_skipped") or [])
    )


def _progress_printer() -> Callable[[float, float], None] | None:
    """A progress bar with an ETA on a terminal (it ends its line when the talk is done)."""
    from prezence.bars import auto_bar

    return auto_bar("talk", seconds=True)


def _backend_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    kw: dict[str, Any] = {}
    if getattr(args, "robot", None) and args.backend != "naoqi":
        raise PrezenceError(
            f"--robot is only used with --backend naoqi (the backend is {args.backend}); add "
            "--backend naoqi, or leave --robot out"
        )
    if args.backend == "sim":
        kw["gui"] = bool(getattr(args, "gui", False))
    options = getattr(args, "robot_option", None) or []
    if options and args.backend != "naoqi":
        raise PrezenceError("--robot-option is only used with --backend naoqi")
    if args.backend == "naoqi":
        if not args.robot:
            raise PrezenceError("--backend naoqi needs --robot tcp://HOST:9559")
        kw["url"] = args.robot
        for text in options:
            kw.update(robot_options(text))
    return kw


#: The NaoqiBackend settings ``--robot-option`` reaches, and their kinds.
ROBOT_OPTIONS: dict[str, type] = {
    "leds": bool,
    "rest_on_close": bool,
    "connect_timeout_s": float,
    "call_timeout_s": float,
    "wake_timeout_s": float,
    "motion_margin_s": float,
    "heartbeat_s": float,
    "neutral_speed_fraction": float,
}
_TRUE, _FALSE = ("1", "true", "yes", "on"), ("0", "false", "no", "off")


def robot_options(text: str) -> dict[str, Any]:
    """``--robot-option leds=on,rest_on_close=true`` as NaoqiBackend keyword arguments.

    Example:
        >>> robot_options("leds=on, wake_timeout_s=20")
        {'leds': True, 'wake_timeout_s': 20.0}
    """
    out: dict[str, Any] = {}
    for item in (i.strip() for i in text.split(",")):
        if not item:
            continue
        key, sep, value = (s.strip() for s in item.partition("="))
        if key not in ROBOT_OPTIONS:
            raise PrezenceError(unknown_message("robot option", key, ROBOT_OPTIONS))
        if not sep or not value:
            raise PrezenceError(f"--robot-option {key}: want {key}=VALUE")
        if ROBOT_OPTIONS[key] is bool:
            if value.lower() not in _TRUE + _FALSE:
                raise PrezenceError(f"--robot-option {key}={value}: want on or off (true/false)")
            out[key] = value.lower() in _TRUE
        else:
            try:
                number = float(value)
            except ValueError:
                number = float("nan")
            low_ok = number >= 0 if key == "motion_margin_s" else number > 0
            if not (low_ok and (key != "neutral_speed_fraction" or number <= 1)):
                want = "in (0, 1]" if key == "neutral_speed_fraction" else "a number > 0"
                want = "a number >= 0" if key == "motion_margin_s" else want
                raise PrezenceError(f"--robot-option {key}={value}: want {want}")
            out[key] = number
    return out


def parse_seconds(text: str) -> float:
    """A length of time from the command line: ``36``, ``36s``, ``10m``, ``10min``, ``9:30``.

    A bare number is seconds.

    Example:
        >>> [parse_seconds(x) for x in ("36", "36s", "10m", "9:30", "1.5min")]
        [36.0, 36.0, 600.0, 570.0, 90.0]
    """
    t = text.strip().lower()
    try:
        if ":" in t:
            m, _, sec = t.partition(":")
            if not 0.0 <= float(sec) < 60.0:
                raise ValueError("seconds past the minute must be under 60")
            value = 60.0 * int(m) + float(sec)
        elif t.endswith("min"):
            value = 60.0 * float(t[:-3])
        elif t.endswith("m"):
            value = 60.0 * float(t[:-1])
        elif t.endswith("s"):
            value = float(t[:-1])
        else:
            value = float(t)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a length of time (seconds, or 10m, 9:30)"
        ) from None
    if not value > 0 or value != value or value == float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r}: the time must be > 0")
    return value


def _load_config(args: argparse.Namespace) -> Config | None:
    """The ``--config`` rules with ``--room``'s named values (the built-in rules when only
    ``--room`` is given); None when neither is given: the command then uses its own rules (a
    scenario's, a recording's, the built-in ones).
    """
    from prezence.config.load import load_config, load_room

    room = load_room(args.room) if args.room else None
    if args.config is None and room is None:
        return None
    return load_config(args.config, room=room)


def _config_or_default(args: argparse.Namespace) -> Config:
    """:func:`_load_config`, or the built-in configuration."""
    from prezence.config.load import load_config

    config = _load_config(args)
    return config if config is not None else load_config(None)


def _options(args: argparse.Namespace, config: Config | None) -> RunOptions:
    """The run options of a coaching command (pacing to a real robot is the loop's business).
    ``config``: the talk's rules, when known here (``replay`` takes the recording's later)."""
    from prezence.feedback.gestures import library_for_talk
    from prezence.talk import RunOptions

    gestures = getattr(args, "gestures", None)
    # refused now, before the robot, a module or a folder: a file that cannot be played, a
    # command the talk can give whose gesture is in no library, or a gesture (of the file or
    # built in) that fails `gestures check` at --speed
    library = library_for_talk(
        gestures or None,
        speed_fraction=args.speed,
        commands=config.talk_commands() if config is not None else None,
    )
    allow = bool(getattr(args, "allow_unchecked_collision", False))
    _refuse_unchecked_collision(getattr(args, "backend", None), library, allow=allow)
    return RunOptions(
        policy=args.policy,
        seed=args.seed if args.seed is not None else 0,
        speed_fraction=args.speed,
        realtime=bool(getattr(args, "realtime", False)),
        report=not args.no_report,
        plots=getattr(args, "plots", True),
        gestures=gestures,
        speaker=_speaker(args),
        allow_unchecked_collision=allow,
    )


def _refuse_unchecked_collision(
    backend: str | None, library: GestureLibrary | None, *, allow: bool
) -> None:
    """On a backend that moves a physical body (``naoqi``), refuse gestures whose
    self-collision was not checked (no PyBullet) now, before a module runs or a folder is
    written, as the talk itself would later (:func:`~prezence.talk.Talk`; a rehearsal analysed
    its whole recording first, and left a half-written folder)."""
    from prezence.backends.registry import BACKENDS

    record = BACKENDS.get(backend) if backend else None
    if record is None or not record.physical or allow:
        return
    from prezence.feedback.collision import require_collision_checked
    from prezence.feedback.limits import load_limits

    require_collision_checked(library, limits=load_limits(), backend=record.name)


def cmd_run(args: argparse.Namespace) -> int:
    from prezence.synthetic.runner import run_talk
    from prezence.synthetic.scenario import check_expectations

    config = _load_config(args)
    if config is not None:
        # the scenario's talk has its own length (scenarios/README.md): said, as replay says it
        # (session 21, a second walkthrough: a config's allocated_s was dropped without a word)
        from prezence.config.load import load_config
        from prezence.synthetic.scenario import load_scenario

        sc = load_scenario(args.scenario)
        default = load_config(None).time.allocated_s
        own = config.time.allocated_s
        # only a time the config sets (a rules file, or a config without [time], has the
        # built-in one, which is no choice of the user's to be told about)
        if own != default and sc.allocated_s is not None and own != sc.allocated_s:
            log.warning(
                "%s: its allocated time (%s) is not used: the scenario %s allocates %g s, and "
                "a scenario's talk keeps its own length",
                args.config,
                "none" if not own else f"{own:g} s",
                sc.name,
                sc.allocated_s,
            )
    out = Path(args.out) if args.out else Path("sessions") / f"{Path(args.scenario).stem}"
    result = run_talk(
        args.scenario,
        out=out,
        options=_options(args, config if config is not None else _config_or_default(args)),
        seed=args.seed,
        backend=args.backend,
        backend_kwargs=_backend_kwargs(args),
        config=config,
        progress=None if args.quiet else _progress_printer(),
    )
    if result.interrupted:  # a talk cut short: its expectations cannot be judged
        return _interrupted_run(result.summary, result.session.root, args)
    problems = check_expectations(result.scenario, result.cues)
    shortfall = robot_shortfall(result.summary)
    outage = outage_note(result.summary) if problems else None
    if args.json:
        print(json.dumps(result.summary, indent=2, sort_keys=True))
        # stdout is the JSON: the verdict goes to stderr, where a CI log shows why it failed
        for p in problems:
            print(f"scenario expectation NOT met: {p}", file=sys.stderr)
        if shortfall:
            print(f"the robot did not give every cue: {shortfall}", file=sys.stderr)
        if outage:
            print(outage, file=sys.stderr)
    else:
        print(format_timeline(result.summary))
        if problems:
            print("scenario expectations NOT met:")
            for p in problems:
                print(f"  - {p}")
            if shortfall:
                print(f"and the robot did not give them all: {shortfall}")
            if outage:
                print(outage)
        elif shortfall:
            # the coach chose as expected; the robot (lost, stuck) did not give it all
            print(
                "scenario expectations met by the cues chosen, but the robot did not give "
                f"them all: {shortfall}"
            )
        else:
            print("scenario expectations met")
        post = result.summary.get("post_talk")
        if post:
            print(post_talk_line(post))
        print(f"session folder: {result.session.root}  (summary.json, cues.jsonl, decisions.jsonl)")
        if not args.no_report:
            page = result.session.report / "report.html"
            if args.plots:
                print(f"report: {page}")
            else:
                again = f"prezence report {shlex.quote(str(result.session.root))}"
                print(f"report: {page}  (tables; plots: --plots or {again})")
    # A scenario states what a good coach must do; missing it fails the run, as CI wants, and
    # so does a robot that did not give what the coach chose.
    if problems:
        return EXIT_EXPECTATIONS
    return EXIT_ROBOT if shortfall else 0


def _interrupted_run(summary: dict[str, Any], root: Path, args: argparse.Namespace) -> int:
    """``run``/``demo`` stopped by Ctrl-C or SIGTERM: what was written, and exit 130 or 143
    (never 0 or 3: the expectations of a talk cut short are not judged)."""
    if args.json:
        print(json.dumps(summary, indent=2, sort_keys=True))
    else:
        print(format_timeline(summary))
        post = summary.get("post_talk")
        if post:
            print(post_talk_line(post))
        print(f"session folder: {root}  (summary.json, cues.jsonl, decisions.jsonl)")
    status = _interrupt_status()
    how = STOPPED_BY[status]
    length = summary.get("time", {}).get("allocated_s")
    print(
        f"talk stopped by {how} at {_mmss(summary.get('talk_s')).strip()}"
        + (f" of {_mmss(length).strip()}" if length else "")
        + f": scenario expectations not checked; {root} holds the talk up to there",
        file=sys.stderr,
    )
    return status


def cmd_report(args: argparse.Namespace) -> int:
    from prezence.report.build import report_main

    return report_main(args.session, config=args.config)


def cmd_evaluate(args: argparse.Namespace) -> int:
    from prezence.evaluate import evaluate_main

    return int(evaluate_main(args.rest))  # its own parser: prezence evaluate -h


def cmd_replay(args: argparse.Namespace) -> int:
    from prezence.replay import replay

    if args.room and not args.config:
        raise PrezenceError(
            "--room gives named values to --config rules; give --config too (the recording's "
            "config.toml holds numbers only)"
        )
    from prezence.sessiondir import claim_session_dir, overlaps

    src = Path(args.session)
    if args.out and overlaps(Path(args.out), src):
        raise PrezenceError(
            f"--out {args.out} overlaps the recording {src}: replay never writes into or over it"
        )
    config = _load_config(args)
    kw = _backend_kwargs(args)
    options = _options(args, config)  # None: the recording's rules, checked by replay()
    out = claim_session_dir(
        args.out,
        "replay",
        force=args.force,
        protect=(src,),
        default=src.parent / f"{src.name}-replay-{args.policy}",
    )
    with drop_if_left_empty(out):
        result = replay(
            src,
            out=out,
            options=options,
            config=config,
            backend=args.backend,
            backend_kwargs=kw,
            allocated_s=args.allocated,
        )
    status = _finish_session(result.session.root, result.summary, args, report=result.report)
    return _stopped_status(result.summary, result.session.root, status)


def cmd_rehearse(args: argparse.Namespace) -> int:
    from prezence.rehearse import module_args, rehearse
    from prezence.sessiondir import claim_session_dir

    rec = Path(args.recording)
    config = _config_or_default(args)
    kw = _backend_kwargs(args)
    options = _options(args, config)
    margs = {
        "speech": _speech_words(args),
        "vision": module_args("--vision-args", "vision", args.vision_args),
    }
    out = claim_session_dir(
        args.out,
        "rehearsal",
        force=args.force,
        default=_speaker_root(args) / f"rehearsal-{rec.stem}",
    )
    from prezence.bars import progress_bar

    with drop_if_left_empty(out), progress_bar("analysing", seconds=True) as show:
        result = rehearse(
            rec,
            out=out,
            options=options,
            config=config,
            backend=args.backend,
            backend_kwargs=kw,
            module_args=margs,
            allocated_s=args.allocated,
            progress=show,
        )
    status = _finish_session(result.session.root, result.summary, args, report=result.report)
    return _stopped_status(result.summary, result.session.root, status)


def cmd_up(args: argparse.Namespace) -> int:
    from prezence.backends.registry import make_backend
    from prezence.launcher import ModuleSpec, modules_on, up
    from prezence.rehearse import module_args

    config = _config_or_default(args)
    if args.allocated is not None:
        config = config.with_allocated(args.allocated)
    specs: list[ModuleSpec] = []
    if args.audio:  # the speech module, and any module whose record reads audio
        specs += modules_on(
            "--audio",
            args.audio,
            {"speech": _speech_words(args)},
        )
    elif args.speech_args:
        raise PrezenceError("--speech-args without --audio: the speech module is not started")
    elif args.language is not None:
        raise PrezenceError("--language without --audio: the speech module is not started")
    if args.video:
        specs += modules_on(
            "--video",
            args.video,
            {"vision": module_args("--vision-args", "vision", args.vision_args)},
        )
    elif args.vision_args:
        raise PrezenceError("--vision-args without --video: the vision module is not started")
    try:
        specs += [ModuleSpec.parse(m) for m in args.module or []]
    except ValueError as e:
        raise PrezenceError(str(e)) from None
    if not specs:
        raise PrezenceError("nothing to listen to: give --audio, --video or --module")
    from prezence.inputs import check_up_inputs
    from prezence.sessiondir import claim_session_dir

    kw = _backend_kwargs(args)
    # gestures refused before the robot is reached (and before a module or a folder)
    options = _options(args, config)
    check_up_inputs(audio=args.audio, video=args.video, backend=args.backend, robot=args.robot)
    backend = make_backend(args.backend, **kw)
    out = claim_session_dir(args.out, "live", force=args.force, root=_speaker_root(args))
    view = None if args.quiet else _live_view(config, specs)
    with drop_if_left_empty(out):
        try:
            result = up(
                config,
                session_dir=out,
                modules=specs,
                backend=backend,
                options=options,
                grace_s=args.grace,
                duration_s=args.duration,
                view=view,
            )
        except ValueError as e:  # two modules of the same name
            raise PrezenceError(str(e)) from None
        finally:
            if view is not None:
                view.close()
    status = _finish_session(result.session.root, result.summary, args, report=result.report)
    if result.error is not None:
        print(f"error: the talk stopped: {result.error}", file=sys.stderr)
        return 2
    return status


def _live_view(config: Config, specs: Sequence[Any]) -> RichLiveView:
    """The live view: a redrawn table on a terminal, plain lines otherwise."""
    from prezence.live_view import RichLiveView

    # metrics no module writes are "not measured" (unknown when a module names none)
    known = all(s.metrics for s in specs)
    measured = {m for s in specs for m in s.metrics} if known else None
    return RichLiveView(config, [s.name for s in specs], measured=measured)


def _stopped_status(summary: dict[str, Any], root: Path, status: int) -> int:
    """``replay``/``rehearse`` stopped by Ctrl-C or SIGTERM before their recording's end: 130
    or 143 (a CI gate must not read a talk cut short as done), said on stderr; else ``status``.
    (``up`` ends at Ctrl-C as a rule, and takes SIGTERM alike: not here.)"""
    if not summary.get("interrupted"):
        return status
    stopped = _interrupt_status()
    how = STOPPED_BY[stopped]
    print(
        f"stopped by {how} at {_mmss(summary.get('talk_s')).strip()}: {root} holds the talk "
        "up to there",
        file=sys.stderr,
    )
    return stopped


def _finish_session(
    root: Path, summary: dict[str, Any], args: argparse.Namespace, *, report: Path | None
) -> int:
    """Print what a session left: the timeline (or summary.json), notes, its folder, its report.

    Returns:
        0, or :data:`EXIT_ROBOT` when the robot did not give every cue or its summary.
    """
    shortfall = robot_shortfall(summary)
    if getattr(args, "json", False):
        print(json.dumps(summary, indent=2, sort_keys=True))
        return EXIT_ROBOT if shortfall else 0
    print(format_timeline(summary, root))
    if summary.get("truth_dropped"):
        print(
            f"note: the recording's ground truth is not used ({summary['truth_dropped']}); "
            "cues are judged by these rules on the recorded values"
        )
    post = summary.get("post_talk")
    if post:
        print(post_talk_line(post))
    if shortfall:
        print(f"the robot did not give every cue: {shortfall}")
    print(f"session folder: {root}")
    if report is not None:
        print(f"report: {report}")
    return EXIT_ROBOT if shortfall else 0


def cmd_check_config(args: argparse.Namespace) -> int:
    from prezence.backends.registry import BACKENDS
    from prezence.config.load import check_config_files, load_room
    from prezence.errors import ConfigError, UnknownName

    if args.backend not in BACKENDS:
        raise UnknownName("backend", args.backend, BACKENDS)
    files = [Path(p) for p in args.files]
    room = None
    library = None
    problems: list[str] = []
    if args.room:
        try:
            room = load_room(args.room)
        except ConfigError as e:
            problems.append(str(e))
    if args.gestures:
        from prezence.feedback.gestures import library_for_talk

        # the checks a talk makes at --speed, by the function a talk calls (a library every
        # talk refuses, beyond a limit, self-colliding or too long, was said ok); the commands
        # the rules give are checked against it below, per file
        try:
            library = library_for_talk(args.gestures, speed_fraction=args.speed)
        except PrezenceError as e:
            problems.append(str(e))
    notes: list[str] = []
    if not problems:
        _check_collision_checked(args, library, problems, notes)
    good: list[Path] = []  # each file is checked, and said ok, on its own: a lint step's view
    if not problems:
        for f in files:
            if _is_room_file(f):
                found = [
                    f"{f}: a room file has no rules to check; give it as --room {f} to check "
                    "the rules that use its named values"
                ]
            else:
                found = check_config_files([f], room=room, notes=notes, library=library)
            problems += found
            if not found:
                good.append(f)
    for p in problems:
        print(p, file=sys.stderr)
    for n in notes:
        print(f"warning: {n}", file=sys.stderr)
    for f in good:
        print(f"{f}: ok" + (f" (room {args.room})" if args.room else ""))
    return 1 if problems else 0


def _check_collision_checked(
    args: argparse.Namespace,
    library: GestureLibrary | None,
    problems: list[str],
    notes: list[str],
) -> None:
    """``check-config``: gestures whose self-collision was not checked here (no PyBullet) fail
    for a ``--backend`` that moves a physical body, as such a talk refuses them; for another
    backend, a note says that a talk on a real robot would."""
    from prezence.backends.registry import BACKENDS
    from prezence.feedback.collision import require_collision_checked, unchecked_collision
    from prezence.feedback.limits import load_limits

    record = BACKENDS[args.backend]
    limits = load_limits()
    try:
        if record.physical:
            require_collision_checked(library, limits=limits, backend=record.name)
            return
        reasons = unchecked_collision(library, limits=limits)
    except PrezenceError as e:  # refused as that talk refuses it
        problems.append(str(e))
        return
    robots = " or ".join(f"--backend {n}" for n, r in BACKENDS.items() if r.physical)
    for r in reasons:
        notes.append(
            f"{r}: a talk on a real robot ({robots}) refuses it (check-config {robots} fails it)"
        )


def _is_room_file(path: Path) -> bool:
    """A TOML file with a ``[room]`` table and no rules."""
    import tomllib

    if path.suffix.lower() != ".toml":
        return False
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError, RecursionError):
        return False
    return "room" in doc and "rules" not in doc and "rules_file" not in doc


def cmd_gestures_check(args: argparse.Namespace) -> int:
    from prezence.errors import ConfigError
    from prezence.feedback.gesture_check import check_gestures

    try:
        text, status = check_gestures(
            args.speed,
            as_json=args.json,
            collisions=False if args.no_collisions else None,
            library=args.file,
        )
    except ConfigError as e:  # the file is not a library: it fails the check, as check-config
        print(e, file=sys.stderr)
        return 1
    print(text)
    return status


def cmd_gestures_render(args: argparse.Namespace) -> int:
    from prezence.backends.registry import load_tool

    library = None
    if args.library:
        from prezence.feedback.gestures import load_library_file

        library = load_library_file(args.library)
    render_gesture = load_tool("render")

    out = Path(args.out)
    video = Path(args.video) if args.video else out.with_suffix(".mp4")
    params = {"minutes": args.minutes} if args.minutes is not None else None
    render_gesture(args.name, out, video, params=params, library=library)
    print(f"wrote {out} and {video}")
    # drawn as planned, but a gesture a talk refuses is said to be one (a position-limit
    # error stops the render itself)
    from prezence.feedback.gesture_check import gesture_failure
    from prezence.feedback.gestures import load_library

    lib = library if library is not None else load_library()
    gesture = lib[args.name]
    failure = gesture_failure(
        args.name,
        gesture.resolve_params(params) or None,
        speed_fraction=DEFAULT_SPEED_FRACTION,
        library=lib,
    )
    if failure:
        print(
            f"warning: {gesture.at()}gesture '{args.name}' fails `prezence gestures check"
            f"{' ' + str(args.library) if args.library else ''}`: {failure}; a talk refuses it",
            file=sys.stderr,
        )
    return 0


def cmd_sim_serve(args: argparse.Namespace) -> int:
    from prezence.backends.registry import load_tool

    serve_main = load_tool("serve")

    argv = ["--host", args.host, "--port", str(args.port)]
    if args.gui:
        argv.append("--gui")
    argv += ["--model", args.model]
    if args.speech_log:
        argv += ["--speech-log", args.speech_log]
    return _exit_now(int(serve_main(argv) or 0))


def _exit_now(code: int) -> int:
    """End the process at once, output flushed: once a NAOqi client has connected, libqi's
    threads make the interpreter's own exit abort (``terminate called without an active
    exception``, SIGABRT) after the server was closed cleanly."""
    import os

    logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):
            stream.flush()
    os._exit(code)


def _add_robot_args(p: argparse.ArgumentParser, *, out_help: str) -> None:
    """The options of every command that coaches: robot, rules, policy, output."""
    p.add_argument("--backend", default="fake", help="fake | sim | naoqi (default: fake)")
    p.add_argument("--robot", help="NAOqi URL for --backend naoqi, e.g. tcp://127.0.0.1:9559")
    p.add_argument(
        "--robot-option",
        action="append",
        metavar="KEY=VALUE[,…]",
        help="--backend naoqi settings: leds=on (eyes orange during a cue), rest_on_close=on "
        "(crouch and motors off at the end), connect_timeout_s, call_timeout_s, wake_timeout_s, "
        "motion_margin_s, heartbeat_s, neutral_speed_fraction",
    )
    p.add_argument("--gui", action="store_true", help="sim backend: open a PyBullet window")
    p.add_argument("--out", help=f"session folder (default: {out_help})")
    p.add_argument("--config", help="rules: a TOML config or a seed-format rules file")
    p.add_argument(
        "--room", metavar="FILE", help="room profile TOML: the named values the rules use"
    )
    p.add_argument(
        "--policy",
        default=DEFAULT_POLICY,
        help=f"conflict policy: a name, a spec (weighted:escalate_after=0) or your own as "
        f"MODULE:CLASS (default: {DEFAULT_POLICY})",
    )
    p.add_argument(
        "--speed",
        type=speed_fraction,
        default=DEFAULT_SPEED_FRACTION,
        help=f"gesture speed fraction (0..1], default {DEFAULT_SPEED_FRACTION}",
    )
    p.add_argument(
        "--gestures",
        metavar="FILE",
        help="a gesture library of your own (TOML): its gestures replace the built-in ones of "
        "the same name (check it first: prezence gestures check FILE)",
    )
    p.add_argument(
        "--allow-unchecked-collision",
        action="store_true",
        help="--backend naoqi: play gestures whose self-collision was not checked (PyBullet not "
        "installed) instead of refusing the talk; recorded in session.json",
    )
    p.add_argument("--json", action="store_true", help="print summary.json instead")
    p.add_argument("--no-report", action="store_true", help="skip the post-talk report")


def _speaker(args: argparse.Namespace) -> str | None:
    """``--speaker NAME`` checked (a plain name), or None when not given."""
    name = getattr(args, "speaker", None)
    if not name:
        return None
    if "/" in name or name.startswith(".") or not name.strip():
        raise PrezenceError(f"--speaker {name!r}: want a plain name such as 'ana'")
    return str(name).strip()


def _speaker_root(args: argparse.Namespace) -> Path:
    """``sessions/NAME`` with ``--speaker NAME`` (one folder per speaker: progress across
    rehearsals reads it; session.json records the name too), else ``sessions``."""
    from prezence.sessiondir import SESSIONS_ROOT

    name = _speaker(args)
    return SESSIONS_ROOT if name is None else SESSIONS_ROOT / name


def cmd_progress(args: argparse.Namespace) -> int:
    from prezence.progress import format_progress, progress, progress_all

    folder = Path(args.folder) if args.folder else _speaker_root(args)
    if (folder / "session.json").is_file():  # one session: its speaker's table
        print(format_progress(progress(folder)))
    else:  # a folder: one table per speaker (a persona, a --speaker name, the folder)
        print("\n\n".join(format_progress(p) for p in progress_all(folder)))
    return 0


def _add_speaker(p: argparse.ArgumentParser, help_text: str | None = None) -> None:
    p.add_argument(
        "--speaker",
        metavar="NAME",
        help=help_text
        or "whose rehearsal this is: sessions go to sessions/NAME/ and the report shows "
        "the progress across NAME's rehearsals",
    )


def _add_force(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--force",
        action="store_true",
        help="when --out exists and is not empty, move it aside to OUT.old-<time> (nothing is "
        "ever deleted) instead of refusing",
    )


def _add_run_args(p: argparse.ArgumentParser) -> None:
    _add_robot_args(p, out_help="sessions/<scenario>")
    p.add_argument(
        "--seed", type=non_negative_int, default=None, help="presenter seed (default: scenario's)"
    )
    p.add_argument("--realtime", action="store_true", help="pace to the wall clock")
    p.add_argument(
        "--plots",
        action="store_true",
        help="draw the report's plots (about 1 s; `prezence report DIR` draws them later too)",
    )


def _add_recorded_args(p: argparse.ArgumentParser, *, allocated_default: str) -> None:
    """``replay`` and ``rehearse``: the coach runs over recorded streams."""
    p.add_argument(
        "--seed", type=non_negative_int, default=0, help="seed of policies that use chance"
    )
    p.add_argument(
        "--realtime",
        action="store_true",
        help="coach at the recording's pace on the wall clock (always on with --backend naoqi)",
    )
    _add_allocated(p, default=allocated_default)


def _add_allocated(p: argparse.ArgumentParser, *, default: str = "the config's") -> None:
    p.add_argument(
        "--allocated",
        type=parse_seconds,
        metavar="SECONDS",
        help=f"time allocated to the talk: seconds, or 10m, 9:30 (default: {default})",
    )


def _speech_words(args: argparse.Namespace) -> list[str]:
    """The speech module's extra words: ``--language`` (when given) and ``--speech-args``."""
    from prezence.rehearse import module_args

    words = module_args("--speech-args", "speech", args.speech_args)
    if args.language is not None:
        if not args.language.strip():
            raise PrezenceError("--language is empty: give a tag such as en or de")
        given = _speech_language(words)
        if given is not None:
            # the module would take both and the later would win without a word
            raise PrezenceError(
                f"--language {args.language} and --speech-args {args.speech_args!r} (language "
                f"{given}) both give the talk's language: give it once"
            )
        words = ["--language", args.language, *words]
    return words


def _speech_language(words: Sequence[str]) -> str | None:
    """The language the speech module's words give (``--language de``, ``--language=de``, an
    abbreviation argparse accepts), read with the module's own parser; None: none."""
    import importlib

    try:
        parser: argparse.ArgumentParser = importlib.import_module(
            "prezence.modules.speech"
        ).build_parser()
    except ImportError:  # its extra is not installed: only the words themselves
        for i, w in enumerate(words):
            if w.startswith("--language="):
                return w.partition("=")[2]
            if w == "--language":
                return words[i + 1] if i + 1 < len(words) else ""
        return None
    parser.set_defaults(language=None)  # its default (en) is no language given
    ns, _ = parser.parse_known_args(["--audio", "x", "--out", "x", *words])
    language = getattr(ns, "language", None)
    return None if language is None else str(language)


def _add_module_args(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--language",
        metavar="TAG",
        help="the talk's language (default en): pace and clarity are measured for English "
        "talks only; for another (de, es, …) they are not written, and the report says why",
    )
    for module in ("speech", "vision"):
        p.add_argument(
            f"--{module}-args",
            metavar="ARGS",
            help=f"options added to the {module} module's command line, quoted (python -m "
            f"prezence.modules.{module} -h lists them)",
        )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="prezence", description="A NAO coaches you while you rehearse a talk."
    )
    parser.add_argument("--version", action="version", version=f"prezence {__version__}")
    parser.add_argument(
        "-v", "--verbose", action="count", default=0, help="more logging (repeatable)"
    )
    parser.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        help=QUIET_HELP,
    )
    parser.add_argument(
        "--list",
        choices=LISTS,
        metavar="WHAT",
        help=f"list what can be named and exit: {', '.join(LISTS)}",
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    # -v/-q also after the subcommand (prezence run demo -q): own names, merged in main()
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "-v",
        "--verbose",
        dest="sub_verbose",
        action="count",
        default=argparse.SUPPRESS,
        help="more logging (repeatable)",
    )
    common.add_argument(
        "-q",
        "--quiet",
        dest="sub_quiet",
        action="store_true",
        default=argparse.SUPPRESS,
        help=QUIET_HELP,
    )
    sub = parser.add_subparsers(dest="command")

    def add(parent: Any, name: str, **kw: Any) -> argparse.ArgumentParser:
        q: argparse.ArgumentParser = parent.add_parser(name, parents=[common], **kw)
        return q

    p = add(sub, "run", help="run a synthetic talk headless")
    p.add_argument("scenario", help="scenario name (see scenarios/) or a path to a TOML")
    _add_run_args(p)
    p.set_defaults(func=cmd_run)

    p = add(sub, "demo", help=f"run the '{DEMO_SCENARIO}' talk headless")
    _add_run_args(p)
    p.set_defaults(func=cmd_run, scenario=DEMO_SCENARIO)

    p = add(sub, "replay", help="re-run the processor over a recorded session's streams")
    p.add_argument("session", help="a session folder (or any folder with stream files)")
    _add_robot_args(p, out_help="<session>-replay-<policy>, -2, -3 ... when taken")
    _add_force(p)
    _add_recorded_args(p, allocated_default="the recording's")
    p.set_defaults(func=cmd_replay)

    p = add(sub, "up", help="live rehearsal: input modules + processor + robot")
    p.add_argument("--audio", help="mic, or an audio/video file played as if live")
    p.add_argument("--video", help="cam, cam:N, or a video file played as if live")
    p.add_argument(
        "--module",
        action="append",
        metavar="NAME[:METRIC,...]=COMMAND",
        help="extra module ({session} and {t0} are filled in; naming its metrics makes hang "
        "detection exact); repeatable",
    )
    _add_module_args(p)
    _add_allocated(p)
    p.add_argument(
        "--grace",
        type=non_negative_float,
        default=30.0,
        help="seconds after the allocated time (default 30)",
    )
    p.add_argument("--duration", type=parse_seconds, help="stop after this long (seconds)")
    p.add_argument(
        "--seed", type=non_negative_int, default=0, help="seed of policies that use chance"
    )
    _add_robot_args(p, out_help="a new sessions/[NAME/]live-YYYYMMDD-HHMMSS")
    _add_force(p)
    _add_speaker(p)
    p.set_defaults(func=cmd_up)

    p = add(sub, "rehearse", help="coach a recorded rehearsal (audio or video file)")
    p.add_argument("recording", help="an audio or video file of the talk (WAV, FLAC, MP3, MP4)")
    _add_module_args(p)
    _add_robot_args(p, out_help="sessions/[NAME/]rehearsal-<recording>, -2, -3 ... when taken")
    _add_force(p)
    _add_speaker(p)
    _add_recorded_args(p, allocated_default="the config's")
    p.set_defaults(func=cmd_rehearse)

    p = add(sub, "report", help="(re)build the report of a session folder")
    p.add_argument("session", help="the session folder (streams/, cues.jsonl, config.toml)")
    p.add_argument("--config", help="judge by this config instead of the folder's")
    p.set_defaults(func=cmd_report)

    p = add(sub, "progress", help="progress across rehearsals: each metric's trend")
    p.add_argument(
        "folder",
        nargs="?",
        help="a folder of one speaker's sessions, or one session (its folder's sessions)",
    )
    _add_speaker(p, help_text="read sessions/NAME/ (when no folder is given)")
    p.set_defaults(func=cmd_progress)

    p = sub.add_parser(
        "evaluate",
        help="closed-loop evaluation: scenarios x seeds x policies (see prezence evaluate -h)",
        add_help=False,
    )
    p.set_defaults(func=cmd_evaluate, rest=[])

    p = add(sub, "check-config", help="validate config or rules files")
    p.add_argument("files", nargs="+", help="TOML configs or seed-format rules files")
    p.add_argument(
        "--room", metavar="FILE", help="room profile TOML whose named values the rules use"
    )
    p.add_argument(
        "--gestures",
        metavar="FILE",
        help="the gesture library of your own the talks will play: checked as a talk checks "
        "it (limits, self-collision, duration at --speed), and every command the rules can "
        "give must have its gesture there or built in",
    )
    p.add_argument(
        "--speed",
        type=speed_fraction,
        default=DEFAULT_SPEED_FRACTION,
        help=f"the talks' gesture speed fraction (0..1], default {DEFAULT_SPEED_FRACTION}",
    )
    p.add_argument(
        "--backend",
        default="fake",
        help="the talks' backend, fake | sim | naoqi (default: fake); naoqi: gestures whose "
        "self-collision was not checked here (no PyBullet) fail, as such a talk refuses them",
    )
    p.set_defaults(func=cmd_check_config)

    g = add(sub, "gestures", help="check or render the gesture library")
    gs = g.add_subparsers(dest="gcommand", required=True)
    p = add(gs, "check", help="timing and limit table for every gesture (or those of FILE)")
    p.add_argument(
        "file",
        nargs="?",
        metavar="FILE",
        help="a gesture library of your own (TOML): check its gestures; without it, the "
        "built-in library's (docs/gestures.md)",
    )
    p.add_argument("--json", action="store_true", help="print the table as JSON")
    p.add_argument("--speed", type=float, default=0.6, help="speed fraction (default 0.6)")
    p.add_argument(
        "--no-collisions",
        action="store_true",
        help="skip the self-collision check (done when PyBullet is installed; 2-4 s)",
    )
    p.set_defaults(func=cmd_gestures_check)
    p = add(gs, "render", help="contact sheet PNG and video of one gesture")
    p.add_argument("name", help="the gesture (prezence --list gestures)")
    p.add_argument("--out", required=True, help="PNG contact sheet")
    p.add_argument("--video", help="MP4, AVI or GIF (default: next to --out, .mp4)")
    p.add_argument("--minutes", type=int, help="time_left: minutes to show")
    p.add_argument(
        "--library",
        metavar="FILE",
        help="a gesture library of your own: its gestures in place of the built-in ones",
    )
    p.set_defaults(func=cmd_gestures_render)

    s = add(sub, "sim", help="the simulated NAO")
    ss = s.add_subparsers(dest="scommand", required=True)
    p = add(ss, "serve", help="serve a virtual NAO over the NAOqi protocol")
    p.add_argument(
        "--host", default="127.0.0.1", help="address to listen on (default: loopback only)"
    )
    p.add_argument("--port", type=int, default=9559, help="TCP port (default 9559, NAOqi's)")
    p.add_argument("--gui", action="store_true", help="open a PyBullet window")
    p.add_argument(
        "--model",
        choices=("pybullet", "kinematic"),
        default="pybullet",
        help="the body: PyBullet (default) or a kinematic model without physics",
    )
    p.add_argument("--speech-log", help="JSON lines: what the robot said and did, with times")
    p.set_defaults(func=cmd_sim_serve)
    return parser


#: What ``prezence --list`` lists.
LISTS = ("scenarios", "policies", "gestures", "backends")


def list_names(what: str) -> list[str]:
    """The names ``--list WHAT`` prints: scenarios, policies, gestures or backends."""
    if what == "scenarios":
        from prezence.synthetic.scenario import list_scenarios

        return list(list_scenarios())
    if what == "policies":
        from prezence.processor import policy_names

        return sorted(policy_names())
    if what == "gestures":
        from prezence.feedback.gestures import load_library

        return list(load_library().names)
    from prezence.backends.registry import BACKENDS

    return list(BACKENDS)


#: Options whose value is a number or a length of time (a value with a dash is one for them).
_NUMBER_OPTIONS = frozenset(
    ("--allocated", "--grace", "--duration", "--seed", "--speed", "--minutes", "--port")
)


def _glue_negative_values(argv: Sequence[str]) -> list[str]:
    """``--allocated -5m`` as ``--allocated=-5m``: argparse takes a value that starts with a
    dash and is not a plain number for an option, and says only "expected one argument"; glued,
    the option's own check names what is wrong ("must be > 0"). Only after the options that take
    a number or a time (:data:`_NUMBER_OPTIONS`), and nothing after ``--``.
    """
    out: list[str] = []
    for i, a in enumerate(argv):
        prev = argv[i - 1] if i else ""
        if "--" in argv[:i]:
            out.append(a)
        elif prev in _NUMBER_OPTIONS and re.match(r"-[\d.:]", a):
            out[-1] = f"{prev}={a}"
        else:
            out.append(a)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    argv = _glue_negative_values(sys.argv[1:] if argv is None else list(argv))
    args, extra = parser.parse_known_args(argv)
    if args.list:
        try:
            print("\n".join(list_names(args.list)))
        except BrokenPipeError:
            return _broken_pipe()
        return 0
    if args.command is None:
        parser.error("a command is required (prezence -h lists them)")
    if args.command == "evaluate":  # its own parser takes -q/-v too (prezence evaluate -h)
        args.verbose += sum(a.count("v") for a in extra if a == "--verbose" or _is_vs(a))
        args.quiet = args.quiet or "-q" in extra or "--quiet" in extra
        args.rest = [*extra, *(["--quiet"] if args.quiet and "--quiet" not in extra else [])]
    elif extra:
        parser.error(f"unrecognized arguments: {' '.join(extra)}")
    args.verbose += getattr(args, "sub_verbose", 0)
    args.quiet = args.quiet or getattr(args, "sub_quiet", False)
    level = logging.WARNING - 10 * args.verbose + (20 if args.quiet else 0)
    logging.basicConfig(
        level=max(logging.DEBUG, level), format="%(levelname)s %(name)s: %(message)s"
    )
    if args.quiet and (
        getattr(args, "backend", None) == "sim"
        or args.command == "gestures"
        or isinstance(getattr(args, "gestures", None), str)  # own gestures' collision check
    ):
        _import_without_banner("pybullet")
    try:
        with _sigterm_as_interrupt():
            return int(args.func(args))
    except PrezenceError as e:
        if args.debug:
            raise
        print(f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as e:
        status = EXIT_TERMINATED if isinstance(e, Terminated) else EXIT_INTERRUPTED
        print(f"stopped by {STOPPED_BY[status]}", file=sys.stderr)
        return status
    except BrokenPipeError:
        return _broken_pipe()


def _is_vs(arg: str) -> bool:
    """``-v``, ``-vv``, …"""
    return len(arg) > 1 and arg[0] == "-" and set(arg[1:]) == {"v"}


def _import_without_banner(module: str) -> None:
    """Import ``module`` with file descriptor 2 sent to /dev/null: pybullet prints its build
    time there from C at import ("pybullet build time: …"), which ``-q`` (errors only on
    stderr) must not show. Not installed: nothing (the command says so itself)."""
    import importlib
    import os

    if module in sys.modules:
        return
    sys.stderr.flush()
    try:
        saved = os.dup(2)
    except OSError:
        return
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(devnull, 2)
        finally:
            os.close(devnull)
        with contextlib.suppress(ImportError):
            importlib.import_module(module)
    finally:
        os.dup2(saved, 2)
        os.close(saved)


#: The signals that stopped the running command (SIGTERM is recorded here; Ctrl-C is not).
_SIGNALLED: list[int] = []


def _interrupt_status() -> int:
    """The exit status of a command a signal stopped: 143 after SIGTERM, else 130 (Ctrl-C)."""
    return EXIT_TERMINATED if signal.SIGTERM in _SIGNALLED else EXIT_INTERRUPTED


@contextlib.contextmanager
def _sigterm_as_interrupt() -> Any:
    """Within, SIGTERM (what a CI runner sends at its time limit) stops the command as Ctrl-C
    does, with :class:`Terminated`: the talk's folder is finished, evaluate's workers are ended,
    and the exit status is 143. Python's default is to die at once: a folder without
    summary.json, a session.json giving the whole talk's length, orphaned worker processes."""
    _SIGNALLED.clear()
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def on_sigterm(signum: int, frame: Any) -> None:
        _SIGNALLED.append(signum)
        raise Terminated()

    previous = signal.signal(signal.SIGTERM, on_sigterm)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


#: Exit status after the reader of our output went away (``prezence … | head``): 128 + SIGPIPE.
EXIT_BROKEN_PIPE = 141


def _broken_pipe() -> int:
    """The reader of stdout is gone: stop quietly (no traceback, no second error at exit)."""
    import os

    with contextlib.suppress(OSError, ValueError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    return EXIT_BROKEN_PIPE


if __name__ == "__main__":
    sys.exit(main())
