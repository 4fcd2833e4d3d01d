"""Output writers never follow a link out of their output directory (results.safe_output_path): a
symbolic or hard link under a name they write is replaced by a new file. `demorch paraview`'s own
test is in test_paraview.py; here the helper and the avalanche study's report/."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import yaml

from orchestrator.results import RELEASE_DIR, RESULTS, Trajectory, safe_output_path, write_results
from orchestrator.studies.avalanche import report as pictures

REPO = Path(__file__).resolve().parent.parent


def test_a_safe_output_path_is_one_entry_of_its_directory(tmp_path: Path) -> None:
    outside = tmp_path / "outside.txt"
    outside.write_text("precious")
    out = tmp_path / "out"
    out.mkdir()
    (out / "own.txt").write_text("kept")
    (out / "symbolic").symlink_to(outside)
    os.link(outside, out / "hard")
    (out / "folder").mkdir()
    assert safe_output_path(out, "own.txt").read_text() == "kept"  # a file of its own is written over in place
    for name in ("symbolic", "hard"):
        safe_output_path(out, name).write_text("new")
    assert outside.read_text() == "precious" and (out / "symbolic").read_text() == "new" and not (out / "symbolic").is_symlink()
    assert safe_output_path(out, "folder").is_dir() and safe_output_path(out, "missing") == out / "missing"
    for name in ("", ".", "..", "../x", "a/b", "/etc/passwd"):
        with pytest.raises(ValueError, match="is not a file name"):
            safe_output_path(out, name)


def test_the_study_report_replaces_links_in_report(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """report/ a link, or links in it under the names its writers use: the figures, the VTK and
    index.html land in the study directory, the links' targets are untouched."""
    frames, bodies = 3, 2
    trajectory = Trajectory(time=np.arange(frames) * 0.1, ids=np.arange(bodies), material=np.array(["brick"] * bodies),
                            mass=np.full(bodies, 6e-3), radius=np.full(bodies, 0.017), inertia=np.full((bodies, 3), 1e-7),
                            position=np.tile([[[0.1, 0.0, 0.01], [0.2, 0.0, 0.01]]], (frames, 1, 1)), velocity=np.zeros((frames, bodies, 3)),
                            angular_velocity=np.zeros((frames, bodies, 3)), orientation=np.tile([1.0, 0.0, 0.0, 0.0], (frames, bodies, 1)))
    study = tmp_path / "study"
    (study / RELEASE_DIR).mkdir(parents=True)
    write_results(study / RELEASE_DIR / RESULTS, trajectory)
    report = {"study": yaml.safe_load((REPO / "cases" / "avalanche" / "small.yaml").read_text())}
    for name in ("plot_deposit", "plot_front", "plot_force_chains"):  # what they draw is beside the point: they write by name
        monkeypatch.setattr(pictures, name, lambda *arguments, **options: arguments[-2 if len(arguments) > 2 else -1].write_text("figure"))
    monkeypatch.setattr(pictures, "study_rows", lambda *arguments: [])
    outside = tmp_path / "outside.txt"
    outside.write_text("precious")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (study / "report").symlink_to(elsewhere, target_is_directory=True)
    pictures.write_report(study, report)
    assert not (study / "report").is_symlink() and not list(elsewhere.iterdir())
    for name in ("index.html", "deposit.png", "bodies_0000.vtu", "snapshot_0000.png"):
        (study / "report" / name).unlink()
        (study / "report" / name).symlink_to(outside)
    page = pictures.write_report(study, report)
    assert outside.read_text() == "precious" and page == study / "report" / "index.html"
    assert not any(path.is_symlink() for path in (study / "report").iterdir())
