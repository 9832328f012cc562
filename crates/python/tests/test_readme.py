"""The README's example runs as written."""

from __future__ import annotations

import os
import pathlib
import re

import pytest

import lifted


def test_readme_example(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    text = (pathlib.Path(__file__).resolve().parents[1] / "README.md").read_text()
    code = re.search(r"```python\n(.*?)```", text, re.S)
    assert code is not None
    monkeypatch.chdir(tmp_path)
    scope: dict[str, object] = {}
    exec(compile(code.group(1), "README.md", "exec"), scope)
    fit = scope["fit"]
    assert isinstance(fit, lifted.SubspaceFit) and fit.order == 2
    assert os.path.exists(tmp_path / "model.json")
