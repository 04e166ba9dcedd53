"""The seed's line format: one rule per line, a second front end to the config dataclasses.

Grammar (``#`` starts a comment, blank lines are ignored)::

    <metric> <check> <value>… [strict] [<below-cmd> <above-cmd>] [key=value…]

- ``check`` is ``min`` (one value: the low bound), ``max`` (one value: the high bound) or
  ``inRange`` (two values, low <= high), in any letter case.
- A value is a number or a named value from the room profile (UPPER_CASE, e.g. ``ANGLE``).
- Positional commands: ``min`` takes one (the *below* command), ``max`` one (the *above*
  command), ``inRange`` two, in the order ``<below> <above>``. The explicit form
  ``below=speedUp above=slowDown`` says the same without relying on the order.
- Keys: ``below=``, ``above=`` (commands), ``scale=`` (deviation scale, the metric's unit),
  ``gain=``, ``offset=`` (added to every value), ``at=listener`` (offset = the inverse-square
  estimate at the room's farthest listener), ``stream=`` (file name), ``stale=`` (seconds),
  ``unit=``, ``range=LO..HI`` (the values a metric of your own can physically take; the stream
  readers skip the others). A value with spaces or ``#`` is written in double quotes:
  ``unit="dB SPL"``.

The checks shared with the TOML front end (commands exist and point the right way, a bound at or
below zero needs ``scale``…) live in :func:`check_rule`; each front end turns a
:class:`RuleProblem` into a :class:`~prezence.errors.ConfigError` with its own location
(``file:line:col`` here, ``file: rules[2].above`` in TOML).
"""

from __future__ import annotations

import difflib
import logging
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from prezence.config.model import LISTENER, Check, Direction, RoomProfile, Rule
from prezence.errors import ConfigError, unknown_message
from prezence.metrics import METRICS

log = logging.getLogger(__name__)

#: Command name → the direction it asks the presenter to move a metric.
CommandTable = Mapping[str, Direction]
Syntax = Literal["line", "toml"]

METRIC_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
NAME_RE = re.compile(r"[A-Z][A-Z0-9_]*\Z")
NUMBER_RE = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\Z")

CHECK_WORDS: dict[str, Check] = {c.value.lower(): c for c in Check}
#: Which bounds each check takes, in positional order.
BOUNDS: dict[Check, tuple[str, ...]] = {
    Check.MIN: ("low",),
    Check.MAX: ("high",),
    Check.IN_RANGE: ("low", "high"),
}
N_VALUES = {c: len(b) for c, b in BOUNDS.items()}
#: Which commands each check takes, in positional order.
SLOTS: dict[Check, tuple[str, ...]] = {
    Check.MIN: ("below",),
    Check.MAX: ("above",),
    Check.IN_RANGE: ("below", "above"),
}
#: key= of the line format → Rule attribute.
LINE_KEYS: dict[str, str] = {
    "below": "below",
    "above": "above",
    "scale": "scale",
    "gain": "gain",
    "offset": "offset",
    "at": "offset",
    "stream": "stream",
    "stale": "stale_after_s",
    "unit": "unit",
    "range": "physical_range",
}
_NUMBER_KEYS = {"scale", "gain", "offset", "stale"}


class RuleProblem(ValueError):
    """A rule breaks a check; ``field`` is the Rule attribute at fault (front ends locate it)."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(message)
        self.field = field
        self.message = message

    def __reduce__(self) -> tuple[Any, ...]:
        # picklable (a process pool sends errors back): Exception's own gives cls(message)
        return (type(self), (self.field, self.message), self.__dict__)


def command_table() -> dict[str, Direction]:
    """The built-in command table as name → direction."""
    # Imported here: prezence.feedback.commands imports prezence.config.model.
    from prezence.feedback.commands import load_commands

    return {name: cmd.direction for name, cmd in load_commands().items()}


def parse_check(word: str) -> Check:
    """``min``/``max``/``inRange`` in any letter case; raises :class:`RuleProblem`.

    Example:
        >>> parse_check("INRANGE")
        <Check.IN_RANGE: 'inRange'>
    """
    try:
        return CHECK_WORDS[word.lower()]
    except KeyError:
        close = difflib.get_close_matches(word.lower(), list(CHECK_WORDS), n=1, cutoff=0.6)
        hint = f"; did you mean '{CHECK_WORDS[close[0]].value}'?" if close else ""
        raise RuleProblem(
            "check", f"unknown check '{word}'{hint} (checks: min, max, inRange)"
        ) from None


def resolve_name(name: str, room: RoomProfile) -> float:
    """A named value of the room; an unknown name lists the known ones."""
    if name in room.values:
        return float(room.values[name])
    known = sorted(room.values)
    close = difflib.get_close_matches(name, known, n=1, cutoff=0.6)
    hint = f"; did you mean '{close[0]}'?" if close else ""
    listed = ", ".join(known) if known else "none"
    if NAME_RE.match(name):
        what = f"unknown named value '{name}'"
    else:
        what = f"expected a number or a named value (UPPER_CASE, from the room), found '{name}'"
    raise RuleProblem("value", f"{what} (room '{room.name}' defines: {listed}){hint}")


def _kv(syntax: Syntax, key: str, value: str) -> str:
    """Write ``key=value`` the way the user's format does (for fix suggestions)."""
    if syntax == "line":
        return f"{key}={value}"
    quoted = value if NUMBER_RE.match(value) else f'"{value}"'
    return f"{key} = {quoted}"


def _printable(field: str, value: str) -> None:
    if not value.isprintable() or '"' in value:
        raise RuleProblem(field, f"{field} {value!r} must be printable text without '\"'")


def check_rule(
    rule: Rule,
    *,
    commands: CommandTable,
    syntax: Syntax = "line",
    positional: bool = False,
) -> None:
    """Check what both front ends require of a rule; raises :class:`RuleProblem`.

    Args:
        rule: the rule, named values already resolved.
        commands: command name → direction (see :func:`command_table`).
        syntax: the user's format, for the fix suggestions in messages.
        positional: the commands were written positionally (explain the order if reversed).
    """
    if not METRIC_RE.match(rule.metric):
        raise RuleProblem(
            "metric",
            f"metric name {rule.metric!r} must be letters, digits and '_', "
            "not starting with a digit",
        )
    chk = rule.check.value
    for name, v, needed in (
        ("low", rule.low, rule.check in (Check.MIN, Check.IN_RANGE)),
        ("high", rule.high, rule.check in (Check.MAX, Check.IN_RANGE)),
    ):
        if needed and v is None:
            raise RuleProblem(name, f"a {chk} rule needs {name}")
        if not needed and v is not None:
            raise RuleProblem(name, f"a {chk} rule has no {name} bound")
        if v is not None and not math.isfinite(v):
            raise RuleProblem(name, f"{name} must be a finite number, found {v}")
    if rule.low is not None and rule.high is not None and rule.low > rule.high:
        raise RuleProblem("high", f"inRange needs low <= high, found {rule.low:g} > {rule.high:g}")
    for name, v in (
        ("scale", rule.scale),
        ("gain", rule.gain),
        ("stale_after_s", rule.stale_after_s),
    ):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise RuleProblem(name, f"{name} must be a number > 0, found {v}")
    if not math.isfinite(rule.offset):
        raise RuleProblem("offset", f"offset must be a finite number, found {rule.offset}")
    _check_commands(rule, commands, syntax, positional)
    _check_physical_range(rule, syntax)
    _check_bounds_in_range(rule)
    if rule.scale is None:
        for name, v in (("low", rule.low), ("high", rule.high)):
            if v is not None and v <= 0:
                raise RuleProblem(
                    name,
                    f"bound {v:g} is <= 0, so a deviation in percent of it means nothing; give "
                    f"the deviation scale in the metric's unit, e.g. {_kv(syntax, 'scale', '10')} "
                    f"(a value one scale outside the band deviates by 100 %)",
                )
    _printable("unit", rule.unit)
    _printable("stream", rule.stream)
    parts = re.split(r"[/\\]", rule.stream)
    if rule.stream.startswith(("/", "\\")) or ".." in parts or not parts[-1]:
        raise RuleProblem(
            "stream", f"stream {rule.stream!r} must be a file name inside the streams folder"
        )


def _check_physical_range(rule: Rule, syntax: Syntax) -> None:
    if rule.physical_range is None:
        return
    lo, hi = rule.physical_range
    rec = METRICS.get(rule.metric)
    if rec is not None and rec.physical_range is not None:
        rlo, rhi = rec.physical_range
        raise RuleProblem(
            "physical_range",
            f"{rule.metric} has its physical range {rlo:g}..{rhi:g} {rec.unit} from its record "
            "(prezence/metrics.py); a range of its own is for metrics without one",
        )
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        shown = f"{lo:g}..{hi:g}" if syntax == "line" else f"[{lo:g}, {hi:g}]"
        raise RuleProblem(
            "physical_range", f"range needs two finite numbers LO < HI, found {shown}"
        )


def _check_bounds_in_range(rule: Rule) -> None:
    """A bound outside the values the metric can take either can never be met (the rule
    would cue for the whole talk) or is always met (its command is never given)."""
    vr = rule.value_range
    if vr is None:
        return
    lo, hi = vr[0] + rule.offset, vr[1] + rule.offset
    rec = METRICS.get(rule.metric)
    unit = rec.unit if rec is not None else rule.unit
    shown = f"{lo:g}..{hi:g}" + (f" {unit}" if unit and ".." not in unit else "")
    where = f"{rule.metric} is {shown} (physical range"
    where += f", with offset {rule.offset:g})" if rule.offset else ")"
    chk = rule.check.value
    for name, v, side in (("low", rule.low, "below"), ("high", rule.high, "above")):
        if v is None:
            continue
        bound = f"{chk} {v:g}" if rule.check is not Check.IN_RANGE else f"{name} {v:g}"
        # the lower bound above every value, or the upper one below every value
        never_met = v > hi if name == "low" else v < lo
        if never_met:
            raise RuleProblem(name, f"{where}; {bound} can never be met")
        if v < lo or v > hi:
            cmd = getattr(rule, side)
            what = f"'{cmd}' is never given" if cmd else f"the {side} side never cues"
            beyond = "below" if v < lo else "above"
            raise RuleProblem(
                name, f"{where}; {bound} is {beyond} every value it can take, so {what}"
            )


def parse_range(text: str) -> tuple[float, float] | None:
    """``LO..HI`` as two numbers (any order; :func:`check_rule` wants LO < HI); None if not.

    Example:
        >>> parse_range("-90..90.5")
        (-90.0, 90.5)
        >>> parse_range("0-60") is None
        True
    """
    lo, sep, hi = text.partition("..")
    a, b = _number(lo), _number(hi)
    if not sep or a is None or b is None:
        return None
    return a, b


def _check_commands(rule: Rule, commands: CommandTable, syntax: Syntax, positional: bool) -> None:
    slots = SLOTS[rule.check]
    for side in ("below", "above"):
        name = getattr(rule, side)
        if name is None:
            continue
        if side not in slots:
            bound = "lower" if side == "below" else "upper"
            raise RuleProblem(
                side,
                f"a {rule.check.value} rule has no {bound} bound, so the {side} command "
                f"'{name}' would never be given",
            )
        if name not in commands:
            raise RuleProblem(side, unknown_message("command", name, commands))
    below, above = rule.below, rule.above
    bad_below = below is not None and commands[below] is Direction.LOWER
    bad_above = above is not None and commands[above] is Direction.RAISE
    fix = f"{_kv(syntax, 'below', str(above))} {_kv(syntax, 'above', str(below))}"
    if bad_below and bad_above:
        order = "commands are written in the order <below> <above>: " if positional else ""
        swapped = f"'{above} {below}', or clearer: " if positional else ""
        raise RuleProblem(
            "below",
            f"{order}'{below}' would be given when {rule.metric} is below {rule.low:g} and "
            f"'{above}' when it is above {rule.high:g}, the wrong way round ('{below}' lowers "
            f"the metric, '{above}' raises it); write {swapped}{fix}",
        )
    for side, bad, want in (
        ("below", bad_below, Direction.RAISE),
        ("above", bad_above, Direction.LOWER),
    ):
        if bad:
            name = getattr(rule, side)
            fitting = sorted(n for n, d in commands.items() if d is want)
            raise RuleProblem(
                side,
                f"the {side} command '{name}' {commands[name].value}s {rule.metric}, but it is "
                f"given when the value is {side} the band; use one that {want.value}s it "
                f"({', '.join(fitting)}) or a neutral one",
            )


@dataclass(frozen=True)
class _Token:
    text: str
    col: int  # 1-based


class _Where:
    """Builds ConfigErrors for one line."""

    def __init__(self, path: str, line: int) -> None:
        self.path = path
        self.line = line

    def __call__(self, col: int, message: str) -> ConfigError:
        return ConfigError(message, path=self.path, line=self.line, col=col)


def _tokens(line: str, where: _Where) -> list[_Token]:
    """Split on whitespace; ``#`` outside double quotes ends the line."""
    out: list[_Token] = []
    i, n = 0, len(line)
    while i < n:
        ch = line[i]
        if ch.isspace():
            i += 1
            continue
        if ch == "#":
            break
        start, quote = i, -1
        while i < n:
            ch = line[i]
            if ch == '"':
                quote = i if quote < 0 else -1
            elif quote < 0 and (ch.isspace() or ch == "#"):
                break
            i += 1
        if quote >= 0:
            raise where(quote + 1, "unterminated '\"'")
        out.append(_Token(line[start:i], start + 1))
    return out


def _number(text: str) -> float | None:
    if not NUMBER_RE.match(text):
        return None
    x = float(text)
    return x if math.isfinite(x) else None


def parse_rule_line(
    line: str,
    *,
    path: str | Path = "<string>",
    lineno: int = 1,
    room: RoomProfile | None = None,
    commands: CommandTable | None = None,
) -> Rule | None:
    """Parse one line; None for a blank or comment line. Raises :class:`ConfigError`.

    Example:
        >>> r = parse_rule_line("speech_speed inRange 140 180 speedUp slowDown")
        >>> (r.low, r.high, r.below, r.above)
        (140.0, 180.0, 'speedUp', 'slowDown')
    """
    room = room if room is not None else RoomProfile()
    commands = commands if commands is not None else command_table()
    where = _Where(str(path), lineno)
    toks = _tokens(line, where)
    if not toks:
        return None
    metric = toks[0]
    if not METRIC_RE.match(metric.text):
        raise where(
            metric.col,
            f"expected a metric name (letters, digits, '_'), found '{metric.text}'",
        )
    end_col = toks[-1].col + len(toks[-1].text)
    if len(toks) < 2:
        raise where(end_col, f"'{metric.text}' needs a check: min, max or inRange")
    try:
        check = parse_check(toks[1].text)
    except RuleProblem as p:
        raise where(toks[1].col, p.message) from None
    n = N_VALUES[check]
    usage = {Check.MIN: "<low>", Check.MAX: "<high>", Check.IN_RANGE: "<low> <high>"}[check]
    cols: dict[str, int] = {"metric": metric.col, "check": toks[1].col}
    values: list[float] = []
    for t in toks[2 : 2 + n]:
        x = _number(t.text)
        if x is None:
            if "=" in t.text or t.text.lower() == "strict" or t.text in commands:
                raise where(t.col, f"{check.value} takes {n} value(s): {usage}; found '{t.text}'")
            try:
                x = resolve_name(t.text, room)
            except RuleProblem as p:
                raise where(t.col, p.message) from None
        values.append(x)
    if len(values) < n:
        raise where(end_col, f"{check.value} takes {n} value(s): {usage}")
    bounds = BOUNDS[check]
    named_scale: float | None = None
    named: dict[str, str] = {}  # bound -> the room's name it came from
    for name, t in zip(bounds, toks[2 : 2 + n], strict=True):
        cols[name] = t.col
        if t.text in room.values:
            named[name] = t.text
        if named_scale is None and t.text in room.scales:
            named_scale = float(room.scales[t.text])
    rest = toks[2 + n :]
    for j, t in enumerate(rest):
        if j > 0 and "=" not in t.text and t.text.lower() in CHECK_WORDS:
            prev = rest[j - 1]
            raise where(
                prev.col,
                f"a second rule starts here ('{prev.text} {t.text} …'); write one rule per line",
            )
    strict = False
    positional: list[_Token] = []
    kv: dict[str, str] = {}
    for t in rest:
        if "=" in t.text:
            key, _, raw = t.text.partition("=")
            vcol = t.col + len(key) + 1
            if key not in LINE_KEYS:
                raise where(t.col, unknown_message("key", key, LINE_KEYS))
            if key in kv:
                raise where(t.col, f"{key}= given twice")
            if raw.startswith('"') and raw.endswith('"') and len(raw) >= 2:
                raw = raw[1:-1]
            if '"' in raw:
                raise where(vcol, f'quote the whole value: {key}="…"')
            if not raw:
                raise where(vcol, f"{key}= needs a value")
            kv[key] = raw
            cols[LINE_KEYS[key]] = vcol
        elif t.text.lower() == "strict":
            if strict:
                raise where(t.col, "strict given twice")
            strict = True
        elif _number(t.text) is not None or t.text in room.values:
            raise where(t.col, f"{check.value} takes {n} value(s): {usage}; extra '{t.text}'")
        else:
            positional.append(t)
    slots = SLOTS[check]
    if len(positional) > len(slots):
        extra = positional[len(slots)]
        raise where(
            extra.col,
            f"{check.value} takes {len(slots)} command(s): "
            f"{' '.join(f'<{s}>' for s in slots)}; extra '{extra.text}'",
        )
    if positional and len(positional) < len(slots):
        raise where(
            positional[0].col,
            "inRange takes two commands in the order <below> <above>; for one side only, "
            "write below=… or above=…",
        )
    cmds: dict[str, str] = {}
    for slot, t in zip(slots, positional, strict=False):
        cmds[slot] = t.text
        cols[slot] = t.col
    for side in ("below", "above"):
        if side in kv:
            if side in cmds:
                raise where(cols[side], f"{side} command given twice ('{cmds[side]}' and {side}=)")
            cmds[side] = kv[side]
    nums: dict[str, float] = {}
    for key in _NUMBER_KEYS & kv.keys():
        x = _number(kv[key])
        if x is None:
            raise where(cols[LINE_KEYS[key]], f"{key}= takes a number, found '{kv[key]}'")
        nums[key] = x
    physical_range: tuple[float, float] | None = None
    if "range" in kv:
        physical_range = parse_range(kv["range"])
        if physical_range is None:
            raise where(
                cols["physical_range"],
                f"range= takes LO..HI, two numbers, e.g. range=0..60; found '{kv['range']}'",
            )
    offset = nums.get("offset", 0.0)
    if "at" in kv:
        col = cols["offset"]
        if kv["at"] != "listener":
            raise where(col, f"at= takes 'listener', found '{kv['at']}'")
        if "offset" in kv:
            raise where(col, "give at=listener or offset=, not both")
        if room.farthest_listener_m is None:
            raise where(
                col,
                f"at=listener needs the room's farthest_listener_m (room '{room.name}' has none)",
            )
        offset = room.listener_offset_db()
    at = LISTENER if "at" in kv else ""
    low = values[0] if "low" in bounds else None
    high = values[-1] if "high" in bounds else None
    rule = Rule(
        metric=metric.text,
        check=check,
        low=low,
        high=high,
        strict=strict,
        below=cmds.get("below"),
        above=cmds.get("above"),
        scale=nums.get("scale", named_scale),
        gain=nums.get("gain", 1.0),
        offset=offset,
        at=at,
        stream=kv.get("stream", ""),
        stale_after_s=nums.get("stale"),
        unit=kv.get("unit", ""),
        physical_range=physical_range,
        source=f"{path}:{lineno}",
    )
    try:
        check_rule(rule, commands=commands, syntax="line", positional=bool(positional))
    except RuleProblem as p:
        message = p.message
        if p.field in named:  # the number is the room's: say so
            message += f" ({named[p.field]} = {getattr(rule, p.field):g} in room '{room.name}')"
        raise where(cols.get(p.field, 1), message) from None
    return rule


def parse_lines(
    text: str,
    *,
    path: str | Path = "<string>",
    room: RoomProfile | None = None,
    commands: CommandTable | None = None,
    errors: list[ConfigError] | None = None,
) -> tuple[Rule, ...]:
    """Parse a whole rule file. Raises :class:`ConfigError` at the first problem.

    Args:
        text: the file's text.
        path: the file name shown in messages.
        room: the room profile that named values come from (default: ``RoomProfile()``).
        commands: command name → direction (default: the built-in command table).
        errors: when given, problems are appended here and parsing goes on (for
            ``check-config``); the result then holds only the good rules.

    Example:
        >>> rules = parse_lines("speech_speed inRange 140 180 below=speedUp above=slowDown\\n"
        ...                     "cv_headGaze min ANGLE lookUp scale=10  # degrees")
        >>> [(r.metric, r.low, r.high) for r in rules]
        [('speech_speed', 140.0, 180.0), ('cv_headGaze', -15.0, None)]
    """
    room = room if room is not None else RoomProfile()
    commands = commands if commands is not None else command_table()
    rules: list[Rule] = []
    first: dict[str, int] = {}
    for lineno, line in enumerate(text.split("\n"), start=1):
        try:
            rule = parse_rule_line(
                line.removesuffix("\r"), path=path, lineno=lineno, room=room, commands=commands
            )
            if rule is None:
                continue
            if rule.metric in first:
                raise ConfigError(
                    f"second rule for metric '{rule.metric}' (the first is on line "
                    f"{first[rule.metric]}); one rule per metric",
                    path=str(path),
                    line=lineno,
                    col=len(line) - len(line.lstrip()) + 1,
                )
        except ConfigError as e:
            if errors is None:
                raise
            errors.append(e)
            continue
        first[rule.metric] = lineno
        rules.append(rule)
    log.debug("%s: %d rules", path, len(rules))
    return tuple(rules)


def _num(x: float) -> str:
    if not math.isfinite(x):
        raise ValueError(f"cannot write the non-finite number {x}")
    if x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return repr(float(x))


def _text(v: str) -> str:
    if '"' in v or not v.isprintable():
        raise ValueError(f"cannot write {v!r} in the line format")
    return f'"{v}"' if not v or " " in v or "#" in v else v


def format_rule(rule: Rule) -> str:
    """The rule in the explicit line form; ``parse_lines(format_rule(r)) == (r,)``.

    Named values come out as numbers, and ``at=listener`` as its ``offset=``.

    Example:
        >>> from prezence.config.model import Check, Rule
        >>> format_rule(Rule("speech_speed", Check.IN_RANGE, low=140, high=180,
        ...                  below="speedUp", above="slowDown"))
        'speech_speed inRange 140 180 below=speedUp above=slowDown'
    """
    wanted = BOUNDS[rule.check]
    bounds = [getattr(rule, b) for b in wanted]
    if any(b is None for b in bounds) or any(
        getattr(rule, b) is not None for b in ("low", "high") if b not in wanted
    ):
        raise ValueError(f"rule {rule.metric!r}: its bounds do not fit check {rule.check.value}")
    parts = [rule.metric, rule.check.value, *(_num(b) for b in bounds)]
    if rule.strict:
        parts.append("strict")
    for key, v in (("below", rule.below), ("above", rule.above)):
        if v is not None:
            parts.append(f"{key}={v}")
    for key, x in (
        ("scale", rule.scale),
        ("gain", None if rule.gain == 1.0 else rule.gain),
        ("offset", rule.offset or None),
        ("stale", rule.stale_after_s),
    ):
        if x is not None:
            parts.append(f"{key}={_num(x)}")
    if rule.stream != f"{rule.metric}.txt":
        parts.append(f"stream={_text(rule.stream)}")
    if rule.unit:
        parts.append(f"unit={_text(rule.unit)}")
    if rule.physical_range is not None:
        lo, hi = rule.physical_range
        parts.append(f"range={_num(lo)}..{_num(hi)}")
    return " ".join(parts)
