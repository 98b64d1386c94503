"""``evomesh mesh --resample`` (issue 17): a digitised boundary meshed at its size locally,
and the flags as service inputs."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from service.cli import main
from service.cli.control_flags import add_control_flags, control_inputs


def test_local_mesh_resamples_a_dense_circle(tmp_path: Path) -> None:
    t = np.linspace(0.0, 2.0 * np.pi, 5000, endpoint=False)
    region = tmp_path / "circle.json"
    region.write_text(json.dumps({"outer": np.c_[np.cos(t), np.sin(t)].tolist()}))
    out = tmp_path / "circle.out.json"
    args = ["mesh", str(region), "--size", "0.2", "--smooth", "none", "-o", str(out)]
    assert main([*args, "--resample", "--resample-tolerance", "0.01"]) == 0
    doc = json.loads(out.read_text())
    assert len(doc["points"]) < 200  # not the 5,000 input vertices
    assert 0 < doc["summary"]["smoothed"]["boundary"]["max_deviation"] <= 0.01
    assert main(args) == 0
    assert len(json.loads(out.read_text())["points"]) >= 5000


def test_the_resample_flags_become_service_inputs() -> None:
    p = argparse.ArgumentParser()
    add_control_flags(p)
    args = p.parse_args(["--resample", "--resample-tolerance", "0.5"])
    assert control_inputs(args) == {"resample": True, "resample_tolerance": 0.5}
    with pytest.raises(ValueError, match="resample-tolerance"):
        control_inputs(p.parse_args(["--resample-tolerance", "-1"]))
