"""Issue 13: whatever bytes a stream, session or config file holds, the answer is samples or a
clear error, never a traceback (a small, fast cousin of ``bench/fuzz_trust.py``)."""

from __future__ import annotations

import tempfile
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from prezence.config.load import default_path
from prezence.config.tomlconf import loads_config
from prezence.errors import ConfigError
from prezence.session import SessionDir, read_jsonl
from prezence.streams.tail import read_stream

LINE = st.one_of(
    st.builds(lambda t, v: f"{t} {v}", st.floats(allow_nan=True), st.floats(allow_nan=True)),
    st.text(max_size=40),
    st.sampled_from(["1e9 1", "nan nan", "inf 3", "-1 2", "1e308 1e308", "x" * 5000]),
)


@settings(max_examples=150, deadline=None)
@given(lines=st.lists(LINE, max_size=40), torn=st.booleans(), limit=st.floats(0, 1e4))
def test_any_stream_file_gives_samples_within_the_talk(
    lines: list[str], torn: bool, limit: float
) -> None:
    with tempfile.TemporaryDirectory() as d:
        f = Path(d) / "s.txt"
        text = "\n".join(lines) + ("" if torn else "\n")
        f.write_bytes(text.encode("utf-8", "surrogatepass"))
        samples, stats = read_stream(f, "m", max_t=limit)
        assert all(s.t <= limit for s in samples)
        assert stats.samples == len(samples)


@settings(max_examples=150, deadline=None)
@given(data=st.binary(max_size=300) | st.text(max_size=300).map(str.encode))
def test_any_session_json_or_jsonl_is_read_or_refused_clearly(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as d:
        s = SessionDir(Path(d))
        s.meta.write_bytes(data)
        s.cues.write_bytes(data)
        for read in (s.read_meta, lambda: read_jsonl(s.cues)):
            try:
                out = read()
            except ConfigError as e:
                assert str(s.root) in str(e)
            else:
                assert isinstance(out, dict | list)


BASE = default_path().read_text()


@settings(max_examples=150, deadline=None)
@given(cut=st.integers(0, len(BASE)), insert=st.text(max_size=30))
def test_any_mangled_config_loads_or_names_its_problem(cut: int, insert: str) -> None:
    text = BASE[:cut] + insert + BASE[cut:]
    try:
        loads_config(text, path="c.toml")
    except ConfigError as e:
        assert str(e).startswith("c.toml")
