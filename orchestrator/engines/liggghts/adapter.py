"""LIGGGHTS adapter: data file + deck from the template, `liggghts -in`, text dump → Trajectory."""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path
from typing import Callable

import numpy as np

from orchestrator.case import ContactLaw
from orchestrator.plan import RunPlan
from orchestrator.post.lost import lost_bodies
from orchestrator.results import Contacts, Trajectory
from orchestrator.engines import common
from orchestrator.engines.options import RunOptions
from orchestrator.engines.liggghts import deck, plugin, superquadrics
from orchestrator.engines.liggghts.deck import (CHECKPOINT_EXT, CONTACT_PAIRS_NAME, CONTACT_WALLS_NAME, DECK_NAME, DUMP_NAME, INSTALL_HINT,
                                                TEXT_DUMP_NAME, dump_columns)
from orchestrator.engines.liggghts.dump import (binary_dump_steps, clump_states, superquadric_states, contact_rows, read_binary_dump, read_dump, read_local_dump,
                                                sphere_states)
from orchestrator.engines import checkpoint
from orchestrator.engines.checkpoint import segment_name
from orchestrator.engines.build import engine_version
from orchestrator.engines.base import LOG_NAME, AdapterDefaults, EngineError, EngineInfo, ProgressCallback, require_executable, run_engine

_THERMO_LINE = re.compile(r"^\s*(\d+)\s+(\d+)\s+(\S+)(?:\s+\S+)*\s*$")  # step atoms ke [rest sums]


_LOOP_LINE = re.compile(r"^Loop time of (\S+) on \d+ procs for (\d+) steps", re.MULTILINE)


def loop_times(log: str) -> list[tuple[float, int]]:
    """(seconds, steps) of each time loop LIGGGHTS reports in a log's text ("Loop time of …"), in
    order, the zero-step set-ups included: the engine's own cost, without start-up and set-ups."""
    return [(float(seconds), int(steps)) for seconds, steps in _LOOP_LINE.findall(log)]


class ThermoWatcher:
    """Reads thermo lines (step atoms ke): simulated time for progress and the last step; calls
    on_step(step) at each (the adapter seals and prunes its checkpoints there). Lost bodies are
    counted from the frames (post.lost), not from the atom count."""

    def __init__(self, dt: float, on_step: Callable[[int], None] | None = None):
        self.dt = dt
        self.on_step = on_step
        self.last_step = 0

    def __call__(self, line: str) -> float | None:
        match = _THERMO_LINE.match(line)
        if not match:
            return None
        step, kinetic = int(match.group(1)), match.group(3)
        self.last_step = step
        if self.on_step is not None:
            self.on_step(step)
        try:
            if not np.isfinite(float(kinetic)):
                return float("nan")
        except ValueError:
            return None
        return step * self.dt


def seal_behind(rundir: Path, total: int) -> Callable[[int], None]:
    """What to do at each thermo line of step S: seal the checkpoints of steps before S, prune the old.

    The checkpoint of step S is written by `write_restart` after the thermo line of S that ends a
    sub-run, so it is complete only once a thermo line of a later step is out (sealing at S itself
    could hash a file still being written). One written at the last step stays unsealed, as the
    other engines write none there."""
    def on_step(step: int) -> None:
        checkpoint.seal(rundir, CHECKPOINT_EXT, min(step - 1, total - 1))
        checkpoint.prune(rundir, CHECKPOINT_EXT)
    return on_step


class LiggghtsAdapter(AdapterDefaults):
    name = "liggghts"
    checkpoint_ext = CHECKPOINT_EXT

    def __init__(self, executable: str = "liggghts", mpi_processes: int = 1, processor_grid: str = "* * *",
                 max_bins: float = deck.MAX_BINS, skin_radii: float = deck.SKIN_RADII):
        """max_bins, skin_radii: neighbour-list tuning (deck.MAX_BINS, deck.SKIN_RADII: measured defaults);
        they change the speed, never a force."""
        self.executable = executable
        self.mpi_processes = mpi_processes
        self.processor_grid = processor_grid
        self.max_bins = max_bins
        self.skin_radii = skin_radii

    @classmethod
    def from_options(cls, options: RunOptions) -> "LiggghtsAdapter":
        adapter = cls(mpi_processes=options.processes(), processor_grid=options.grid())
        adapter.options = options
        return adapter

    def build_inputs(self) -> dict[str, str]:
        return {**super().build_inputs(), "plugin": plugin.build_key(),
                "superquadric_build": plugin.build_key(plugin.SUPERQUADRIC_SOURCES)}

    def law_plugin(self, force: bool = False, progress: Callable[[str], None] | None = None) -> Path:
        """The compiled bilinear law (capability `compiled_law`), built once and cached outside the
        clone; and the source-built executable that superquadric bodies run on (same cache)."""
        path = plugin.ensure_plugin(force=force, progress=progress)
        plugin.ensure_superquadric_liggghts(force=force, progress=progress)
        return path

    def law_plugin_status(self) -> dict[str, object]:
        return {**plugin.plugin_status(), "superquadric_executable": str(plugin.superquadric_executable_path()),
                "superquadric_built": plugin.superquadric_executable_path().exists()}

    def info(self) -> EngineInfo:
        return EngineInfo(
            name=self.name,
            executable=shutil.which(self.executable),
            version=engine_version(shutil.which(self.executable), ("-h",), r"LIGGGHTS \(Version ([^,)]+)"),
            install_hint=INSTALL_HINT,
        )

    # -- input -----------------------------------------------------------------------------
    def write_input(self, plan: RunPlan, rundir: Path) -> Path:
        return deck.write_deck(plan, rundir, self.processor_grid, self.max_bins, self.skin_radii, self.checkpoint_steps(plan))

    # -- run -------------------------------------------------------------------------------
    def command(self, deck: Path, executable: str | None = None) -> list[str]:
        """The engine's command line for `deck`; `executable` instead of the adapter's own when given
        (the source-built LIGGGHTS for superquadric bodies)."""
        executable = executable or require_executable(self.executable, INSTALL_HINT)
        base = [executable, "-echo", "screen", "-in", deck.name]  # echo: the log shows the failing command
        # LIGGGHTS prints its ERROR line and then calls MPI_Abort: with a block-buffered pipe the
        # message is lost. Line buffering (stdbuf, coreutils) keeps it in the log.
        stdbuf = shutil.which("stdbuf")
        if stdbuf:
            base = [stdbuf, "-oL", "-eL", *base]
        if self.mpi_processes > 1:
            mpirun = require_executable("mpirun", "apt-get install -y openmpi-bin")
            return [mpirun, "--allow-run-as-root", "--oversubscribe", "-np", str(self.mpi_processes), *base]
        return base

    def execute(self, plan: RunPlan, rundir: Path, progress: ProgressCallback | None = None, timeout: float | None = None) -> None:
        case = plan.case
        deck = rundir / segment_name(DECK_NAME, plan.segment)
        log = rundir / self.log_name(plan)
        dt, total = plan.schedule.dt, plan.schedule.total_steps
        watcher = ThermoWatcher(dt, seal_behind(rundir, total))
        env = dict(os.environ)
        executable = None
        if superquadrics.one_atom_bodies(plan):  # Debian's build has no superquadrics: the source-built one
            executable = str(plugin.ensure_superquadric_liggghts())
        elif case.law is ContactLaw.bilinear:  # the compiled law: load the plugin
            env.update(plugin.liggghts_env(plugin.ensure_plugin()))
        try:
            tail = run_engine(self.command(deck, executable), rundir, deck, watcher, total * dt, progress, env=env, timeout=timeout,
                              log_name=log.name)
        except EngineError as error:  # LIGGGHTS stops once its box is empty (write_restart): the bodies that left are the cause
            raise self._lost_instead(plan, rundir, error) from None
        # Spheres dropped from the box are NaN in the frames: the runner counts lost bodies (post.lost).
        stopped = common.at_rest_attrs(rundir, dt)
        if watcher.last_step < total and not (stopped and watcher.last_step == round(stopped["stopped_at_rest"] / dt)):
            raise EngineError(f"the run stopped at step {watcher.last_step} of {total}", deck, log, tail)

    def _lost_instead(self, plan: RunPlan, rundir: Path, error: EngineError) -> EngineError:
        """The bodies lost by the frames written (post.lost) as the failure, when there are any; else `error`."""
        try:
            lost = lost_bodies(self.read_output(plan, rundir), plan.domain.lower, plan.domain.upper)
        except (EngineError, OSError, ValueError):
            return error
        return EngineError(lost.message(), error.deck, error.log, error.tail) if len(lost) else error

    # -- output ----------------------------------------------------------------------------
    def read_output(self, plan: RunPlan, rundir: Path) -> Trajectory:
        case = plan.case
        deck = rundir / DECK_NAME
        dt = plan.schedule.dt
        if (rundir / DUMP_NAME).exists():
            columns = list(dump_columns(plan))
            steps, frames = checkpoint.merge([read_binary_dump(path, len(columns)) for path in checkpoint.segment_files(rundir, DUMP_NAME)])
        else:
            steps, columns, frames = read_dump(rundir / TEXT_DUMP_NAME)
        if not frames:
            raise EngineError("the engine wrote no dump frames", deck, rundir / LOG_NAME)
        column = {name: i for i, name in enumerate(columns)}
        if "id_multisphere" in column:
            position, velocity, spin, orientation, atom_slot = clump_states(plan, column, frames)
            ids = np.arange(1, len(case.bodies.clumps) + 1)
        elif "quat1" in column:  # superquadrics: one atom per body, atom id = body index + 1
            ids = np.arange(1, len(case.bodies.clumps) + 1)
            position, velocity, spin, orientation = superquadric_states(ids, column, frames)
            atom_slot = np.full(len(ids) + 1, -1, dtype=np.int64)
            atom_slot[ids] = np.arange(len(ids))
        else:
            ids = frames[0][:, 0].astype(np.int64)
            position, velocity, spin = sphere_states(ids, column, frames)
            orientation = np.full(position.shape[:2] + (4,), np.nan)
            atom_slot = np.full(int(ids.max()) + 1, -1, dtype=np.int64)
            atom_slot[ids] = np.arange(len(ids))
        return Trajectory(
            time=np.asarray(steps, dtype=float) * dt,
            ids=ids,
            material=plan.materials(),
            mass=plan.masses(),
            radius=plan.radii(),
            inertia=plan.inertia(),
            position=position,
            velocity=velocity,
            angular_velocity=spin,
            orientation=orientation,
            attrs={"orientation_tracked": "id_multisphere" in column or "quat1" in column, **common.at_rest_attrs(rundir, dt)},
            contacts=self.read_contacts(plan, rundir, steps, atom_slot) if case.record_contacts else None,
        )

    @staticmethod
    def read_contacts(plan: RunPlan, rundir: Path, steps: list[int], atom_slot: np.ndarray) -> Contacts:
        """The contacts of each dumped frame (steps), from the deck's two `dump local` files. A wall's
        mesh number is its place among the walls present at that step (removed walls leave `fix walls`)."""
        pairs, walls = (_merged_local_dumps(rundir, name) for name in (CONTACT_PAIRS_NAME, CONTACT_WALLS_NAME))
        frames = []
        for step in steps:
            present = [i for i, wall in enumerate(plan.case.walls) if plan.removals.get(wall.name, step) >= step]
            frames.append(contact_rows(pairs.get(step), walls.get(step), atom_slot, present))
        return Contacts.from_frames(frames)

    def usable_checkpoints(self, plan: RunPlan, rundir: Path) -> list[tuple[int, Path]]:
        """Not those at a wall removal step: LIGGGHTS rebuilds its wall fix there, and a run
        continued from that instant departs from the uninterrupted one (measured 2026-11-30: 1e-7 m,
        2.5e-4 m/s on spheres resting on the wall that stays); from any other step it is exact."""
        removals = set(plan.removals.values())
        return [(step, path) for step, path in super().usable_checkpoints(plan, rundir) if step not in removals]

    def last_frame_step(self, plan: RunPlan, rundir: Path) -> int | None:
        columns = len(dump_columns(plan))
        pieces = [binary_dump_steps(path, columns) for path in checkpoint.segment_files(rundir, DUMP_NAME)]
        steps, _ = checkpoint.merge([(piece, piece) for piece in pieces])
        return steps[-1] if steps else None


def _merged_local_dumps(rundir: Path, name: str) -> dict[int, np.ndarray]:
    """step → rows of every segment's `dump local` file of `name`, merged like the frames."""
    pieces = [(list(found), list(found.values())) for found in (read_local_dump(path) for path in checkpoint.segment_files(rundir, name))]
    steps, rows = checkpoint.merge(pieces)
    return dict(zip(steps, rows))
