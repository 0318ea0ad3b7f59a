"""``summary.json``'s writer: indented keys, and long lists one encoded line per item."""

from __future__ import annotations

import json
import math
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from sysid_core.data.io import json_line, json_text, write_json

#: JSON-like values with the floats a run reports, NaN and infinity among them.
VALUES = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4)
    ),
    max_leaves=12,
)


def _strict(value: Any) -> Any:
    """What strict JSON keeps of ``value``: NaN and infinity become null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _strict(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_strict(v) for v in value]
    return value


@given(
    top=st.dictionaries(st.text(max_size=6).filter(lambda k: k != "history"), VALUES, max_size=5),
    history=st.lists(VALUES, max_size=5),
)
def test_lines_read_back_as_the_whole_object(top: dict[str, Any], history: list[Any]) -> None:
    text = json_text(top, {"history": [json_line(item) for item in history]})
    assert json.loads(text) == _strict({**top, "history": history})
    # one line per item of the list, after the indented keys
    if history:
        lines = [f"    {json_line(item)}," for item in history]
        lines[-1] = lines[-1][:-1]
        assert text.splitlines()[-2 - len(history) : -2] == lines


def test_a_file_is_written_whole(tmp_path: Any) -> None:
    path = write_json(tmp_path / "s.json", {"a": float("nan")}, {"history": ['{"x": 1}']})
    assert json.loads(path.read_text()) == {"a": None, "history": [{"x": 1}]}
