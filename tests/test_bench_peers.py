"""scripts/bench_peers.py at small sizes: selfcd's side measured for real (its
pairs checked against the exact reference), peers used when importable and
reported as unavailable when not."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import selfcd

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "bench_peers.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_peers", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    yield module
    del sys.modules[spec.name]


def test_quick_run_with_installed_peers(tmp_path, bench):
    out = tmp_path / "peers.json"
    proc = subprocess.run([sys.executable, str(SCRIPT), "--quick", "--repeat", "1", "--inputs", "folded,crumpled",
                           "--no-progress", "--json", str(out)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    for title in ("Per frame", "One-shot", "Proximity", "Continuous"):
        assert title in proc.stdout
    res = json.loads(out.read_text())
    assert [r["input"] for r in res["per_frame"]] == ["folded", "crumpled"]
    crumpled = bench.load_input("crumpled", quick=True)
    reference = selfcd.reference_pairs(selfcd.Mesh(crumpled.rest, crumpled.faces), np.stack(crumpled.frames))
    frame_row, shot_row = res["per_frame"][1], res["one_shot"][1]
    assert frame_row["exact_pairs"] == [len(p) for p in reference] and min(frame_row["exact_pairs"]) > 0
    assert frame_row["bvh_vs_exact"] == [[0, 0]] * len(reference)
    assert frame_row[f"{selfcd.DEFAULT_METHOD}_ms"] > 0
    assert shot_row["exact_pairs"] == len(selfcd.self_intersections(crumpled.state, crumpled.faces))
    if "libigl_vs_exact" in shot_row:  # libigl's predicates are exact too
        assert shot_row["libigl_vs_exact"] == [0, 0]
    # only the intersection-free input gets a continuous query
    assert [r["input"] for r in res["continuous"]] == ["folded"]
    # the coherent queries ran (their answers are checked against fresh ones inside the script)
    assert all(r["selfcd_coherent_ms"] > 0 for r in res["proximity"])
    seq = res["continuous"][0]
    assert seq["seq_steps"] == len(crumpled.frames) - 1 and seq["seq_coherent_ms"] > 0
    assert seq["seq_builds"] + seq["seq_reuses"] == seq["seq_steps"]


def test_missing_peers_are_reported_unavailable(monkeypatch, capsys, bench):
    for module in ("warp", "igl", "ipctk"):
        monkeypatch.setitem(sys.modules, module, None)  # makes `import module` fail
    assert bench.main(["--quick", "--repeat", "1", "--inputs", "folded", "--tables", "one_shot,proximity",
                       "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert text.count("unavailable") == 3
    assert "| folded | 3200 |" in text
    for line in text.splitlines():
        if line.startswith("| folded"):
            assert "| - |" in line  # the peers' columns are empty


def test_unknown_input_is_refused(bench):
    with pytest.raises(SystemExit):
        bench.main(["--inputs", "nonesuch"])
