"""The pre-flight output estimate covers what a run writes and holds: checked against a real run."""

from __future__ import annotations

import itertools
import resource
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from orchestrator import estimate
from orchestrator.case import CaseError, parse_case
from orchestrator.plan import make_plan
from orchestrator.runner import run_case

from conftest import requires_liggghts

REPO = Path(__file__).resolve().parent.parent


def touching_spheres(duration: float = 0.004) -> dict:
    """200 spheres stacked in contact on a floor, a frame every step, every contact recorded."""
    radius, spacing = 0.005, 0.00999
    spheres = [{"material": "glass", "radius": radius, "position": [i * spacing, j * spacing, 0.999 * radius + k * spacing]}
               for i, j, k in itertools.product(range(8), range(5), range(5))]
    pair = {"en2": 0.5, "mu": 0.5, "kn": 1e5, "kt_over_kn": 0.4}
    return {"name": "stack", "engine": "liggghts", "time": {"step": 2e-6, "duration": duration, "output_interval": 2e-6},
            "materials": [{"name": "glass", "density": 2500.0}, {"name": "floor", "density": 2500.0}],
            "contacts": [{"materials": ["glass", "glass"], **pair}, {"materials": ["glass", "floor"], **pair}],
            "walls": [{"type": "rectangle", "name": "base", "material": "floor", "origin": [-0.05, -0.05, 0.0],
                       "edge1": [0.2, 0.0, 0.0], "edge2": [0.0, 0.2, 0.0]}],
            "record_contacts": True, "bodies": {"spheres": spheres}}


@requires_liggghts
@pytest.mark.engine
def test_the_estimate_bounds_what_a_run_with_contacts_writes_and_holds(tmp_path: Path) -> None:
    """The estimate is an upper bound within a factor of 4 (the contact count is a dense pile's): results,
    raw engine output and the run's peak memory, measured (2001 frames of 200 spheres)."""
    (tmp_path / "stack.yaml").write_text(yaml.safe_dump(touching_spheres()))
    output = make_plan(parse_case(touching_spheres()), tmp_path).output
    subprocess.run([sys.executable, "-m", "orchestrator.cli", "run", "stack.yaml", "-o", "run"], cwd=tmp_path, check=True,
                   capture_output=True, env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(REPO)})
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
    run = tmp_path / "run"
    results = (run / "results.h5").stat().st_size
    raw = sum((run / name).stat().st_size for name in ("frames.bin", "contacts_pairs.dump", "contacts_walls.dump"))
    assert results <= output.results <= 4 * results, (results, output)
    assert raw <= output.raw <= 4 * raw, (raw, output)
    assert peak <= output.memory, (peak, output)


def test_a_run_that_would_not_fit_the_machine_is_refused_with_the_numbers(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    output = make_plan(parse_case(touching_spheres(duration=0.05)), tmp_path).output
    assert output.results > 2 * 25_001 * 200 * 104  # contacts counted, not bodies only
    monkeypatch.setattr(estimate, "machine_memory", lambda: output.memory - 1)
    with pytest.raises(CaseError, match=r"time.output_interval: the run would write 25001 frames: .* GB of memory"):
        estimate.check_machine(output, tmp_path)
    monkeypatch.setattr(estimate, "machine_memory", lambda: 2 * output.memory)
    warning = estimate.check_machine(output, tmp_path)
    assert warning is not None and warning.startswith("a large run")
    monkeypatch.setattr(estimate, "machine_memory", lambda: 100 * output.memory)
    assert estimate.check_machine(output, tmp_path) is None or output.disk > 0.25 * estimate.shutil.disk_usage(tmp_path).free


@pytest.mark.engine
def test_a_run_refused_for_the_machine_writes_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from conftest import free_fall_case

    monkeypatch.setattr(estimate, "machine_memory", lambda: 1)
    with pytest.raises(CaseError, match="of memory"):
        run_case(free_fall_case("cocd"), tmp_path, tmp_path / "run")
    assert not (tmp_path / "run" / "run.json").exists()
