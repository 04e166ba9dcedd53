"""The TOML form of a configuration (stdlib ``tomllib``), and :func:`dumps_config` to write it.

Layout (every key is optional unless noted; a missing key takes the dataclass default)::

    format = 1                      # required
    rules_file = "rules.txt"        # a seed line-format file, relative to this file …
    [room]        name, values (table NAME → number), scales (table NAME → scale of the rules
                  whose bound is that name), laptop_distance_m, farthest_listener_m
    [processor]   the fields of ProcessorSettings; praise_command = false disables praise
    [time]        the fields of TimeSettings; allocated_s = false disables time warnings
    [[rules]]     … or rules as tables: metric, check, low, high (numbers or named values as
                  strings), strict, below, above, scale, gain, offset, at = "listener", stream,
                  stale_after_s, unit, range = [LO, HI] (a metric of your own: the values it
                  can physically take)

Syntax errors carry tomllib's line and column. Semantic errors carry the key path
(``rules[2].above``, rules counted from 0) and, where a simple scan of the text finds it, the line.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from prezence.config.lines import (
    METRIC_RE,
    NAME_RE,
    CommandTable,
    RuleProblem,
    check_rule,
    command_table,
    parse_check,
    parse_lines,
    resolve_name,
)
from prezence.config.model import (
    DAY_S,
    FORMAT,
    LISTENER,
    SETTING_BOUNDS,
    ZERO_IS_OFF,
    Config,
    ProcessorSettings,
    RoomProfile,
    Rule,
    TimeSettings,
)
from prezence.errors import ConfigError, unknown_message
from prezence.tomlio import KeyPath, keypath_str, locate

log = logging.getLogger(__name__)

TOP_KEYS = ("format", "rules_file", "room", "processor", "time", "rules")
#: What a room file (``--room``) holds: its format and its ``[room]``, nothing else.
ROOM_FILE_KEYS = ("format", "room")
ROOM_KEYS = ("name", "values", "scales", "laptop_distance_m", "farthest_listener_m")
RULE_KEYS = (
    "metric",
    "check",
    "low",
    "high",
    "strict",
    "below",
    "above",
    "scale",
    "gain",
    "offset",
    "at",
    "stream",
    "stale_after_s",
    "unit",
    "range",
)


class _Bad(ValueError):
    """A value is wrong; the caller knows where."""


@dataclass
class _Ctx:
    path: str
    text: str
    commands: CommandTable
    errors: list[ConfigError] | None

    def error(self, kp: KeyPath, message: str) -> ConfigError:
        return ConfigError(
            message, path=self.path, line=locate(self.text, kp), key=keypath_str(kp) or None
        )

    def report(self, e: ConfigError) -> None:
        """Raise, or collect when checking."""
        if self.errors is None:
            raise e
        self.errors.append(e)


def _describe(v: object) -> str:
    if isinstance(v, bool):
        return f"boolean {str(v).lower()}"
    if isinstance(v, str):
        return f"string {v!r}"
    if isinstance(v, dict):
        return "a table"
    if isinstance(v, list):
        return "an array"
    return f"{type(v).__name__} {v}"


def _num(v: object) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise _Bad(f"expected a number, found {_describe(v)}")
    try:
        x = float(v)
    except OverflowError:
        x = math.inf
    if not math.isfinite(x):
        raise _Bad(f"expected a finite number, found {v}")
    return x


def _positive(v: object) -> float:
    x = _num(v)
    if x <= 0:
        raise _Bad(f"must be > 0, found {x:g}")
    return x


def _nonneg(v: object) -> float:
    x = _num(v)
    if x < 0:
        raise _Bad(f"must be >= 0, found {x:g}")
    return x


def _str(v: object) -> str:
    if not isinstance(v, str):
        raise _Bad(f"expected a string, found {_describe(v)}")
    return v


def _bool(v: object) -> bool:
    if not isinstance(v, bool):
        raise _Bad(f"expected true or false, found {_describe(v)}")
    return v


def _table(v: object, what: str) -> dict[str, Any]:
    if not isinstance(v, dict):
        raise _Bad(f"expected a table ({what}), found {_describe(v)}")
    return v


def _known_keys(ctx: _Ctx, table: Mapping[str, Any], known: tuple[str, ...], kp: KeyPath) -> None:
    for k in table:
        if k not in known:
            ctx.report(ctx.error((*kp, k), unknown_message("key", k, known)))


Converter = Callable[[object, _Ctx], Any]


def _command(v: object, ctx: _Ctx) -> str:
    name = _str(v)
    if name not in ctx.commands:
        raise _Bad(unknown_message("command", name, ctx.commands))
    return name


def _command_or_false(v: object, ctx: _Ctx) -> str | None:
    if v is False:
        return None
    return _command(v, ctx)


def _positive_or_false(v: object, ctx: _Ctx) -> float | None:
    return None if v is False else _positive(v)


def _warn_times(v: object, ctx: _Ctx) -> tuple[float, ...]:
    if not isinstance(v, list):
        raise _Bad(f"expected an array of seconds, found {_describe(v)}")
    out = tuple(_positive(x) for x in v)
    if len(set(out)) != len(out):
        raise _Bad("each time may appear once")
    return out


def _plain(conv: Callable[[object], Any]) -> Converter:
    return lambda v, ctx: conv(v)


def _between(lo: float, hi: float, *, zero: bool = False) -> Converter:
    """A number in ``[lo, hi]`` (``zero``: 0 is allowed too, meaning "off")."""

    def conv(v: object, ctx: _Ctx) -> float:
        x = _num(v)
        if zero and x == 0:
            return x
        if not lo <= x <= hi:
            off = " (or 0: off)" if zero else ""
            raise _Bad(f"must be between {lo:g} and {hi:g}{off}, found {x:g}")
        return x

    return conv


def _bounded(key: str) -> Converter:
    lo, hi = SETTING_BOUNDS[key]
    return _between(lo, hi, zero=key in ZERO_IS_OFF)


def _allocated(v: object, ctx: _Ctx) -> float | None:
    return None if v is False else _bounded("allocated_s")(v, ctx)


def _warn_times_bounded(v: object, ctx: _Ctx) -> tuple[float, ...]:
    out = _warn_times(v, ctx)
    for x in out:
        if x > DAY_S:
            raise _Bad(f"each time must be at most {DAY_S:g} s, found {x:g}")
    return out


_PROCESSOR: dict[str, Converter] = {
    "threshold": _bounded("threshold"),
    "decay_half_life_s": _bounded("decay_half_life_s"),
    "min_gap_s": _bounded("min_gap_s"),
    "refractory_s": _bounded("refractory_s"),
    "stale_after_s": _bounded("stale_after_s"),
    "decision_period_s": _bounded("decision_period_s"),
    "praise_after_s": _bounded("praise_after_s"),
    "praise_command": _command_or_false,
}
_TIME: dict[str, Converter] = {
    "allocated_s": _allocated,
    "warn_at_s_left": _warn_times_bounded,
    "warn_command": _command,
    "overtime_command": _command,
    "overtime_repeat_s": _bounded("overtime_repeat_s"),
}


def _settings(
    cls: type[ProcessorSettings] | type[TimeSettings],
    spec: dict[str, Converter],
    raw: object,
    name: str,
    ctx: _Ctx,
) -> Any:
    try:
        table = _table(raw, f"[{name}]")
    except _Bad as e:
        ctx.report(ctx.error((name,), str(e)))
        return cls()
    keys = tuple(spec)
    _known_keys(ctx, table, keys, (name,))
    kwargs: dict[str, Any] = {}
    for k, conv in spec.items():
        if k in table:
            try:
                kwargs[k] = conv(table[k], ctx)
            except _Bad as e:
                ctx.report(ctx.error((name, k), str(e)))
    return cls(**kwargs)


def _room(raw: object, ctx: _Ctx) -> RoomProfile:
    try:
        table = _table(raw, "[room]")
    except _Bad as e:
        ctx.report(ctx.error(("room",), str(e)))
        return RoomProfile()
    _known_keys(ctx, table, ROOM_KEYS, ("room",))
    kwargs: dict[str, Any] = {}
    try:
        if "name" in table:
            kwargs["name"] = _str(table["name"])
    except _Bad as e:
        ctx.report(ctx.error(("room", "name"), str(e)))
    if "values" in table:
        try:
            values = _table(table["values"], "NAME = number")
        except _Bad as e:
            ctx.report(ctx.error(("room", "values"), str(e)))
            values = {}
        good: dict[str, float] = {}
        for k, v in values.items():
            try:
                if not NAME_RE.match(k):
                    raise _Bad(f"named values are UPPER_CASE (letters, digits, '_'), not '{k}'")
                good[k] = _num(v)
            except _Bad as e:
                ctx.report(ctx.error(("room", "values", k), str(e)))
        kwargs["values"] = good
    if "scales" in table:
        try:
            scales = _table(table["scales"], "NAME = number > 0")
        except _Bad as e:
            ctx.report(ctx.error(("room", "scales"), str(e)))
            scales = {}
        good_scales: dict[str, float] = {}
        for k, v in scales.items():
            try:
                if not NAME_RE.match(k):
                    raise _Bad(f"named values are UPPER_CASE (letters, digits, '_'), not '{k}'")
                good_scales[k] = _positive(v)
            except _Bad as e:
                ctx.report(ctx.error(("room", "scales", k), str(e)))
        kwargs["scales"] = good_scales
    for k in ("laptop_distance_m", "farthest_listener_m"):
        if k in table:
            try:
                kwargs[k] = _positive(table[k])
            except _Bad as e:
                ctx.report(ctx.error(("room", k), str(e)))
    room = RoomProfile(**kwargs)
    if room.farthest_listener_m is not None and room.farthest_listener_m < room.laptop_distance_m:
        ctx.report(
            ctx.error(
                ("room", "farthest_listener_m"),
                f"the farthest listener ({room.farthest_listener_m:g} m) is nearer than the "
                f"laptop ({room.laptop_distance_m:g} m)",
            )
        )
        room = RoomProfile(**{**kwargs, "farthest_listener_m": None})
    return room


def _rule(raw: object, kp: KeyPath, room: RoomProfile, ctx: _Ctx) -> Rule:
    """One [[rules]] table; raises ConfigError at its first problem."""
    try:
        table = _table(raw, "[[rules]]")
    except _Bad as e:
        raise ctx.error(kp, str(e)) from None
    for k in table:
        if k not in RULE_KEYS:
            raise ctx.error((*kp, k), unknown_message("key", k, RULE_KEYS))
    for k in ("metric", "check"):
        if k not in table:
            raise ctx.error(kp, f"missing key '{k}'")
    key = "metric"
    try:
        metric = _str(table["metric"])
        if not METRIC_RE.match(metric):
            raise _Bad(f"metric name {metric!r} must be letters, digits and '_'")
        key = "check"
        check = parse_check(_str(table["check"]))
        bounds: dict[str, float | None] = {"low": None, "high": None}
        named_scale: float | None = None
        named: dict[str, str] = {}  # bound -> the room's name it came from
        for key in ("low", "high"):
            v = table.get(key)
            if isinstance(v, str):
                bounds[key] = resolve_name(v, room)
                named[key] = v
                if named_scale is None and v in room.scales:
                    named_scale = float(room.scales[v])
            elif v is not None:
                bounds[key] = _num(v)
        key = "strict"
        strict = _bool(table.get("strict", False))
        cmds: dict[str, str | None] = {}
        for key in ("below", "above"):
            cmds[key] = _str(table[key]) if key in table else None
        nums: dict[str, float | None] = {}
        for key in ("scale", "gain", "offset", "stale_after_s"):
            nums[key] = _num(table[key]) if key in table else None
        texts: dict[str, str] = {}
        for key in ("stream", "unit"):
            texts[key] = _str(table.get(key, ""))
        key = "range"
        physical_range: tuple[float, float] | None = None
        if "range" in table:
            pair = table["range"]
            if not (isinstance(pair, list) and len(pair) == 2):
                raise _Bad(f"range takes [LO, HI], two numbers; found {_describe(pair)}")
            physical_range = (_num(pair[0]), _num(pair[1]))
        key = "at"
        offset = nums["offset"] if nums["offset"] is not None else 0.0
        if "at" in table:
            if table["at"] != "listener":
                raise _Bad(f'at takes "listener", found {_describe(table["at"])}')
            if "offset" in table:
                raise _Bad('give at = "listener" or offset, not both')
            if room.farthest_listener_m is None:
                raise _Bad(
                    f"at = \"listener\" needs [room] farthest_listener_m (room '{room.name}' has "
                    "none)"
                )
            offset = room.listener_offset_db()
    except (_Bad, RuleProblem) as e:
        raise ctx.error((*kp, key), str(e)) from None
    gain = nums["gain"]
    line = locate(ctx.text, kp)
    rule = Rule(
        metric=metric,
        check=check,
        low=bounds["low"],
        high=bounds["high"],
        strict=strict,
        below=cmds["below"],
        above=cmds["above"],
        scale=nums["scale"] if nums["scale"] is not None else named_scale,
        gain=gain if gain is not None else 1.0,
        offset=offset,
        at=LISTENER if "at" in table else "",
        stream=texts["stream"],
        stale_after_s=nums["stale_after_s"],
        unit=texts["unit"],
        physical_range=physical_range,
        source=f"{ctx.path}:{line}" if line is not None else f"{ctx.path}: {keypath_str(kp)}",
    )
    try:
        check_rule(rule, commands=ctx.commands, syntax="toml")
    except RuleProblem as p:
        key = {"physical_range": "range"}.get(p.field, p.field)  # the TOML key's name
        message = p.message
        if p.field in named:  # the number is the room's: say so
            message += f" ({named[p.field]} = {getattr(rule, p.field):g} in room '{room.name}')"
        raise ctx.error((*kp, key), message) from None
    return rule


def _rules(
    doc: Mapping[str, Any], room: RoomProfile, base_dir: Path, ctx: _Ctx
) -> tuple[Rule, ...]:
    if "rules_file" in doc:
        if "rules" in doc:
            raise ctx.error(("rules_file",), "give rules_file or [[rules]], not both")
        try:
            name = _str(doc["rules_file"])
        except _Bad as e:
            raise ctx.error(("rules_file",), str(e)) from None
        file = base_dir / name
        try:
            text = file.read_text(encoding="utf-8-sig")
        except (OSError, UnicodeDecodeError) as e:
            raise ctx.error(("rules_file",), f"cannot read '{file}': {e}") from e
        return parse_lines(text, path=file, room=room, commands=ctx.commands, errors=ctx.errors)
    if "rules" not in doc:
        raise ctx.error(("rules",), 'no rules: add [[rules]] tables or rules_file = "rules.txt"')
    raw = doc["rules"]
    if not isinstance(raw, list):
        raise ctx.error(("rules",), f"expected [[rules]] tables, found {_describe(raw)}")
    rules: list[Rule] = []
    first: dict[str, int] = {}
    for i, item in enumerate(raw):
        try:
            rule = _rule(item, ("rules", i), room, ctx)
            if rule.metric in first:
                raise ctx.error(
                    ("rules", i, "metric"),
                    f"second rule for metric '{rule.metric}' (the first is "
                    f"rules[{first[rule.metric]}]); one rule per metric",
                )
        except ConfigError as e:
            ctx.report(e)
            continue
        first[rule.metric] = i
        rules.append(rule)
    return tuple(rules)


def _parse(text: str, path: str) -> dict[str, Any]:
    from prezence.tomlio import loads_toml

    return loads_toml(text, path=path)


def _check_format(doc: Mapping[str, Any], ctx: _Ctx) -> None:
    if "format" not in doc:
        raise ctx.error(("format",), f"missing 'format = {FORMAT}' (the config format version)")
    if doc["format"] != FORMAT or isinstance(doc["format"], bool):
        raise ctx.error(
            ("format",),
            f"format {doc['format']!r} is not supported; this Prezence reads format = {FORMAT}",
        )


def loads_config(
    text: str,
    *,
    path: str | Path = "<string>",
    room: RoomProfile | None = None,
    base_dir: str | Path | None = None,
    commands: CommandTable | None = None,
    errors: list[ConfigError] | None = None,
) -> Config:
    """Load a configuration from TOML text. Raises :class:`ConfigError`.

    Args:
        text: the TOML text.
        path: the file name shown in messages.
        room: overrides the file's ``[room]`` (named values then come from it).
        base_dir: where ``rules_file`` is looked up (default: the folder of ``path``).
        commands: command name → direction (default: the built-in command table).
        errors: when given, problems are appended here and loading goes on as far as it can
            (for ``check-config``); the result is then only partly meaningful.

    Example:
        >>> cfg = loads_config('format = 1\\n[[rules]]\\nmetric = "cv_headGaze"\\n'
        ...                    'check = "min"\\nlow = "ANGLE"\\nscale = 10\\nbelow = "lookUp"\\n')
        >>> cfg.rules[0].low
        -15.0
    """
    spath = str(path)
    ctx = _Ctx(spath, text, commands if commands is not None else command_table(), errors)
    doc = _parse(text, spath)
    _check_format(doc, ctx)
    _known_keys(ctx, doc, TOP_KEYS, ())
    if room is None:
        room = _room(doc.get("room", {}), ctx)
    processor = _settings(ProcessorSettings, _PROCESSOR, doc.get("processor", {}), "processor", ctx)
    time = _settings(TimeSettings, _TIME, doc.get("time", {}), "time", ctx)
    base = Path(base_dir) if base_dir is not None else Path(spath).parent
    try:
        rules = _rules(doc, room, base, ctx)
    except ConfigError as e:
        ctx.report(e)
        rules = ()
    log.debug("%s: %d rules", spath, len(rules))
    return Config(rules=rules, processor=processor, time=time, room=room, source=spath)


def loads_room(text: str, *, path: str | Path = "<string>") -> RoomProfile:
    """The ``[room]`` of a room file, which holds ``format`` and ``[room]`` and nothing else;
    raises ConfigError.

    A table of a whole config (``[processor]``, ``[[rules]]``) is refused rather than ignored:
    whoever wrote it there expects it to count.

    Example:
        >>> try:
        ...     loads_room('format = 1\\n[room]\\n[processor]\\nthreshold = 5\\n', path="r.toml")
        ... except ConfigError as e:
        ...     print(e.line, e.key, e.reason[:25])
        3 processor unknown table 'processor'
    """
    spath = str(path)
    ctx = _Ctx(spath, text, {}, None)
    doc = _parse(text, spath)
    _check_format(doc, ctx)
    for k, v in doc.items():
        if k in ROOM_FILE_KEYS:
            continue
        table = isinstance(v, dict) or (isinstance(v, list) and v and isinstance(v[0], dict))
        if k in TOP_KEYS:
            where = (f"[[{k}]]" if isinstance(v, list) else f"[{k}]") if table else k
            msg = (
                f"unknown {'table' if table else 'key'} '{k}' in a room file; it holds format "
                f"and [room] only: give {where} in the --config file"
            )
        else:
            msg = unknown_message("table" if table else "key", k, ROOM_FILE_KEYS)
        raise ctx.error((k,), msg)
    if "room" not in doc:
        raise ctx.error(("room",), "missing [room]")
    return _room(doc["room"], ctx)


# --- writing ---------------------------------------------------------------------------------

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+\Z")


def _quote(s: str) -> str:
    out = ['"']
    for ch in s:
        if ch in '"\\':
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _key(k: str) -> str:
    return k if _BARE_KEY.match(k) else _quote(k)


def _value(v: object) -> str:
    if v is None:  # TOML has no null: the two optional settings use false
        return "false"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"cannot write the non-finite number {v}")
        return repr(v)
    if isinstance(v, str):
        return _quote(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} as TOML")


def _table_lines(header: str, d: Mapping[str, Any]) -> list[str]:
    return ["", header, *(f"{_key(k)} = {_value(v)}" for k, v in d.items())]


def dumps_config(config: Config) -> str:
    """The configuration as TOML text; :func:`loads_config` of it gives an equal Config.

    Named values are written as the numbers they resolved to; ``at = "listener"`` is kept as
    such (the [room] written with it gives the same offset), so that what reads the file back
    (a report, a replay) can still say the band applies at the farthest listener.
    """
    d = config.to_dict()
    out = ["# Prezence configuration", f"format = {FORMAT}"]
    if not config.rules:
        out.append("rules = []")
    room = dict(d["room"])
    values = room.pop("values")
    scales = room.pop("scales")
    out += _table_lines("[room]", room)
    out += _table_lines("[room.values]", values)
    out += _table_lines("[room.scales]", scales)
    out += _table_lines("[processor]", d["processor"])
    out += _table_lines("[time]", d["time"])
    for r in d["rules"]:
        out += _table_lines("[[rules]]", r)
    return "\n".join(out) + "\n"
