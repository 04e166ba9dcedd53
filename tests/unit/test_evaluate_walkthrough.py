"""Session 22, a researcher's walkthrough of ``prezence evaluate``: what the tables say must
be what ran (each policy once, by its one name; anchors known however spelt), and a presenter
model must be one a presenter can have."""

from __future__ import annotations

from pathlib import Path

import pytest
from test_evaluate import paired_rows  # tests/unit is on sys.path (pytest prepends it)

from prezence.cli import main
from prezence.evaluate import aggregate, conclusion_lines, conclusions, evaluate


def _evaluate(tmp_path: Path, capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str]:
    out = tmp_path / "ev"
    argv = ["evaluate", "--seeds", "1", "--out", str(out), "-q", *args]
    code = main(argv)
    err = capsys.readouterr().err
    if code != 0:
        assert not out.exists()  # refused before any talk: no folder left either
    return code, err


@pytest.mark.parametrize(
    ("option", "names", "said"),
    [
        ("--policies", ["none", "pz16", "pz16", "rhema"], "policy pz16 is given twice"),
        (
            "--policies",
            ["none", "pt", "presentation_trainer"],
            "policy pt and presentation_trainer are one policy, presentation_trainer",
        ),
        (
            "--policies",
            ["rhema", "rhema:window_s=20"],
            "policy rhema and rhema:window_s=20 are one policy, rhema",
        ),
        ("--scenarios", ["demo", "demo"], "scenario demo is given twice"),
        ("--presenters", ["cost", "cost:1"], "presenter model cost and cost:1 are one"),
    ],
    ids=["twice", "alias", "default-value", "scenario", "presenter"],
)
def test_a_name_given_twice_however_spelt_is_refused_before_any_talk(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    option: str,
    names: list[str],
    said: str,
) -> None:
    # Before: pz16 ran twice and its false alarms and stale cues, sums, doubled in its row;
    # pt and presentation_trainer were two rows of one policy.
    others = {"--policies": ["none"], "--scenarios": ["short_talk"], "--presenters": ["cost"]}
    args = [option, *names]
    for opt, default in others.items():
        if opt != option:
            args += [opt, *default]
    code, err = _evaluate(tmp_path, capsys, *args)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and said in lines[0], err
    assert "give it once" in lines[0]


def test_rows_carry_the_canonical_name_and_an_alias_is_an_anchor() -> None:
    rows = evaluate(["short_talk"], ["none", "weighted", "pt"], 1)
    assert sorted({r["policy"] for r in rows}) == ["none", "presentation_trainer", "weighted"]
    (concl,) = conclusions(aggregate(rows))
    assert concl["anchors"] == ["presentation_trainer"]
    assert concl["default_beats_anchors_per_cue"] is not None  # before: "–", no anchor found


def test_a_parametrised_anchor_counts_as_that_anchor_and_the_label_says_so() -> None:
    rows = [
        dict(r, policy="rhema:hits=2,max_samples=4") if r["policy"] == "rhema" else r
        for r in paired_rows()
    ]
    concl = {c["presenter"]: c for c in conclusions(aggregate(rows))}
    assert concl["free"]["anchors"] == ["rhema:hits=2,max_samples=4"]
    assert concl["free"]["default_beats_anchors_per_cue"] is True
    assert concl["free"]["default_stale"] == 0
    header = conclusion_lines(list(concl.values()))[2]
    assert "weighted beats every anchor (rhema:hits=2,max_samples=4) per cue" in header
    # the three anchors, as named by default: the label as before
    three = paired_rows() + [
        dict(r, policy=a) for r in paired_rows() if r["policy"] == "rhema"
        for a in ("pz16", "presentation_trainer")
    ]  # fmt: skip
    plain = conclusion_lines(conclusions(aggregate(three)))[2]
    assert "| weighted beats every anchor per cue |" in plain


@pytest.mark.parametrize("spec", ["cost:inf", "cost:1e9", "cost:nan", "cost:pause_s=inf",
                                  "cost:6+measured", "cost:fade=-1"])  # fmt: skip
def test_a_presenter_factor_a_presenter_cannot_have_is_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], spec: str
) -> None:
    # Before: cost:inf and cost:1e9 ran (infinite pauses, the gaze at -inf deg) and gave a table.
    with pytest.raises(SystemExit) as stop:  # as every bad value of an option: argparse's
        _evaluate(
            tmp_path, capsys, "--scenarios", "short_talk", "--policies", "weighted",
            "--presenters", spec,
        )  # fmt: skip
    assert stop.value.code == 2
    assert not (tmp_path / "ev").exists()
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"presenter model {spec!r}: the factor must be from 0 to 5" in last, last


def test_the_largest_factor_still_runs() -> None:
    from prezence.synthetic.presenters import MAX_COST_FACTOR, parse_presenter_model

    cost = parse_presenter_model(f"cost:{MAX_COST_FACTOR:g}").cost
    assert cost is not None and cost.attend_gaze_deg >= -90.0
    assert parse_presenter_model("cost:slip_probability=0").cost is not None  # 0: off


def test_the_help_gives_the_default_presenters_as_they_are_typed(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # Before: "(default: ['free+measured', 'cost+measured'])", a Python list.
    from prezence.evaluate import build_parser

    text = " ".join(build_parser().format_help().split())
    assert "(default: free+measured cost+measured)" in text
    assert "['" not in text


def test_every_output_column_and_field_is_documented() -> None:
    # Before: docs/evaluation.md named none of relevant, latencies, waited, backlog_s, talk_s …
    from prezence.evaluate import COLUMNS, evaluation_json

    docs = Path(__file__).parents[2] / "docs" / "evaluation.md"
    section = docs.read_text(encoding="utf-8").split("### The output files", 1)[1]
    section = section.split("\n## ", 1)[0]
    for column in COLUMNS:
        assert f"| `{column}` |" in section, column
    doc = evaluation_json(paired_rows())
    fields = set(doc) | set(doc["policies"]["weighted"]) | set(doc["conclusions"][0])
    for key in sorted(fields):
        assert f"`{key}`" in section, key
