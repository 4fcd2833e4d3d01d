"""The bilinear law: the Python reference, the compiled LIGGGHTS plugin against it, the build cache."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from orchestrator.contact.law import BilinearNormal, tangential_step

from conftest import requires_liggghts

KN, EN2 = 1e5, 0.3


def test_reference_cycle_restores_en2_of_the_energy() -> None:
    """Load to h_m then unload: stored k h_m²/2, returned e_n² k h_m²/2."""
    law = BilinearNormal(KN, EN2)
    up = np.linspace(0, 1e-5, 1001)[1:]
    down = up[::-1][1:]
    loading = [law.step(h) for h in up]
    unloading = [law.step(h) for h in down]
    stored = np.trapezoid(loading, up)
    returned = np.trapezoid(unloading[::-1], down[::-1])
    # The first unloading sample is one step below h_m: that strip, 2 Δh/h_m = 0.2 % here, is missing.
    assert returned / stored == pytest.approx(EN2, rel=3e-3)
    assert law.step(-1e-9) == 0.0 and law.force == 0.0  # contact lost: history reset


def test_reference_partial_unload_then_reload() -> None:
    law = BilinearNormal(KN, EN2)
    assert law.step(1e-5) == pytest.approx(1.0)
    assert law.step(0.6e-5) == pytest.approx(EN2 * KN * 0.6e-5)  # jumps onto the unloading line
    assert law.step(0.8e-5) == pytest.approx(EN2 * KN * 0.6e-5 + KN * 0.2e-5)  # reloads with k_n


def test_tangential_spring_is_capped_by_coulomb() -> None:
    force = tangential_step(np.zeros(3), np.array([1.0, 0.0, 0.0]), 1e-3, 1e4, 0.5, 100.0)
    assert force == pytest.approx([10.0, 0.0, 0.0])
    capped = tangential_step(force, np.array([10.0, 0.0, 0.0]), 1e-3, 1e4, 0.5, 100.0)
    assert np.linalg.norm(capped) == pytest.approx(50.0)


DECK = """atom_style granular
atom_modify map array
boundary f f f
newton off
communicate single vel yes
units si
region box block -0.02 0.02 -0.02 0.02 -0.02 0.02 units box
create_box 2 box
fix kn all property/global kn peratomtypepair 2 {kn} {kn} {kn} {kn}
fix kt all property/global kt peratomtypepair 2 4e4 4e4 4e4 4e4
fix mu all property/global coefficientFriction peratomtypepair 2 0.5 0.5 0.5 0.5
fix en all property/global coefficientRestitutionSquared peratomtypepair 2 {en2} {en2} {en2} {en2}
pair_style gran model bilinear tangential history
pair_coeff * *
neighbor 0.002 bin
neigh_modify delay 0
timestep 1e-6
create_atoms 1 single 0.0 0.0 0.0 units box
create_atoms 1 single 0.0 0.0 0.01 units box
set atom 1 diameter 0.01 density 2500
set atom 2 diameter 0.01 density 2500
group moving id 2
# Prescribed displacement of the upper sphere (no integration): approach 10 um, back off 4 um,
# approach 8 um, then leave; one step moves 0.1 um.
variable s equal step
variable dz equal 1e-6-((v_s<=110)*v_s+(v_s>110)*(v_s<=150)*(220-v_s)+(v_s>150)*(v_s<=230)*(v_s-80)+(v_s>230)*(380-v_s))*1e-7
fix prescribed moving move variable NULL NULL v_dz NULL NULL NULL
dump d all custom 1 dump.txt id z fz
dump_modify d sort id format "%d %.17g %.17g"
run 400
"""


@requires_liggghts
@pytest.mark.engine
def test_compiled_model_matches_the_reference_at_every_step(tmp_path: Path) -> None:
    import subprocess

    from orchestrator.engines.liggghts.plugin import ensure_plugin, liggghts_env

    (tmp_path / "in.deck").write_text(DECK.format(kn=KN, en2=EN2))
    env = {**__import__("os").environ, **liggghts_env(ensure_plugin())}
    result = subprocess.run(["liggghts", "-in", "in.deck"], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout[-2000:]
    assert "WARNING" not in result.stdout  # the plugin replaces none of the engine's styles
    frames = _frames(tmp_path / "dump.txt")
    overlap = 0.01 - frames[:, 1, 1]
    force = frames[:, 1, 2]
    law = BilinearNormal(KN, EN2)
    expected = np.array([law.step(h) for h in overlap])
    assert np.any(np.diff(overlap) < 0) and force.max() > 0.9  # the cycle was loaded and unloaded
    assert np.max(np.abs(force - expected)) <= 1e-9 * force.max()  # ≤ 1e-9 relative


def _frames(path: Path) -> np.ndarray:
    blocks = path.read_text().split("ITEM: TIMESTEP\n")[1:]
    return np.array([np.array(b.split("\n", 8)[8].split(), dtype=float).reshape(-1, 3) for b in blocks])


@pytest.mark.engine
@requires_liggghts
def test_build_is_cached_outside_the_clone(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from orchestrator.engines.liggghts import plugin as contact_build

    monkeypatch.setenv("DEMORCH_CACHE", str(tmp_path / "cache"))
    started = time.perf_counter()
    first = contact_build.ensure_plugin()
    cold = time.perf_counter() - started
    built_at = first.stat().st_mtime_ns
    started = time.perf_counter()
    second = contact_build.ensure_plugin()
    warm = time.perf_counter() - started
    assert first == second and second.stat().st_mtime_ns == built_at  # not rebuilt
    assert str(first).startswith(str(tmp_path / "cache"))
    assert warm < cold
    print(f"plugin build: cold {cold:.2f} s, warm {warm:.3f} s")


@pytest.mark.engine
@requires_liggghts
def test_the_compiled_law_is_the_same_whatever_the_neighbour_list_rebuilds(tmp_path: Path) -> None:
    """Five spheres colliding (pairs meet, part and meet again): LIGGGHTS' own neighbour-list
    rebuilds and a rebuild at every step give the same run to the bit. A pair's history must be
    cleared when it parts, not only when the list is rebuilt (before the deck's
    contact_distance_factor, 0.43 mm apart after 0.6 s)."""
    from orchestrator.engines import RunOptions, get_adapter
    from orchestrator.plan import make_plan
    from test_checkpoint import colliding_spheres

    case = colliding_spheres("liggghts", "bilinear")
    runs = []
    for every_step in (False, True):
        directory = tmp_path / str(every_step)
        directory.mkdir()
        adapter = get_adapter("liggghts", RunOptions(checkpoint_interval=0))
        plan = make_plan(case, tmp_path)
        deck = adapter.write_input(plan, directory)
        if every_step:
            deck.write_text(deck.read_text().replace("neigh_modify    delay 0", "neigh_modify    delay 0 every 1 check no", 1))
        adapter.execute(plan, directory)
        runs.append(adapter.read_output(plan, directory))
    assert "every 1 check no" in deck.read_text()
    assert np.array_equal(runs[0].position, runs[1].position)
