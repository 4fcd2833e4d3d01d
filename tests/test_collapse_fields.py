"""Depth profiles and erosion waves (post.profiles, post.waves) on constructed grains and curves,
whose answers are known by construction; and the study's fields settings."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from orchestrator.case import CaseError
from orchestrator.post import profiles as pf
from orchestrator.post import waves as wv
from orchestrator.results import read_results
from orchestrator.studies.collapse.record import render_section, row_record, runout_order
from orchestrator.studies.collapse.spec import parse_collapse
from orchestrator.studies.collapse.study import run_collapse

D = 0.001  # m: the grains of the study's 2D simulations
HEX = math.pi / (2 * math.sqrt(3))  # solid fraction of equal discs in a triangular lattice, 0.9069


def triangular_packing(length: float, height: float, base: float = 0.0, d: float = D) -> np.ndarray:
    """(N, 2) centres (x, z) of touching equal discs in rows d√3/2 apart, the lowest resting on `base`."""
    rows = np.arange(base + d / 2, base + height - d / 2 + 1e-12, d * math.sqrt(3) / 2)
    return np.array([(x + (d / 2 if k % 2 else 0.0), z) for k, z in enumerate(rows) for x in np.arange(d / 2, length, d)])


def test_solid_fraction_of_a_triangular_packing() -> None:
    """Equal discs in a triangular lattice cover π/(2√3) = 0.9069 of the plane. Averaged over whole
    rows (layers of one row spacing, away from the free surface and the base), the profile gives it
    within 2 %; the window (40 d) holds whole periods of the lattice, so the error is the lattice's
    phase in the window only."""
    centres = triangular_packing(0.1, 0.02)
    radii = np.full(len(centres), D / 2)
    edges = np.arange(0.0, 0.02, D * math.sqrt(3) / 2) + D / 2 - D * math.sqrt(3) / 4
    _, fraction = pf.station_profile(centres[:, 0], centres[:, 1], np.zeros(len(centres)), radii, 0.05, 0.04, edges, planar=True)
    assert np.mean(fraction[3:-3]) == pytest.approx(HEX, rel=0.02)
    assert np.all(np.abs(fraction[3:-3] - HEX) < 0.02 * HEX)


def test_solid_fraction_of_a_cubic_packing_of_spheres() -> None:
    """3D: spheres on a simple cubic lattice fill π/6 = 0.5236 of space; with layers of one d centred
    on the lattice planes every interior layer holds exactly that (within 2 %)."""
    grid = np.arange(D / 2, 0.02, D)
    centres = np.array([(x, z) for x in grid for z in grid[:15]])
    depth = D  # one sphere across: the channel's width
    radii = np.full(len(centres), D / 2)
    edges = np.arange(0.0, 0.0151, D)
    _, fraction = pf.station_profile(centres[:, 0], centres[:, 1], np.zeros(len(centres)), radii, 0.01, 0.01, edges, planar=False, depth=depth)
    assert np.allclose(fraction, math.pi / 6, rtol=0.02)


def shear_layer(profile) -> tuple[np.ndarray, np.ndarray]:
    """A triangular packing 30 d deep with u_x(z) = profile(z) per grain centre, read at one station
    in layers of d/2: (layer centres, u_x)."""
    centres = triangular_packing(0.1, 0.03)
    ux = profile(centres[:, 1])
    edges = np.arange(0.0, 0.03 + 1e-12, D / 2)
    velocity, _ = pf.station_profile(centres[:, 0], centres[:, 1], ux, np.full(len(centres), D / 2), 0.05, 0.004, edges, planar=True)
    return 0.5 * (edges[1:] + edges[:-1]), velocity


def test_a_linear_shear_profile_is_recovered() -> None:
    """u_x = γ̇ (z − z0) with γ̇ = 40 /s, z0 = 2 mm: the fit on the layers inside the packing gives γ̇
    and z0 within 2 % (the layers' measure-weighted centres differ from their mid-heights by the
    lattice's phase, a zero-mean error over the 50 layers fitted)."""
    z, ux = shear_layer(lambda h: 40.0 * (h - 0.002))
    inner = slice(4, -4)
    rate, base = pf.fit_linear_shear(z[inner], ux[inner])
    assert rate == pytest.approx(40.0, rel=0.02)
    assert base == pytest.approx(0.002, rel=0.02)


def test_an_exponential_profile_is_recovered() -> None:
    """u_x = u_s exp((z − H)/ℓ), u_s = 0.5 m/s, ℓ = 3 mm, H = 30 mm (a surface flow's creeping tail):
    u_s and ℓ within 2 % (averaging over a grain's height biases u by ≈ exp(σ²/2ℓ²) − 1 < 1 % for
    σ ≈ d/4 of centres about a layer's middle)."""
    z, ux = shear_layer(lambda h: 0.5 * np.exp((h - 0.03) / 0.003))
    inner = slice(4, -4)
    surface, length = pf.fit_exponential(z[inner], ux[inner], top=0.03)
    assert surface == pytest.approx(0.5, rel=0.02)
    assert length == pytest.approx(0.003, rel=0.02)


def test_the_dominant_wavelength_of_a_sinusoidal_trace() -> None:
    """h = 5 mm + 1.5 mm sin(2π x / 8 cm) + a slope, sampled every 1 mm over 30 cm and rounded to
    whole millimetres (the interface's resolution is one layer of d): λ within 5 % and A within 15 %
    (rounding to 1 mm takes up to 0.5 mm off a 1.5 mm crest)."""
    x = np.arange(0.0, 0.3, D)
    h = np.round((0.005 + 0.0015 * np.sin(2 * math.pi * x / 0.08 + 0.7) - 0.01 * x) / D) * D
    wavelength, amplitude = wv.dominant_wave(x, h)
    assert wavelength == pytest.approx(0.08, rel=0.05)
    assert amplitude == pytest.approx(0.0015, rel=0.15)


def test_a_flat_or_short_trace_has_no_wavelength() -> None:
    x = np.arange(0.0, 0.3, D)
    assert all(math.isnan(v) for v in wv.dominant_wave(x, np.full(len(x), 0.004)))
    assert all(math.isnan(v) for v in wv.dominant_wave(x[:5], np.sin(x[:5])))


def wavy_bed() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A triangular packing 12 d deep over 40 cm; the grains above z_i(x) = 6 mm + 2 mm sin(2π x / 8 cm)
    flow at 0.3 m/s, those below are still: (centres, u_x, radii)."""
    centres = triangular_packing(0.4, 0.012)
    level = 0.006 + 0.002 * np.sin(2 * math.pi * centres[:, 0] / 0.08)
    return centres, np.where(centres[:, 1] > level, 0.3, 0.0), np.full(len(centres), D / 2)


def test_a_sinusoidal_interface_is_traced_and_its_wavelength_measured() -> None:
    """The interface between still and flowing grains, traced every d with the h_sf rule (layers of
    one d) and measured: λ = 8 cm within 5 % (the acceptance's bound; the trace is quantised to d,
    an eighth of the 4 mm wave height) and A = 2 mm within 25 % (one layer of d is 1 mm)."""
    centres, ux, radii = wavy_bed()
    stations = np.arange(0.0105, 0.39, D)
    trace = wv.interface_trace(centres[:, 0], centres[:, 1], ux, radii, stations, D)
    wavelength, amplitude = wv.dominant_wave(stations, trace)
    assert wavelength == pytest.approx(0.08, rel=0.05)
    assert amplitude == pytest.approx(0.002, rel=0.25)


def test_layer_speeds_and_fractions_of_a_wavy_bed() -> None:
    """u1 = 0.3 m/s within 2 % and u2 below the 1 cm/s rule (the interface is quantised to layers of
    d, so a column's layer straddling the sine can put a still grain above it or a moving one below);
    Φ1 and Φ2 of the triangular packing within 10 % (the extents are counted from the quantised
    interface, the base and the top grain's edge: about half a grain per column of 12)."""
    centres, ux, radii = wavy_bed()
    stations = np.arange(0.0105, 0.39, D)
    trace = wv.interface_trace(centres[:, 0], centres[:, 1], ux, radii, stations, D)
    layers = wv.layer_speeds_and_fractions(centres[:, 0], centres[:, 1], ux, radii, stations, trace, 0.0, planar=True)
    assert layers["u1"] == pytest.approx(0.3, rel=0.02)
    assert 0.0 <= layers["u2"] < 0.01
    assert layers["phi1"] == pytest.approx(HEX, rel=0.10)
    assert layers["phi2"] == pytest.approx(HEX, rel=0.10)


def test_the_kelvin_helmholtz_threshold_matches_a_hand_computation() -> None:
    """λ = 8 cm, Φ1 = 0.5 over Φ2 = 0.6, g = 9.81: g λ / 2π = 0.12490 m²/s², Φ2/Φ1 − Φ1/Φ2 = 1.2 −
    0.83333 = 0.36667, so √(0.045798) = 0.21400 m/s. A denser flowing layer needs no shear (0)."""
    assert wv.kelvin_helmholtz_threshold(0.08, 0.5, 0.6, 9.81) == pytest.approx(0.21400, abs=5e-5)
    assert wv.kelvin_helmholtz_threshold(0.08, 0.6, 0.5) == 0.0
    assert math.isnan(wv.kelvin_helmholtz_threshold(math.nan, 0.5, 0.6))


def test_flowing_and_static_fractions_split_at_one_centimetre_per_second() -> None:
    velocity = np.array([0.0, 0.005, 0.02, 0.3, np.nan])
    fraction = np.array([0.8, 0.8, 0.6, 0.5, 0.0])
    assert pf.flowing_layer_fraction(velocity, fraction) == pytest.approx((0.55, 0.8))


@pytest.mark.parametrize("change, field", [
    ({"fields": {"stations": [0.5, 20.0]}}, "fields.stations"),
    ({"fields": {"stations": []}}, "fields.stations"),
    ({"fields": {"layer": 0.0}}, "fields.layer"),
    ({"fields": {"wave_window": -1.0}}, "fields.wave_window"),
])
def test_bad_fields_settings_name_the_field(change: dict, field: str) -> None:
    with pytest.raises(CaseError) as error:
        parse_collapse({"channel": {"length": 0.6}, **change})
    message = str(error.value)
    assert field in message and "\n" not in message.strip()


ERODIBLE = {
    "name": "tiny_erodible", "engine": "cocd", "dimension": 2,
    "column": {"length": 0.03, "height": 0.021},
    "channel": {"slope_deg": 22.0, "length": 0.1},
    "grains": {"diameter": 0.002},
    "bed": {"erodible_thickness": 0.004},
    "contacts": {"mu": 0.9},
    "preparation": {"settle_time": 0.15},
    "release": {"duration": 0.4, "output_interval": 0.01},
    "fields": {"stations": [0.3, 1.0, 2.0], "wave_window": 2.0},
    "cocd_step": 0.001,
    "cocd": {"solver": "piqp", "tolerance": 1e-8},
}


@pytest.fixture(scope="module")
def erodible(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, dict, Path]:
    """A 2D column of ≈ 170 discs collapsing at 22° onto a 4 mm erodible layer (2 grains) on cocd."""
    root = tmp_path_factory.mktemp("fields")
    report = run_collapse(parse_collapse(ERODIBLE), root / "study", preparations=root / "preparations")
    return report, dict(np.load(root / "study" / "profiles.npz")), root / "study"


@pytest.mark.engine
def test_a_2d_cocd_run_weighs_its_grains_as_discs(erodible: tuple) -> None:
    """2D cocd grains are discs of unit thickness: mass ρ π r² per metre (not 4/3 ρ π r³)."""
    _, _, directory = erodible
    trajectory = read_results(directory / "run" / "results.h5")
    assert np.allclose(trajectory.mass, 2500.0 * math.pi * trajectory.radius**2, rtol=1e-12)


@pytest.mark.engine
def test_profiles_at_the_stations(erodible: tuple) -> None:
    """At release the bed downstream of the gate is still (u_x = 0) and packed up to its initial
    level: its mean Φ at each station is that of a rain of 10 % polydisperse discs, 0.75–0.91 (the
    triangular lattice's 0.907 the upper bound; a 2 cm window of 2 mm grains holds ≈ 10 grains per
    layer); the flow then passes the first station (0.9 cm past the gate) faster than 10 cm/s, and
    its flowing layer is looser than the bed it runs on."""
    report, arrays, _ = erodible
    fields = report["fields"]
    z, ux, phi = arrays["profile_z"], arrays["profile_ux"], arrays["profile_phi"]
    assert ux.shape == phi.shape == (3, len(arrays["time"]), len(z))
    shown = len(fields["z"])  # report.json: the same profiles up to the highest layer reached
    assert 0 < shown <= len(z) and np.asarray(fields["phi"]).shape == (3, len(arrays["time"]), shown)
    assert np.allclose(np.asarray(fields["phi"], dtype=float), phi[:, :, :shown], atol=1e-4)
    assert np.allclose(arrays["stations"], [0.009, 0.03, 0.06])
    assert fields["initial_bed_level"] == pytest.approx(0.006)
    inside = (z > 0.002 + 0.001) & (z < 0.006 - 0.001)  # the erodible layer, a grain radius from its edges
    assert np.all((phi[:, 0, inside].mean(axis=1) > 0.75) & (phi[:, 0, inside].mean(axis=1) < 0.91))
    assert np.nanmax(np.abs(ux[:, 0])) == 0.0
    assert np.nanmax(ux[0]) > 0.1
    flowing = [v for v in fields["flowing_fraction"][0] if v is not None]
    static = [v for v in fields["static_fraction"][0] if v is not None]
    assert flowing and static and np.median(flowing) < np.median(static)


@pytest.mark.engine
def test_the_interface_is_traced_behind_the_front(erodible: tuple) -> None:
    """h_sf(x, t) is traced only in the window behind the front and lies between the base plane and
    the flow's top; the waves' report carries a wavelength and amplitude per frame, and the Kelvin–
    Helmholtz inputs at the frame of the largest waves when there is one."""
    report, arrays, _ = erodible
    interface, x = arrays["interface"], arrays["interface_x"]
    front = np.asarray(report["front"]["position"])
    traced = np.isfinite(interface)
    assert traced.any()
    frames, slices = np.nonzero(traced)
    assert np.all(x[slices] <= front[frames] + 1e-12)
    assert np.all(x[slices] >= front[frames] - report["fields"]["waves"]["window"] - 1e-12)
    assert np.nanmin(interface) >= 0.0 and np.nanmax(interface) <= 0.021 + 0.004
    waves = report["fields"]["waves"]
    assert len(waves["wavelength"]) == len(waves["amplitude"]) == len(front)
    assert isinstance(waves["wavelength_resolved"], bool)
    if waves["frame"] is not None:
        kh = waves["kelvin_helmholtz"]
        assert kh["u1"] > kh["u2"]
        assert 0.0 < kh["phi1"] <= 1.0 and 0.0 < kh["phi2"] <= 1.0
        assert arrays["wave_grains"].shape[1] == 5


@pytest.mark.engine
def test_a_row_record_reads_the_finished_run(erodible: tuple) -> None:
    """`demorch collapse record`'s reader: the run's runout, grains and engine wall time, and the
    runout at the study's times (t √(R0/20 cm) here) read off the front curve."""
    report, _, directory = erodible
    record = row_record([directory])
    run = record["runs"][0]
    assert record["time_scale"] == pytest.approx(math.sqrt(0.03 / 0.20))
    assert run["runout_over_R0"] == report["runout_over_R0"] and run["grains"] == report["grains"]
    assert run["cost_s"]["release"] > 0.0 and run["cost_s"]["preparation"] > 0.0
    front = report["front"]
    t = 0.5 * record["time_scale"]
    assert run["runout_at_study_times"]["0.5"] == pytest.approx(np.interp(t, front["time"], front["position"]) / 0.03)
    assert run["runout_at_study_times"]["2"] is None  # 2 s of the study's clock is 0.77 s here, past the 0.4 s run


def row(thickness: float, runout: float) -> dict:
    return {"erodible_thickness": thickness, "runout_over_R0": runout, "reached_end": False,
            "grains": {"column": 100, "bed": 50}, "cost_s": {"preparation": 60.0, "release": 120.0},
            "runout_at_study_times": {"0.5": 1.0, "1": None},
            "front": {"v_max": 0.5, "slow_phase": True, "v_slow": 0.1},
            "waves": {"median_wavelength": 0.04, "median_wavelength_half_window": 0.02, "wavelength_resolved": False,
                      "amplitude_at_frame": 0.0015, "kelvin_helmholtz": {"shear": 0.2, "threshold": 0.1}}}


def test_the_row_section_states_the_order_and_the_gap() -> None:
    """The validation page's section: the order of the final runouts, the 3 → 5 mm gap against the
    study's 1.10 R0 at 22°, and the slow phase at 10 mm against 20 cm/s scaled by √(R0/20 cm)."""
    record = {"recorded": "2026-12-01", "engine": "cocd", "dimension": 2, "slope_deg": 22.0, "step": 0.001,
              "column": {"length": 0.05, "height": 0.035}, "grains": {"diameter": 0.001}, "contacts": {"mu": 0.9},
              "time_scale": 0.5, "runs": [row(0.0, 4.0), row(0.003, 3.5), row(0.005, 4.5), row(0.010, 5.0)]}
    assert runout_order(record) == "3 < 0 < 5 < 10 mm"
    text = "\n".join(render_section(record))
    assert "Gap r_f(5 mm) − r_f(3 mm): +1.00 R0 (the study at 22°: +1.10 R0)" in text
    assert "0.100 m/s against the study's 0.2 m/s × 0.500 = 0.100 m/s" in text
    assert "4.0 / 2.0 (follows the window)" in text
    assert "| 3.0 |" in text  # minutes: one of rain, two of release
