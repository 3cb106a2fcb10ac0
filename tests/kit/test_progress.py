"""kit.progress: a bar for long loops, none under KIT_FAST (recorded outputs stay stable)."""

from __future__ import annotations

from kit.progress import progress, progress_enabled


def test_no_bar_under_kit_fast(monkeypatch, capsys):
    monkeypatch.setenv("KIT_FAST", "1")
    assert not progress_enabled()
    assert list(progress(range(5), desc="runs")) == [0, 1, 2, 3, 4]
    assert capsys.readouterr().err == ""


def test_a_bar_otherwise(monkeypatch, capsys):
    monkeypatch.delenv("KIT_FAST", raising=False)
    assert progress_enabled()
    assert list(progress(iter(range(3)), desc="runs", total=3)) == [0, 1, 2]
    assert "runs" in capsys.readouterr().err  # tqdm's text bar outside a notebook
