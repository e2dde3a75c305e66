"""scripts/bench_blender.py: argument checks and the missing-Blender message always;
a short run of both engines when Blender's Python module is installed."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "bench_blender.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_blender", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_bad_arguments_exit_with_usage(bench):
    with pytest.raises(SystemExit) as e:
        bench.main(["--scenes", "middle"])
    assert e.value.code == 2
    with pytest.raises(SystemExit):
        bench.main(["--frames", "0"])


def test_missing_blender_is_reported(monkeypatch, capsys, bench):
    monkeypatch.setitem(sys.modules, "bpy", None)  # makes `import bpy` fail
    assert bench.main(["--scenes", "center", "--resolution", "5", "--frames", "2"]) == 2
    assert "bpy" in capsys.readouterr().err


def test_both_engines_simulate_the_scene(bench, capsys):
    pytest.importorskip("bpy")
    row = bench.run_scene(sys.modules["bpy"], "center", 9, 20)
    assert row["triangles"] == 128 and row["selfcd_ms"] > 0 and row["blender_ms"] > 0
    # both cloths fall about the centre pin
    assert row["selfcd_final_mean_z"] < -0.01 and row["blender_final_mean_z"] < -0.01
    assert row["selfcd_max_intersections"] == 0
    assert "| center | 128 | 20 |" in bench.table([row])
